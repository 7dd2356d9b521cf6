"""Command line: plan fence pushes that take a polygonal part from one pose to another.

Usage::

    nudge plan-push PART.yaml --start X,Y,THETA --goal X,Y,THETA
        [--margin-deg 7] [--safety-factor 1.15] [--objective distance|pushes]
        [--solver closed_form|cvxpy] [--json] [--plot FILE.png] [--psd FILE.png]

Poses are ``x,y,theta`` in metres and radians (world frame; ``(x, y)`` is the
centre of mass); ``theta`` may carry a ``deg`` suffix (``0.1,0,90deg``) or a
``rad`` one.  A pose may start with a minus sign (``--start -0.1,0,0``).
``--psd`` alone (no ``--start``/``--goal``) only draws the part's push
stability diagram.

Output: the plan's summary table, or with ``--json`` the plan as JSON
(:meth:`planning.pushing.plan.PushPlan.to_dict`) and nothing else on stdout.
Messages go to stderr.  Exit status: 0 success, 1 no plan found
(:class:`~planning.pushing.planner.PlanningError`), 2 bad input (one line
``error: ...`` naming the field).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import warnings
from typing import Optional, Sequence

from sweeps.terminal import (InputError, Parser, fail, join_negative_values, load_part_of_kind,
                          report_warnings)
from sweeps.terminal import parse_pose as _parse_pose

EXIT_OK, EXIT_PLANNING, EXIT_INPUT = 0, 1, 2


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
               "theta may end in 'deg' (e.g. 0.1,0,90deg). Exit status: 0 ok, 1 no plan, "
               "2 bad input.")
    p.add_argument("part", metavar="PART.yaml", help="part file (see sweeps.partfile)")
    p.add_argument("--start", metavar="X,Y,THETA", help="start pose (m, m, rad or ...deg)")
    p.add_argument("--goal", metavar="X,Y,THETA", help="goal pose (m, m, rad or ...deg)")
    p.add_argument("--margin-deg", type=float, default=7.0, metavar="DEG",
                   help="margin angle taken off each maximum reorient angle (default 7)")
    p.add_argument("--safety-factor", type=float, default=1.15, metavar="F",
                   help="multiplier of the Peshkin distance, >= 1 (default 1.15)")
    p.add_argument("--objective", choices=("distance", "pushes"), default="distance",
                   help="minimise total push distance (default) or the number of pushes")
    p.add_argument("--solver", choices=("closed_form", "cvxpy"), default="closed_form",
                   help="LP solver (default closed_form; cvxpy is the reference)")
    p.add_argument("--json", action="store_true", help="print the plan as JSON on stdout")
    p.add_argument("--plot", metavar="FILE.png", help="draw the plan (Akella-Mason Fig. 1)")
    p.add_argument("--psd", metavar="FILE.png",
                   help="draw the push stability diagram (Fig. 6, normal pushes)")
    return p


def _join_pose_args(argv: Sequence[str]) -> list[str]:
    """``--start -0.1,0,0`` -> ``--start=-0.1,0,0`` (argparse would take the value for an option)."""
    return join_negative_values(argv, ("--start", "--goal"))


def _flag_names(message: str) -> str:
    """Name planner settings by their command-line flags."""
    for field, flag in (("margin_deg", "--margin-deg"), ("safety_factor", "--safety-factor"),
                        ("start", "--start"), ("goal", "--goal")):
        if message.startswith(field + ":"):
            return flag + message[len(field):]
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
        if args.start is not None:
            start = parse_pose(args.start, "--start")
            goal = parse_pose(args.goal, "--goal")
        if args.plot and start is None:
            raise InputError("--plot: needs --start and --goal")
        for flag, path in (("--plot", args.plot), ("--psd", args.psd)):
            if path and not os.path.isdir(os.path.dirname(os.path.abspath(path))):
                raise InputError(f"{flag}: the folder of {path!r} does not exist")
    except InputError as exc:
        return fail(str(exc))

    try:
        part = load_part_of_kind(args.part, "polygon", "nudge plan-tumble for polyhedra")
    except InputError as exc:
        return fail(str(exc))

    # heavy imports (JAX) only after the cheap checks
    from kernels.polygon import PartError
    from planning.pushing.planner import PlanningError, plan_pose, prepare_part

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            prepared = prepare_part(part.vertices, part.com, args.margin_deg, args.safety_factor)
            plan = None
            if start is not None:
                plan = plan_pose(part.vertices, start, goal, com=part.com,
                                 margin_deg=args.margin_deg, safety_factor=args.safety_factor,
                                 objective=args.objective, solver=args.solver)
        except PartError as exc:
            report_warnings(caught)
            return fail(f"{part.path}: {exc}")
        except PlanningError as exc:
            report_warnings(caught)
            return fail(str(exc), EXIT_PLANNING)
        except ValueError as exc:
            report_warnings(caught)
            return fail(_flag_names(str(exc)))
        except ImportError as exc:  # cvxpy missing
            report_warnings(caught)
            return fail(f"--solver {args.solver}: {exc}")
    report_warnings(caught)

    if plan is not None:
        if args.json:
            sys.stdout.write(json.dumps(plan.to_dict(), indent=2) + "\n")
        else:
            sys.stdout.write(f"{part.name}: {part.path}\n{plan.summary()}\n")
    elif not args.json:
        stable = [list(prepared.polygon.edge_vertices(e)) for e in prepared.stable]
        sys.stdout.write(f"{part.name}: {prepared.class_name} part, stable edges {stable}\n")

    if args.plot or args.psd:
        from sweeps.figures import push as push_plots
        for flag, path in (("--plot", args.plot), ("--psd", args.psd)):
            if not path:
                continue
            try:
                if flag == "--plot":
                    push_plots.plot_plan(plan, path, name=part.name)
                else:
                    push_plots.plot_psd(prepared, path, name=part.name)
            except (OSError, ValueError) as exc:
                return fail(f"{flag}: cannot write {path} ({exc})")
            sys.stderr.write(f"wrote {path}\n")
    return EXIT_OK

