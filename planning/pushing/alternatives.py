"""More than one plan for a pose problem: the candidates the pose planner ranks
below its choice, each solved, replayed and verified (input of robust plan
synthesis, :mod:`robustness.synthesis`).

:func:`plan_pose` keeps the best candidate sequence by its objective; the
others (the other sense of rotation, more or fewer reorient pushes, another
stable edge, the paper's sequences under ``strategy="paper"``) are valid plans
too, only longer, and one of them may be the one that survives the real part's
errors.  :func:`plan_alternatives` returns up to ``limit`` of them, distinct,
the planner's own plan first: the best of every (plan class, reorient count)
group in the planner's order, then the next best overall.  Every returned plan
has been replayed by the exact kinematics, as :func:`plan_pose`'s.

Frames and units: those of :func:`planning.plan_pose` (world frame, metres,
radians CCW).
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from kernels import float64
from planning.pushing import planner as pl, pose_lp, sequences as sq
from planning.pushing.options import PushOptions
from planning.pushing.part import PlanningError, check_pose, prepare_part
from planning.pushing.plan import PushPlan


def _solve_all(part, settings, cands) -> list:
    """Every applicable candidate's LP optimum ``(cost, pushes, weights)`` (None:
    not applicable, infeasible, or longer than the part's longest plan)."""
    solve = pose_lp.solve_closed_form
    out = [None] * len(cands)
    for i, c in enumerate(cands):
        if c is None:
            continue
        sol = solve(c.angles, np.ones(len(c.angles), bool), c.merged, c.target, settings.objective,
                    scale=part.size)
        if sol.feasible:
            r = pl._result(c, sol.weights, part.size)
            out[i] = r if r[0] <= part.longest_plan else None
    return out


def _signature(plan: PushPlan) -> tuple:
    """What makes two plans the same plan (pushes to 1e-9 m / 1e-9)."""
    return tuple((p.kind, p.edge, round(p.direction[0], 9), round(p.direction[1], 9),
                  round(p.distance, 9)) for p in plan.pushes)


@float64
def plan_alternatives(vertices, start, goal, com=None, *, options: Optional[PushOptions] = None,
                      limit: int = 8) -> list[PushPlan]:
    """Up to ``limit`` distinct verified plans for one pose problem, the one
    :func:`planning.plan_pose` returns first.

    Args:
      vertices: (m, 2) part vertices (m, part frame); com: centre of mass (m,
        part frame; default the area centroid).
      start, goal: poses ``(x, y, theta)`` (m, m, rad; world frame).
      options: the planner's :class:`~planning.PushOptions` (the closed-form LP
        is used whatever ``options.solver``; a workspace keeps only the
        candidates that fit it, best first).
      limit: the most plans returned (>= 1).

    Returns:
      A list of :class:`~planning.PushPlan` (at least one): the planner's plan,
      then the best of each other (plan class, reorient pushes) group by the
      objective, then the next best candidates; each replayed exactly.

    Raises:
      ValueError / PartError: bad input, naming the field.
      PlanningError: no plan at all (the message of :func:`planning.plan_pose`).
    """
    o = options or PushOptions()
    if not (isinstance(limit, (int, np.integer)) and limit >= 1):
        raise ValueError(f"limit: expected an integer >= 1, got {limit!r}")
    first = pl.plan_pose(vertices, start, goal, com, options=o)   # its message when none
    if limit == 1:
        return [first]
    settings = o
    start, goal = check_pose(start, "start"), check_pose(goal, "goal")
    part = prepare_part(vertices, com, o.margin_deg, o.safety_factor, support=o.support,
                        min_fence_mu=o.min_fence_mu)
    table = sq.candidate_table(part, settings.strategy, settings.extra_steps)
    cands = pl.candidates(part, table, settings, start, goal)
    results = _solve_all(part, settings, cands)
    if settings.workspace is not None:
        results = pl.fit_workspace(part, settings, start, cands, table, results, [])
    pushes = settings.objective == "pushes"
    order = sorted((i for i, r in enumerate(results) if r is not None),
                   key=lambda i: (int(table["tier"][i]), results[i][1] if pushes else 0,
                                  results[i][0], i))
    groups: dict = {}
    for i in order:   # the best of each (class, reorient count) group first, then the rest
        groups.setdefault((int(table["cls"][i]), len(cands[i].steps)), i)
    ranked = list(groups.values()) + [i for i in order if i not in set(groups.values())]
    plans, seen = [first], {_signature(first)}
    for i in ranked:
        if len(plans) >= limit:
            break
        try:
            plan = pl.assemble(part, settings, start, goal, cands[i], table, results[i][2])
        except PlanningError:   # its replay disagrees: not a plan
            continue
        sig = _signature(plan)
        if sig not in seen:
            seen.add(sig)
            plans.append(plan)
    return plans


__all__ = ["plan_alternatives"]
