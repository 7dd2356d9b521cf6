"""Command line: plan fence pushes that take a polygonal part from one pose to another.

Usage::

    nudge plan-push PART.yaml|PLATE.dxf|PART.stl --start X,Y,THETA --goal X,Y,THETA
        [--units mm] [--face -z] [--margin-deg 7] [--safety-factor 1.15] [--objective distance|pushes]
        [--solver closed_form|cvxpy] [--strategy search|paper] [--support-c LO HI]
        [--support any|rigid|uniform|ring]
        [--min-fence-mu MU] [--workspace XMIN XMAX YMIN YMAX]
        [--max-reorients N] [--extra-steps N]
        [--json] [--plot FILE.png] [--psd FILE.png]
    nudge plan-push PART --start any --region XMIN,XMAX,YMIN,YMAX --goal X,Y,THETA
        [--start-heading LO,HI] [--max-stroke M] [...]

The part: a part file (:mod:`sweeps.partfile`), a bundled part's name, or a
CAD file given directly (:mod:`sweeps.cad`): a DXF outline, or a mesh's
footprint resting on ``--face`` (``-z`` default, or a hull face number), read in
``--units`` (else the file's own unit, else metres; a file with no unit whose
size is implausible in metres is refused).

Poses are ``x,y,theta`` in metres and radians (world frame; ``(x, y)`` is the
centre of mass); ``theta`` may carry a ``deg`` suffix (``0.1,0,90deg``) or a
``rad`` one.  A pose may start with a minus sign (``--start -0.1,0,0``).
``--psd`` alone (no ``--start``/``--goal``) only draws the part's push
stability diagram; with a plan it marks the plan's reorient steps.

Options of :func:`planning.plan_pose`: ``--strategy`` (the reorientation
sequences searched), ``--support-c LO HI`` (the support's limit-surface ratio
range in metres: reorient distances from the quasi-static model instead of
Peshkin's bound), ``--min-fence-mu`` (slip-aware plans: every reorient push
sticks at the fence for every ``c`` in that range; needs ``--support-c``) and
``--workspace XMIN XMAX YMIN YMAX`` (metres, world frame: every pose and the
part swept by every push stay inside), and the search's effort:
``--max-reorients N`` (no plan has more reorient pushes, default 24) and
``--extra-steps N`` (each reorientation run tries the fewest steps up to N more,
default 3).  A figure's file type comes from its suffix (``.png``, ``.pdf``,
``.svg``, ...), checked before any work.

Sensorless posing (issue 40): ``--start any`` with ``--region XMIN,XMAX,YMIN,YMAX``
(metres, world frame) plans from an unknown heading (or one in ``--start-heading
LO,HI``, radians or ``deg``) at an unknown position in the region: the shortest
orienting funnel (Goldberg 1993), one register push, then the pose plan, as one
list of fence pushes (each a direction and the fence's final line), replayed
exactly from a grid of 360 headings x 9 positions before it is printed; the
table's ``phase`` column says which pushes orient, register and pose.
``--max-stroke M`` bounds each fence's run (m): a region too large for it is
refused (exit 1).  ``--psd`` then draws the push function with the funnel.

Output: the plan's summary table, or with ``--json`` the plan as JSON
(:meth:`planning.pushing.plan.PushPlan.to_dict`) and nothing else on stdout.
Messages go to stderr.  Exit status: 0 success, 1 no plan found
(:class:`~planning.pushing.planner.PlanningError`), 2 bad input (one line
``error: ...`` naming the field), 3 internal error (``NUDGE_DEBUG=1`` for the
traceback).
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import warnings
from typing import Optional, Sequence

from planning import PushOptions   # the door imports no JAX (kernels.open_door)
from sweeps.errors import Exit, UserError
from sweeps.terminal import (EFFORT_BOUNDS, InputError, Parser, check_figure_path, fail,
                             join_negative_values, load_part_of_kind, report_part,
                             report_warnings)
from sweeps.terminal import parse_pose as _parse_pose



def parse_pose(text: str, field: str) -> tuple[float, float, float]:
    """Parse ``x,y,theta`` (m, m, rad; ``theta`` may end in ``deg`` or ``rad``).

    Raises:
      InputError: the message names ``field`` and shows the expected form.
    """
    return _parse_pose(text, field)


def build_parser(prog: str = "nudge plan-push") -> argparse.ArgumentParser:
    p = Parser(
        prog=prog,
        description="Plan normal fence pushes (Akella & Mason 1992) that take a polygonal part "
                    "from a start pose to a goal pose, and optionally draw the plan and the "
                    "part's push stability diagram.",
        epilog="Poses: x,y,theta in metres and radians, world frame, (x, y) = centre of mass; "
               "theta may end in 'deg' (e.g. 0.1,0,90deg). Lengths (--support-c, --workspace) "
               "in metres. Exit status: 0 ok, 1 no plan, 2 bad input.")
    p.add_argument("part", metavar="PART.yaml", help="part file (see sweeps.partfile), a bundled "
                   "part's name, or a CAD file: a DXF outline or a mesh (STL, OBJ, PLY: its footprint)")
    p.add_argument("--units", metavar="UNIT", default=None,
                   help="a CAD file's unit (m, cm, mm, um, in); default: the file's own, else metres")
    p.add_argument("--face", metavar="FACE", default=None,
                   help="a mesh's face it rests on: -z (default), +z, -x, ... or a hull face number")
    p.add_argument("--start", metavar="X,Y,THETA", help="start pose (m, m, rad or ...deg), or "
                   "'any' (unknown heading and position: needs --region)")
    p.add_argument("--region", metavar="XMIN,XMAX,YMIN,YMAX",
                   help="with --start any: the start positions of the centre of mass (m, world)")
    p.add_argument("--start-heading", metavar="LO,HI",
                   help="with --start any: the start headings lie in [LO, HI] (rad or ...deg)")
    p.add_argument("--max-stroke", type=_number("--max-stroke"), metavar="M",
                   help="with --start any: the longest run of a fence (m, > 0)")
    p.add_argument("--goal", metavar="X,Y,THETA", help="goal pose (m, m, rad or ...deg)")
    _option_flags(p)
    p.add_argument("--json", action="store_true", help="print the plan as JSON on stdout")
    p.add_argument("--plot", metavar="FILE.png", help="draw the plan (Akella-Mason Fig. 1)")
    p.add_argument("--psd", metavar="FILE.png",
                   help="draw the push stability diagram (Fig. 6, normal pushes); with a plan, "
                        "its reorient steps are marked")
    return p


def _flag(field: str) -> str:
    """The command-line flag of a :class:`planning.PushOptions` field."""
    return "--" + field.replace("_", "-")


def _default_note(value) -> str:
    if value is None:
        return ""
    return f" (default {value:g})" if isinstance(value, float) else f" (default {value})"


def _option_flags(p: argparse.ArgumentParser) -> None:
    """A flag for each field of :class:`planning.PushOptions` (its name, default,
    choices, value names and text are the field's; the door imports no JAX):
    ``--margin-deg DEG`` ... ``--extra-steps N``.  The support is two flags:
    ``--support`` (any or a family) and ``--support-c LO HI`` (a ``c`` range)."""
    for f in dataclasses.fields(PushOptions):
        flag, meta = _flag(f.name), f.metadata
        text = meta["doc"] + _default_note(f.default)
        if f.name == "support":
            p.add_argument(flag, choices=meta["choices"], default=None,
                           help=text + "; not with --support-c")
            p.add_argument(flag + "-c", nargs=len(meta["symbol"]), type=_number(flag + "-c"),
                           metavar=meta["symbol"], help="the support's c range (see --support)")
        elif "choices" in meta:
            p.add_argument(flag, choices=meta["choices"], default=f.default, help=text)
        elif isinstance(meta["symbol"], tuple):
            p.add_argument(flag, nargs=len(meta["symbol"]), type=_number(flag),
                           metavar=meta["symbol"], default=f.default, help=text)
        else:
            kind = _integer if isinstance(f.default, int) else _number
            p.add_argument(flag, type=kind(flag), default=f.default, metavar=meta["symbol"],
                           help=text)


def _number(flag: str):
    """argparse type: a finite float, else one error line naming ``flag``."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
        if not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
        return value

    parse.__name__ = flag   # argparse names the flag in its message
    return parse


def _integer(flag: str):
    """argparse type: an integer in ``EFFORT_BOUNDS`` of the setting ``flag`` names,
    else one error line naming ``flag``."""
    lo, hi = EFFORT_BOUNDS[flag.lstrip("-").replace("-", "_")]

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"expected an integer {lo}..{hi}, got {text!r}")
        return value

    parse.__name__ = flag
    return parse


