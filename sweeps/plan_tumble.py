"""Command line: plan tumbles that take a polyhedral part to a goal configuration.

Usage::

    nudge plan-tumble PART.yaml|PART.stl --goal X,Y,THETA,FACE --eps E [--units mm]
        [--start X,Y,THETA,FACE] [--tau-v T] [--tau-g T] [--no-shorten]
        [--json] [--plot FILE.png] [--development FILE.png]
        [--lattice FILE.png] [--lattice-radius R]

The part: a part file (:mod:`sweeps.partfile`), a bundled part's name, or a
mesh given directly (STL, OBJ, PLY, ...: its convex hull, the mesh's own
centre of mass; :mod:`sweeps.cad`) read in ``--units`` (else the file's own,
else metres; a file with no unit whose size is implausible is refused).

A configuration is ``x,y,theta,face`` (Marigo & Bicchi): ``face`` (a face
number of :func:`kernels.polyhedron.make_polyhedron`, optionally written
``F3``) lies on the plane, its frame at world ``(x, y)`` (metres) with
heading ``theta`` (radians, or degrees with a ``deg`` suffix, e.g.
``0.2,0,90deg,3``).  A configuration may start with a minus sign
(``--goal -0.1,0,0,0``).  The start defaults to ``0,0,0,0``.  ``eps`` is the
accuracy in the paper's metric (metres for the position, radians for the
heading); ``--tau-v`` the tolerance on the vertex coordinates (m) and
``--tau-g`` the tolerance of the rational approximation of the translation
generators (default: the planner's choice from eps).

``--development`` and ``--lattice`` alone (no ``--goal``) draw only the
plane development (Fig. 3) and the reachable lattice (Fig. 2).  A figure's
file type comes from its suffix (``.png``, ``.pdf``, ``.svg``, ...), checked
before any work.

Output: the plan's summary, or with ``--json`` the plan as JSON
(:meth:`planning.tumbling.plan.TumblePlan.to_dict`) and nothing else on stdout.
Messages go to stderr.  Exit status: 0 solved, 1 not solvable (the plan is
printed with its reason), 2 bad input (one line ``error: ...`` naming the
field), 3 internal error (``NUDGE_DEBUG=1`` for the traceback).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import warnings
from fractions import Fraction
from typing import Optional, Sequence

from sweeps.errors import Exit, UserError
from sweeps.terminal import (InputError, Parser, check_figure_path, fail, join_negative_values,
                             load_part_of_kind, parse_pose, report_part, report_warnings)



def parse_config(text: str, field: str) -> tuple[float, float, float, int]:
    """Parse ``x,y,theta,face`` (m, m, rad or ``...deg``, face number ``3`` or ``F3``).

    Raises:
      InputError: the message names ``field`` and shows the expected form.
    """
    return parse_pose(text, field, with_face=True)


def _number(text: str, field: str, *, positive: bool, allow_zero: bool = False) -> float:
    try:
        v = float(text)
    except (TypeError, ValueError):
        raise InputError(f"{field}: must be a number, got {text!r}") from None
    if not math.isfinite(v):
        raise InputError(f"{field}: must be finite, got {text!r}")
    if positive and (v < 0 or (v == 0 and not allow_zero)):
        want = "non-negative" if allow_zero else "positive"
        raise InputError(f"{field}: must be a {want} number, got {text!r}")
    return v


def build_parser(prog: str = "nudge plan-tumble") -> argparse.ArgumentParser:
    p = Parser(
        prog=prog,
        description="Plan a sequence of tumbles (rotations about edges on the plane, Marigo & "
                    "Bicchi) that takes a convex polyhedral part from a start configuration to "
                    "within eps of a goal, and optionally draw it.",
        epilog="Configurations: x,y,theta,face in metres, radians (or ...deg) and a face number; "
               "the face lies on the plane with its frame at (x, y), heading theta. "
               "Exit status: 0 solved, 1 not solvable or the effort budget ran out (the best plan "
               "found is printed), 2 bad input, 3 internal error.")
    p.add_argument("part", metavar="PART.yaml", help="part file with kind: polyhedron "
                   "(see sweeps.partfile), a bundled part's name, or a mesh file (STL, OBJ, PLY)")
    p.add_argument("--units", metavar="UNIT", default=None,
                   help="a mesh file's unit (m, cm, mm, um, in); default: the file's own, else metres")
    p.add_argument("--goal", metavar="X,Y,THETA,FACE", help="goal configuration")
    p.add_argument("--start", metavar="X,Y,THETA,FACE", default=None,
                   help="start configuration (default 0,0,0,0)")
    p.add_argument("--eps", metavar="E", help="accuracy: metres for the position, radians for "
                   "the heading (required with --goal)")
    p.add_argument("--tau-v", metavar="T", default="0", help="tolerance on the vertex "
                   "coordinates, metres (default 0)")
    p.add_argument("--tau-g", metavar="T", default=None, help="tolerance of the rational "
                   "approximation of the translation generators (default: from eps)")
    p.add_argument("--effort", metavar="OPS", default=None,
                   help="effort budget of the planner in elementary operations (default "
                        "10000000; 0 for no limit)")
    p.add_argument("--time-limit", metavar="S", default=None,
                   help="wall-clock cap of the planner, seconds (default 30; 0 for no limit)")
    p.add_argument("--no-shorten", action="store_true",
                   help="keep the paper's construction (no shortening of the tumble sequence)")
    p.add_argument("--json", action="store_true", help="print the plan as JSON on stdout")
    p.add_argument("--plot", metavar="FILE.png", help="draw the footprints along the plan")
    p.add_argument("--development", metavar="FILE.png",
                   help="draw the plane development rooted at the start face (Fig. 3)")
    p.add_argument("--lattice", metavar="FILE.png",
                   help="draw the reachable lattice around the start (Fig. 2)")
    p.add_argument("--lattice-radius", metavar="R", default=None,
                   help="radius of the --lattice figure, metres (default: 3 part diameters, "
                        "or enough to show the goal)")
    return p


def _join_config_args(argv: Sequence[str]) -> list[str]:
    """``--goal -0.1,0,0,0`` -> ``--goal=-0.1,0,0,0`` (argparse would take it for an option)."""
    return join_negative_values(argv, ("--start", "--goal", "--eps", "--tau-v", "--tau-g",
                                       "--lattice-radius"))


def _json_default(o):
    if isinstance(o, Fraction):
        return f"{o.numerator}/{o.denominator}"
    try:
        import numpy as np
        if isinstance(o, np.generic):
            return o.item()
        if isinstance(o, np.ndarray):
            return o.tolist()
    except ImportError:  # pragma: no cover
        pass
    if isinstance(o, (tuple, set, frozenset)):
        return list(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def main(argv: Optional[Sequence[str]] = None, prog: str = "nudge plan-tumble") -> int:
    """Run the command line; returns the exit status."""
    args = build_parser(prog).parse_args(_join_config_args(sys.argv[1:] if argv is None else argv))
    try:
        if args.goal is None and not (args.development or args.lattice):
            raise InputError("--goal: required (or give --development / --lattice alone to draw "
                             "only the part's figures)")
        goal = parse_config(args.goal, "--goal") if args.goal is not None else None
        start = parse_config(args.start, "--start") if args.start is not None else (0.0, 0.0, 0.0, 0)
        eps = None
        if args.eps is not None:
            eps = _number(args.eps, "--eps", positive=True)
        elif goal is not None:
            raise InputError("--eps: required with --goal (accuracy in metres / radians)")
        tau_v = _number(args.tau_v, "--tau-v", positive=True, allow_zero=True)
        tau_g = None if args.tau_g is None else _number(args.tau_g, "--tau-g", positive=True)
        budget = {}
        if args.effort is not None:
            v = _number(args.effort, "--effort", positive=True, allow_zero=True)
            if not float(v).is_integer():
                raise InputError(f"--effort: must be a whole number of operations, got {args.effort!r}")
            budget["effort"] = int(v) or None
        if args.time_limit is not None:
            v = _number(args.time_limit, "--time-limit", positive=True, allow_zero=True)
            budget["time_limit"] = v or None
        radius = None
        if args.lattice_radius is not None:
            radius = _number(args.lattice_radius, "--lattice-radius", positive=True)
        if args.plot and goal is None:
            raise InputError("--plot: needs --goal and --eps")
        for flag, path in (("--plot", args.plot), ("--development", args.development),
                           ("--lattice", args.lattice)):
            if path:
                check_figure_path(path, flag)
    except InputError as exc:
        return fail(str(exc))

    try:
        part = load_part_of_kind(args.part, "polyhedron", "nudge plan-push for polygons",
                                 units=args.units)
    except UserError as exc:
        return fail(str(exc))
    report_part(part)
    from sweeps import plausible

    shown = plausible.screen_cli(part, poses={"--start": args.start, "--goal": args.goal},
                                 lengths={"--eps": eps, "--tau-v": tau_v})
    if shown is None:   # an implausible value (sweeps.plausible): refused before any work
        return Exit.INPUT

    # heavy imports (JAX) only after the cheap checks
    from kernels import make_polyhedron

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        plausible.mute(shown)   # the warnings shown above, once
        try:
            poly = make_polyhedron(part.vertices, part.com, tau_v=tau_v)  # faces at tau_v
        except ValueError as exc:
            report_warnings(caught)
            return fail(f"{part.path}: {exc}")
        try:
            for field, cfg in (("--start", start), ("--goal", goal)):
                if cfg is not None and not 0 <= cfg[3] < poly.n_faces:
                    raise InputError(f"{field}: face {cfg[3]} does not exist; this part has faces "
                                     f"0..{poly.n_faces - 1}")
        except InputError as exc:
            report_warnings(caught)
            return fail(str(exc))

        plan = None
        analysis = None
        try:
            if goal is not None:
                from planning import plan_tumble
                plan = plan_tumble(part.vertices, goal, start=start, com=part.com, eps=eps,
                                   tau_v=tau_v, tau_g=tau_g, shorten=not args.no_shorten, **budget)
            if args.lattice or (args.development and plan is not None):
                # the planner's own analysis (cached by plan_tumble: same part, tolerances
                # and start face), so the figures show what the plan was built from
                from planning import analyze_polyhedron
                analysis = analyze_polyhedron(part.vertices, com=part.com, tau_v=tau_v,
                                              tau_g=tau_g, start_face=int(start[3]))
        except ValueError as exc:   # the planner's bad input (naming the field); a bug is exit 3
            report_warnings(caught)
            return fail(str(exc))
    report_warnings(caught)

    code = Exit.OK
    if plan is not None:
        if args.json:
            sys.stdout.write(json.dumps(plan.to_dict(), indent=2, default=_json_default) + "\n")
        else:
            sys.stdout.write(f"{part.name}: {part.source}\n{plan.summary()}\n")
        if plan.verdict != "solved":
            code = Exit.NEGATIVE
            what = ("effort budget exhausted (raise --effort or --time-limit)"
                    if plan.verdict == "budget_exhausted" else "not solvable")
            sys.stderr.write(f"{what}: {' '.join(str(plan.reason).split())}\n")
    elif not args.json:
        sys.stdout.write(f"{part.name}: {part.source}: {poly.n_faces} faces, {poly.n_vertices} "
                         f"vertices, {poly.n_edges} edges\n")

    if args.plot or args.development or args.lattice:
        from sweeps.figures import tumble as tumble_plots
        import numpy as np
        diam = float(np.max(np.linalg.norm(poly.vertices[:, None] - poly.vertices[None], axis=-1)))
        for flag, path in (("--plot", args.plot), ("--development", args.development),
                           ("--lattice", args.lattice)):
            if not path:
                continue
            try:
                if flag == "--plot":
                    tumble_plots.plot_plan(plan, path, name=part.name)
                elif flag == "--development":
                    tumble_plots.plot_development(analysis if analysis is not None else poly, path,
                                                  root=int(start[3]), name=part.name)
                else:
                    r = radius
                    if r is None:
                        r = 3.0 * diam
                        if goal is not None:
                            r = max(r, 1.15 * math.hypot(goal[0] - start[0], goal[1] - start[1]))
                    tumble_plots.plot_reachable(analysis, path, r, name=part.name)
            except OSError as exc:
                return fail(f"{flag}: cannot write {path} ({exc.strerror or exc})")
            sys.stderr.write(f"wrote {path}\n")
    return code