def _join_pose_args(argv: Sequence[str]) -> list[str]:
    """``--start -0.1,0,0`` -> ``--start=-0.1,0,0``, ``--face -z`` -> ``--face=-z``
    (argparse would take the value for an option)."""
    return join_negative_values(argv, ("--start", "--goal", "--face", "--region", "--start-heading"))


def _flag_names(message: str) -> str:
    """Name planner settings by their command-line flags (a PushOptions field's
    is :func:`_flag`'s; a support error names ``--support-c``)."""
    field = message.split(":", 1)[0]
    flags = {"support": "--support-c", "start": "--start", "goal": "--goal", "region": "--region",
             "start_heading": "--start-heading", "max_stroke": "--max-stroke"}
    fields = {f.name for f in dataclasses.fields(PushOptions)}
    if ":" in message and (field in flags or field in fields):
        return flags.get(field, _flag(field)) + message[len(field):]
    return message


def main(argv: Optional[Sequence[str]] = None, prog: str = "nudge plan-push") -> int:
    """Run the command line; returns the exit status."""
    args = build_parser(prog).parse_args(_join_pose_args(sys.argv[1:] if argv is None else argv))
    try:
        if (args.start is None) != (args.goal is None) or (args.start is None and not args.psd):
            missing = "--start" if args.start is None else "--goal"
            raise InputError(f"{missing}: required (give both --start and --goal, or --psd "
                             "alone to draw only the push stability diagram)")
        start = goal = None
        sensorless = _sensorless_args(args)
        if args.start is not None:
            start = None if sensorless else parse_pose(args.start, "--start")
            goal = parse_pose(args.goal, "--goal")
        if args.plot and start is None:
            raise InputError("--plot: needs --start and --goal")
        if args.support is not None and args.support_c is not None:
            raise InputError("--support: give a support family or --support-c LO HI, not both")
        if args.min_fence_mu is not None and args.support_c is None \
                and args.support in (None, "any"):
            raise InputError("--min-fence-mu: slip-aware plans need --support-c LO HI or --support "
                             "rigid|uniform|ring too (whether the fence contact sticks depends on "
                             "the support's limit-surface ratio)")
        for flag, path in (("--plot", args.plot), ("--psd", args.psd)):
            if path:
                check_figure_path(path, flag)
    except InputError as exc:
        return fail(str(exc))

    try:
        face = args.face
        if face is not None and face.lstrip("+-").isdigit() and face[0] not in "+-":
            face = int(face)
        part = load_part_of_kind(args.part, "polygon", "nudge plan-tumble for polyhedra",
                                 units=args.units, face=face)
    except UserError as exc:
        return fail(str(exc))
    report_part(part)
    from sweeps import plausible

    if sensorless:
        return _run_sensorless(args, part, goal, sensorless)
    shown = plausible.screen_cli(part, poses={"--start": args.start, "--goal": args.goal},
                                 frictions={"--min-fence-mu": args.min_fence_mu},
                                 limit_surface={"--support-c": args.support_c})
    if shown is None:   # an implausible value (sweeps.plausible): refused before any work
        return Exit.INPUT

    # heavy imports (JAX) only after the cheap checks
    from kernels import PartError
    from planning import PlanningError, plan_pose, prepare_part

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        plausible.mute(shown)   # the warnings shown above, once
        try:
            options = _push_options(args)
            prepared = prepare_part(part.vertices, part.com, options.margin_deg,
                                    options.safety_factor, support=options.support,
                                    min_fence_mu=options.min_fence_mu)
            plan = None
            if start is not None:
                plan = plan_pose(part.vertices, start, goal, com=part.com, options=options)
        except PartError as exc:
            report_warnings(caught)
            return fail(f"{part.path}: {exc}")
        except PlanningError as exc:
            report_warnings(caught)
            return fail(str(exc), Exit.NEGATIVE)
        except ValueError as exc:
            report_warnings(caught)
            return fail(_flag_names(str(exc)))
        except ImportError as exc:
            if args.solver != "cvxpy":   # only the reference solver is an optional package
                raise
            report_warnings(caught)
            return fail(f"--solver {args.solver}: {exc}")
    report_warnings(caught)

    if plan is not None:
        if args.json:
            sys.stdout.write(json.dumps(plan.to_dict(), indent=2) + "\n")
        else:
            sys.stdout.write(f"{part.name}: {part.source}\n{plan.summary()}\n")
    elif not args.json:
        stable = [list(prepared.polygon.edge_vertices(e)) for e in prepared.stable]
        sys.stdout.write(f"{part.name}: {prepared.class_name} part, stable edges {stable}\n")

    return _write_figures(args, part, plan, prepared)


def _numbers(text: str, field: str, names: Sequence[str], unit: str, angles: bool = False):
    """Comma-separated numbers (``angles``: radians or ``deg``), one error line naming ``field``."""
    from sweeps.terminal import angle_value
    form = ",".join(names)
    parts = [p.strip() for p in str(text).split(",")]
    if len(parts) != len(names):
        raise InputError(f"{field}: expected {form} ({unit}), got {text!r}")
    out = []
    for name, p in zip(names, parts):
        try:
            v = angle_value(p) if angles else float(p)
        except ValueError:
            v = None
        if v is None or not math.isfinite(v):
            raise InputError(f"{field}: {name} must be a finite number ({unit}), got {p!r}")
        out.append(v)
    return tuple(out)


def _sensorless_args(args):
    """``(region, start_heading)`` of ``--start any``, None for a known start;
    every misuse refused in one line (before any work)."""
    any_start = args.start is not None and args.start.strip().lower() == "any"
    if not any_start:
        for flag, value in (("--region", args.region), ("--start-heading", args.start_heading),
                            ("--max-stroke", args.max_stroke)):
            if value is not None:
                raise InputError(f"{flag}: only with --start any (an unknown start pose); give "
                                 "--start any or drop it")
        return None
    if args.region is None:
        raise InputError("--region: required with --start any: XMIN,XMAX,YMIN,YMAX (m), where the "
                         "part's centre of mass may start")
    region = _numbers(args.region, "--region", ("XMIN", "XMAX", "YMIN", "YMAX"), "m")
    if region[0] > region[1] or region[2] > region[3]:
        raise InputError(f"--region: needs XMIN <= XMAX and YMIN <= YMAX, got {args.region!r}; "
                         "swap the bounds")
    heading = None
    if args.start_heading is not None:
        heading = _numbers(args.start_heading, "--start-heading", ("LO", "HI"), "rad or ...deg",
                           angles=True)
        if not heading[0] <= heading[1] < heading[0] + 2 * math.pi:
            raise InputError(f"--start-heading: needs LO <= HI < LO + 2 pi, got "
                             f"{args.start_heading!r}; for every heading drop --start-heading")
    if args.max_stroke is not None and args.max_stroke <= 0:
        raise InputError(f"--max-stroke: must be > 0 (m), got {args.max_stroke}")
    if args.plot:
        raise InputError("--plot: not drawn for --start any (use --psd for the funnel)")
    if args.support is not None or args.support_c is not None or args.min_fence_mu is not None:
        raise InputError("--support: not with --start any yet (the orient and register pushes use "
                         "Peshkin's distances, valid for any support)")
    return region, heading


def _push_options(args):
    """The :class:`planning.PushOptions` of the flags, field for field (a bad
    value: a ValueError naming the option, turned into a flag's name by
    :func:`_flag_names`)."""
    values = {f.name: getattr(args, f.name) for f in dataclasses.fields(PushOptions)}
    if args.support_c is not None:
        values["support"] = {"c": list(args.support_c)}
    if values["workspace"] is not None:
        values["workspace"] = tuple(values["workspace"])
    return PushOptions(**values)


def _run_sensorless(args, part, goal, sensorless) -> int:
    """``--start any``: plan, check and print a sensorless plan."""
    from sweeps import plausible

    shown = plausible.screen_cli(part, poses={"--goal": args.goal})
    if shown is None:
        return Exit.INPUT
    from kernels import PartError
    from planning import PlanningError, plan_sensorless

    region, heading = sensorless
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        plausible.mute(shown)
        try:
            options = _push_options(args)
            plan = plan_sensorless(part.vertices, goal, region, heading, com=part.com,
                                   options=options, max_stroke=args.max_stroke)
        except PartError as exc:
            report_warnings(caught)
            return fail(f"{part.path}: {exc}")
        except PlanningError as exc:
            report_warnings(caught)
            return fail(_flag_names(str(exc)), Exit.NEGATIVE)
        except ValueError as exc:
            report_warnings(caught)
            return fail(_flag_names(str(exc)))
    report_warnings(caught)
    if args.json:
        sys.stdout.write(json.dumps(plan.to_dict(), indent=2) + "\n")
    else:
        sys.stdout.write(f"{part.name}: {part.source}\n{plan.summary()}\n")
    if args.psd:
        from sweeps.figures import push as push_plots
        try:
            push_plots.plot_funnel(plan, args.psd, name=part.name)
        except OSError as exc:
            return fail(f"--psd: cannot write {args.psd} ({exc.strerror or exc})")
        sys.stderr.write(f"wrote {args.psd}\n")
    return Exit.OK


def _write_figures(args, part, plan, prepared) -> int:
    """``--plot`` and ``--psd`` (the PSD marks the plan's reorient steps); the exit status."""
    if not (args.plot or args.psd):
        return Exit.OK
    from sweeps.figures import push as push_plots
    for flag, path in (("--plot", args.plot), ("--psd", args.psd)):
        if not path:
            continue
        try:
            if flag == "--plot":
                push_plots.plot_plan(plan, path, name=part.name, outline=part.loops)
            else:
                push_plots.plot_psd(prepared, path, name=part.name, plan=plan)
        except OSError as exc:
            return fail(f"{flag}: cannot write {path} ({exc.strerror or exc})")
        sys.stderr.write(f"wrote {path}\n")
    return Exit.OK
