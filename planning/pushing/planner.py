"""The pose planner: fence pushes that take a convex polygon from any start
pose to any goal pose (Akella & Mason 1992, and beyond).

For every candidate reorientation sequence (:mod:`planning.pushing.sequences`:
the paper's angle-eating candidates with ``strategy="paper"``, a wider search by
default) the pose-vector LP (:mod:`planning.pushing.pose_lp`) fixes every push
length exactly; the best candidate by the objective is the plan.  Options:
model-based reorient distances (``support``), slip-aware reorient pushes
(``min_fence_mu``) and a workspace (:mod:`planning.pushing.workspace`).  Every
plan is replayed by the exact kinematics (:func:`kernels.push.replay_pushes`,
at the distance rule's slowest rate) before it is returned.

Two implementations share these rules: :func:`plan_pose` here (one problem,
readable numpy, LP by the closed form or by cvxpy) and
:func:`planning.pushing.batch.plan_pose_batch` (many start/goal pairs of one
part, JAX, jit + vmap).  They agree plan for plan (tested).

Frames: world frame, metres, radians CCW.  Pose ``(x, y, theta)``:
``p_world = R(theta) (p - com) + (x, y)``.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Optional

import jax
import jax.numpy as jnp
import numpy as np

from kernels import angle_distance, wrap_angle_np, float64, replay_pushes
from planning.pushing.options import PushOptions, options_of
from planning.pushing import pose_lp, sequences as sq, workspace as wsp
from planning.pushing.part import (ANG_TOL, SAME_ORIENTATION, PlanningError, PushPart,
                                   WorkspaceError, check_pose, prepare_part)
from planning.pushing.plan import Push, PushPlan



# --------------------------------------------------------------------------
# Candidates (numpy reference)
# --------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Candidate:
    """One candidate sequence, its LP data and (once solved) its optimum."""

    row: int
    steps: list             # [sq.Step] reorient pushes
    thetas: np.ndarray      # (r+1,) orientations, thetas[0] = start
    angles: np.ndarray      # ((r+1) * ns,) world angles of the LP columns
    merged: np.ndarray      # ((r+1) * ns,) column extends reorient push i (row i >= 1)
    target: np.ndarray      # (2,) T'' (m)
    need: np.ndarray        # (r,) least distance given to each reorient push (m)
    least: np.ndarray       # (r,) its distance rule's minimum, without the rounding guard (m)
    shifts: np.ndarray      # (r, 2) centre-of-mass displacement of each reorient at its least distance


def candidates(part: PushPart, table: dict, settings: PushOptions, start, goal) -> list:
    """Expand every template of ``table`` for this start/goal pair (None where
    a template does not apply), with its LP data."""
    theta0, thetag = _orientations(start, goal)
    same = angle_distance(theta0, thetag) <= SAME_ORIENTATION
    out = []
    for row in range(len(table["trans"])):
        if table["trans"][row]:
            out.append(_lp_data(part, row, [], np.array([theta0]), start, goal) if same else None)
            continue
        ex = sq.expand(table, row, theta0, thetag, settings.max_reorients)
        out.append(None if ex is None else _lp_data(part, row, ex[0], ex[1], start, goal))
    return out


def _orientations(start, goal) -> tuple[float, float]:
    """Start orientation wrapped to (-pi, pi] and the goal's orientation unwrapped to
    within pi of it (rad): the reorientations a candidate must turn."""
    theta0 = wrap_angle_np(float(start[2]))
    return theta0, theta0 + wrap_angle_np(float(goal[2]) - theta0)


def _lp_data(part: PushPart, row: int, steps, thetas, start, goal) -> Candidate:
    """The candidate's LP data: reorient ``i`` (pivot ``v`` in the body frame)
    moves the centre of mass by ``R(theta_i) v - R(theta_i+1) v`` plus its
    distance along its push direction; the LP's columns are the push
    directions ``theta_i + omega_j`` into each stable edge (world, rad)."""
    r = len(steps)
    omega = part.omega
    ns = len(omega)
    merged = np.zeros((r + 1, ns), bool)
    need, least, shifts = np.zeros(r), np.zeros(r), np.zeros((r, 2))
    if r:
        edge = np.array([st.edge for st in steps])
        sense = np.array([st.sense for st in steps])
        alpha = np.array([st.alpha for st in steps])
        col = np.searchsorted(part.stable, edge)          # stable is sorted: column of each edge
        need = part.reorient_need(edge, sense, alpha)
        least = part.reorient_min(edge, sense, alpha)
        v = part.body[part.pivot[edge, sense]]             # (r, 2) pivot vertices, body frame
        c0, s0, c1, s1 = np.cos(thetas[:-1]), np.sin(thetas[:-1]), np.cos(thetas[1:]), np.sin(thetas[1:])
        th = thetas[1:] + omega[col]
        shifts = np.stack([(c0 - c1) * v[:, 0] - (s0 - s1) * v[:, 1] + need * np.cos(th),
                           (s0 - s1) * v[:, 0] + (c0 - c1) * v[:, 1] + need * np.sin(th)], axis=1)
        merged[np.arange(1, r + 1), col] = True
    target = np.asarray(goal[:2], float) - np.asarray(start[:2], float) - shifts.sum(axis=0)
    angles = (thetas[:, None] + omega[None, :]).ravel()
    return Candidate(row, steps, thetas, angles, merged.ravel(), target, need, least, shifts)


# --------------------------------------------------------------------------
# Replay and verification
# --------------------------------------------------------------------------
@jax.jit
def _replay_jit(geom, pose, directions, distances, rate_c):
    return replay_pushes(geom, pose, directions, distances, rate_c)


def replay_rate(part: PushPart):
    """The ``rate_c`` argument of :func:`kernels.push.replay_pushes` for plans of ``part``."""
    return jnp.asarray(float(part.geom.radius) if part.rate_c is None else part.rate_c)


def verify(part: PushPart, start, goal, directions, distances, edges):
    """Replay pushes (padded to a multiple of 8 to bound recompiles) and list
    every way the replay disagrees with the plan."""
    p = len(distances)
    pad = max(8, -(-p // 8) * 8)
    dirs = np.zeros((pad, 2))
    dirs[:, 0] = 1.0
    dists = np.zeros(pad)
    if p:
        dirs[:p] = directions
        dists[:p] = distances
    final, outs = _replay_jit(part.geom, jnp.asarray(start), jnp.asarray(dirs), jnp.asarray(dists),
                              replay_rate(part))
    final = np.asarray(final)
    poses = np.asarray(outs.pose)[:p]
    landed = np.asarray(outs.edge)[:p]
    finished = np.asarray(outs.finished)[:p]
    pos_err = float(np.hypot(*(final[:2] - np.asarray(goal[:2]))))
    ang_err = angle_distance(final[2], goal[2])
    pos_tol = part.pos_tol(np.hypot(*start[:2]), np.hypot(*goal[:2]), float(np.sum(distances)))
    problems = []
    for i, (got, want, fin) in enumerate(zip(landed, edges, finished)):
        if not fin:
            problems.append(f"push {i} did not finish within the replay's pass limit")
        elif int(got) != int(want):
            problems.append(f"push {i} ended on edge {int(got)} instead of {int(want)}")
    if pos_err >= pos_tol:
        problems.append(f"position error {pos_err:.3e} m >= {pos_tol:.3g} m")
    if ang_err >= ANG_TOL:
        problems.append(f"angle error {ang_err:.3e} rad >= {ANG_TOL:g} rad")
    return poses, (pos_err, ang_err), problems


# --------------------------------------------------------------------------
# Single problem (numpy reference, closed form or cvxpy)
# --------------------------------------------------------------------------
@float64
def plan_pose(vertices, start, goal, com=None, options: Optional[PushOptions] = None) -> PushPlan:
    """Plan normal fence pushes taking the part from ``start`` to ``goal``.

    Args:
      vertices: (m, 2) part vertices (m, part frame), any order.
      start, goal: poses ``(x, y, theta)`` (m, m, rad), world frame.
      com: centre of mass (m, part frame), default the area centroid.
      options: the planner's :class:`~planning.PushOptions` (default
        :data:`planning.pushing.options.DEFAULTS`):

        * ``margin_deg``: margin angle (degrees) taken off each maximum reorient
          angle; ``safety_factor``: multiplier of the reorient distance rule
          (paper 1.15).
        * ``objective``: ``"distance"`` (total push distance, the paper's LP) or
          ``"pushes"`` (fewest pushes, then shortest: the paper's MILP idea);
          ``solver``: ``"closed_form"`` or ``"cvxpy"`` (reference) for each LP.
        * ``strategy``: ``"search"`` (the reorientation sequences of
          :mod:`planning.pushing.sequences`) or ``"paper"`` (Akella & Mason's).
        * ``support``: what the distances assume (:class:`PlanSupport`): ``any``
          (Peshkin's distance), a family or a ``c`` range (m): each reorient
          push then gets the shortest distance that completes it for every
          ``c`` in the range under the quasi-static model (times the safety
          factor).
        * ``min_fence_mu``: optional lower bound of the fence friction
          coefficient (needs a support): only reorient pushes whose fence
          contact sticks throughout for every ``c`` in the range are used.
        * ``workspace``: optional ``(xmin, xmax, ymin, ymax)`` (m, world): every
          pose of the plan and the part swept during every push stay inside.
        * ``max_reorients``: no plan has more reorient pushes; ``extra_steps``:
          the search tries ``n_min .. n_min + extra_steps`` steps per run
          (uni-stable parts also 2, 3 and 4 times ``extra_steps`` more).

    Returns:
      A :class:`~planning.pushing.plan.PushPlan` whose exact replay reaches the
      goal within 1e-9 of the part's size and 1e-9 rad; ``plan.options`` are
      ``options``.

    Raises:
      ValueError / PartError: bad input, naming the field.
      PlanningError: no candidate is feasible (within the effort budget or the
        workspace: the message says which), or the replay disagrees.
    """
    o = options_of(options)   # validated when made: the planner reads its settings from it
    start = check_pose(start, "start")
    goal = check_pose(goal, "goal")
    part = prepare_part(vertices, com, o.margin_deg, o.safety_factor, support=o.support,
                        min_fence_mu=o.min_fence_mu)
    return plan_one(part, o, start, goal, o.solver)


def plan_one(part: PushPart, settings: PushOptions, start, goal, solver: str = "closed_form") -> PushPlan:
    """:func:`plan_pose` for a prepared part; ``settings``: the
    :class:`~planning.PushOptions` (objective, strategy, effort, workspace) it reads."""
    if settings.workspace is not None:
        wsp.check_inside(part, settings.workspace, start, "start")
        wsp.check_inside(part, settings.workspace, goal, "goal")
    table = sq.candidate_table(part, settings.strategy, settings.extra_steps)
    cands = candidates(part, table, settings, start, goal)
    results = solve_candidates(part, settings, cands, table, solver)
    longest = [r[0] for r in results if r is not None and r[0] > part.longest_plan]
    results = [None if r is None or r[0] > part.longest_plan else r for r in results]
    boxes = []
    if settings.workspace is not None:
        results = fit_workspace(part, settings, start, cands, table, results, boxes)
    best = choose(table, results, settings.objective)
    if best is None:
        if settings.workspace is not None and boxes:
            raise _workspace_error(part, settings, start, goal, boxes)
        if longest:
            raise PlanningError(_too_long_message(part, settings, start, goal, min(longest)))
        raise PlanningError(_no_plan_message(part, settings, start, goal, cands, table))
    cost, _, w = results[best]
    return assemble(part, settings, start, goal, cands[best], table, w)


# Lower bounds of a candidate's cost: its reorient distances plus |T''|, and its
# optimum without a workspace; BOUND_SLACK (relative) covers the LPs' rounding.
BOUND_SLACK = 1e-7
EXHAUSTIVE_LP = False    # tests: solve every candidate's LP (the bound must not change the plan)


def solve_candidates(part: PushPart, settings: PushOptions, cands: list, table: dict,
                     solver: str = "closed_form") -> list:
    """Every candidate's LP optimum as ``(cost, pushes, weights)`` (None: not
    applicable or infeasible).  For the ``distance`` objective without a
    workspace the LPs are solved in the order of a lower bound of the cost
    (tier, then the reorient distances plus ``|T''|``: each LP column is a unit
    vector), and a candidate whose bound exceeds the best cost found in its
    tier beyond the tie tolerance ``COST_TIE`` (and ``BOUND_SLACK`` for the
    LP's rounding), or whose tier is above a tier with a plan, is left None:
    it cannot be chosen (:func:`choose`), so the plan is the one solving every
    LP gives (the batched planner's fast path uses the same bound)."""
    solve = pose_lp.solve_closed_form if solver == "closed_form" else pose_lp.solve_cvxpy
    scale = part.size
    results = [None] * len(cands)
    prune = settings.objective == "distance" and settings.workspace is None and not EXHAUSTIVE_LP
    live = [i for i, c in enumerate(cands) if c is not None]
    bound = {i: float(cands[i].need.sum() + math.hypot(*cands[i].target)) for i in live}
    if prune:
        live.sort(key=lambda i: (int(table["tier"][i]), bound[i], i))
    best = None      # (tier, cost) of the best plan found so far
    for i in live:
        tier = int(table["tier"][i])
        if prune and best is not None and (tier > best[0] or bound[i] * (1.0 - BOUND_SLACK)
                                           > best[1] * (1.0 + sq.COST_TIE)):
            if tier > best[0]:
                break
            continue
        cand = cands[i]
        sol = solve(cand.angles, np.ones(len(cand.angles), bool), cand.merged, cand.target,
                    settings.objective, scale=scale)
        if sol.feasible:
            results[i] = _result(cand, sol.weights, scale)
            if results[i][0] <= part.longest_plan and (best is None or results[i][0] < best[1]):
                best = (tier, results[i][0])
    return results


def _result(cand: Candidate, w, scale: float) -> tuple:
    """``(cost, pushes, weights)`` of a candidate's LP weights ``w`` (m)."""
    npush = len(cand.steps) + int(np.sum((w > pose_lp.DROP * scale) & ~cand.merged))
    return float(cand.need.sum() + float(w.sum())), npush, w


EXHAUSTIVE_FIT = False   # tests: fit every candidate (the bound must not change the plan)


def fit_workspace(part: PushPart, settings: PushOptions, start, cands: list, table: dict,
                  results: list, boxes: list) -> list:
    """The candidates' optima inside the workspace (:func:`workspace.fit`), as
    ``results`` (``(cost, pushes, weights)`` or None).  Exact branch and bound:
    a candidate's constrained optimum is never better, in :func:`choose`'s order
    (tier, then fewest pushes for ``pushes``, then cost), than its unconstrained
    one, so candidates are fitted in that order of their unconstrained optimum
    and the fitting stops once no later one can be chosen (outside the cost tie
    ``COST_TIE`` of the best fitted); those left are None.  :func:`choose` then
    picks what it would pick after fitting every candidate.  A fitted plan
    longer than ``part.longest_plan`` does not fit.  ``boxes`` collects the
    candidates whose unconstrained optimum did not fit (for the
    :class:`WorkspaceError`)."""
    pushes = settings.objective == "pushes"
    order = sorted((i for i, r in enumerate(results) if r is not None),
                   key=lambda i: (int(table["tier"][i]), results[i][1] if pushes else 0, results[i][0], i))
    out = [None] * len(results)
    best = None      # (tier, pushes, cost) of the best fitted so far, in choose()'s order
    for i in order:
        tier, npush, cost = int(table["tier"][i]), results[i][1] if pushes else 0, results[i][0]
        if best is not None and not EXHAUSTIVE_FIT and (tier, npush) >= best[:2] and (
                (tier, npush) > best[:2] or cost * (1.0 - BOUND_SLACK) > best[2] * (1.0 + sq.COST_TIE)):
            break       # this one and every later one rank below the best fitted
        w = wsp.fit(part, cands[i], results[i][2], settings.workspace, start, boxes)
        if w is None:
            continue
        out[i] = _result(cands[i], w, part.size)
        if out[i][0] > part.longest_plan:       # (the unconstrained one was not)
            out[i] = None
            continue
        key = (tier, out[i][1] if pushes else 0, out[i][0])
        best = key if best is None or key < best else best
    return out


def choose(table: dict, results: list, objective: str) -> Optional[int]:
    """Index of the best candidate: the lowest tier with a feasible one, then the
    objective (fewest pushes first for ``pushes``), ties (``COST_TIE``) to the
    lowest row.  ``results[i]``: ``(cost, pushes, weights)`` or None."""
    feas = [i for i, r in enumerate(results) if r is not None]
    if not feas:
        return None
    tier = min(int(table["tier"][i]) for i in feas)
    feas = [i for i in feas if int(table["tier"][i]) == tier]
    if objective == "pushes":
        fewest = min(results[i][1] for i in feas)
        feas = [i for i in feas if results[i][1] == fewest]
    low = min(results[i][0] for i in feas)
    return min(i for i in feas if results[i][0] <= low * (1.0 + sq.COST_TIE))


#: The longest message a PlanningError of the push planner carries (characters, one line).
MESSAGE_LIMIT = 300


def option(name: str) -> str:
    """A planner option as every user types it: its keyword, the ``nudge
    plan-push`` flag and the study/certify config key, e.g. ``max_reorients
    (--max-reorients, planner.max_reorients)``."""
    return f"{name} (--{name.replace('_', '-')}, planner.{name})"


def listed(items, k: int = 3) -> str:
    """The first ``k`` of ``items`` joined by ``; ``, then ``and N more``."""
    items = [str(x) for x in items]
    more = f"; and {len(items) - k} more" if len(items) > k else ""
    return "; ".join(items[:k]) + more


def _pose(p) -> str:
    return "(" + ", ".join(f"{float(x):.4g}" for x in p) + ")"


def _message(part: PushPart, start, goal, why: str) -> str:
    """``no pose plan for this <class> part from <start> to <goal><why>``; the
    poses are left out where the line would exceed ``MESSAGE_LIMIT``."""
    head = f"no pose plan for this {part.class_name} part"
    line = f"{head} from {_pose(start)} to {_pose(goal)}{why}"
    return line if len(line) <= MESSAGE_LIMIT else head + why


def _workspace_error(part: PushPart, settings: PushOptions, start, goal, boxes) -> WorkspaceError:
    """No candidate fits the workspace: the error names the smallest workspace
    found (the given one scaled about its centre; :func:`workspace.smallest_workspace`)."""
    scale, box = wsp.smallest_workspace(boxes, settings.workspace)
    found = (f"the smallest workspace found (this one scaled about its centre, by {scale:.4g}) is "
             f"{_pose(box)} m" if math.isfinite(scale)
             else "no larger workspace about its centre was found either")
    why = f" inside the workspace {_pose(settings.workspace)} m: no candidate fits; {found}"
    return WorkspaceError(_message(part, start, goal, why), scale, box if math.isfinite(scale) else None)


def _too_long_message(part: PushPart, settings: PushOptions, start, goal, shortest: float) -> str:
    return _message(part, start, goal, (
        f": the shortest candidate pushes {shortest:.4g} m in all, {shortest / part.size:.3g} part sizes "
        f"(its push directions nearly cancel), more than float64 can replay ({part.longest_plan:.4g} m); "
        + ("strategy='search' (--strategy search, planner.strategy: search) tries more sequences"
           if settings.strategy == "paper" else f"try another {option('margin_deg')}")))


def _no_plan_message(part: PushPart, settings: PushOptions, start, goal, cands, table) -> str:
    """Why no candidate gave a plan, in one line of at most ``MESSAGE_LIMIT``
    characters that names the options to change as the user types them."""
    if (all(c is None for c in cands) and part.min_fence_mu is not None
            and not np.any(part.step[list(part.stable)] > 0.0)):
        lo, hi = part.support_c
        return _message(part, start, goal, (
            f": only translation plans exist, as no reorient push sticks at min_fence_mu="
            f"{part.min_fence_mu:g} for all c in [{lo:.4g}, {hi:.4g}] m; give a higher "
            f"{option('min_fence_mu')} or narrower c (--support-c, planner.support_c)"))
    theta0, thetag = _orientations(start, goal)
    over = [n for n in (sq.reorient_pushes(table, row, theta0, thetag)       # set aside for the budget
                        for row, c in enumerate(cands) if c is None) if n is not None]
    budget = f"max_reorients={settings.max_reorients}"
    if all(c is None for c in cands):
        if not over:
            return _message(part, start, goal, f": no reorient push is allowed{_slip_note(part)}")
        biggest = math.degrees(max(float(part.step[e, s]) for e in part.stable for s in (0, 1)))
        return _message(part, start, goal, (
            f": every candidate needs more than {budget} reorient pushes (step angles up to "
            f"{biggest:.3g} deg{_slip_note(part)}); raise {option('max_reorients')} to {min(over)} or more"))
    tried = (f"; {len(over)} candidates needing {min(over)} to {max(over)} reorient pushes, over {budget}, "
             f"were not tried: raise {option('max_reorients')}" if over else "")
    return _message(part, start, goal, f": no candidate positively spans the required translation"
                                       f"{_slip_note(part)}{tried}")


def _slip_note(part: PushPart) -> str:
    if part.min_fence_mu is None:
        return ""
    return f"; only pushes sticking at min_fence_mu={part.min_fence_mu:g} allowed"


def assemble(part: PushPart, settings: PushOptions, start, goal, cand: Candidate, table: dict,
             weights) -> PushPlan:
    """The plan of a solved candidate, replayed and checked (raises PlanningError
    if the replay disagrees).  Function of ~80 lines: it lists the pushes in
    execution order and fills every field of the plan."""
    ns = len(part.stable)
    w = np.asarray(weights).reshape(len(cand.thetas), ns)
    hull = part.polygon.hull_index
    sidx = {e: i for i, e in enumerate(part.stable)}
    drop = pose_lp.DROP * part.size
    items = []  # (kind, direction, distance, hull edge, pivot, min, rotation)
    for i, th in enumerate(cand.thetas):
        if i >= 1:
            st = cand.steps[i - 1]
            ang = th + part.omega[sidx[st.edge]]
            items.append(("reorient", (math.cos(ang), math.sin(ang)),
                          float(cand.need[i - 1] + w[i, sidx[st.edge]]), st.edge,
                          int(part.pivot[st.edge, st.sense]), float(cand.least[i - 1]),
                          float(th - cand.thetas[i - 1])))
        for j, e in enumerate(part.stable):
            if (i >= 1 and e == cand.steps[i - 1].edge) or w[i, j] <= drop:
                continue
            ang = th + part.omega[j]
            items.append(("translate", (math.cos(ang), math.sin(ang)), float(w[i, j]), e, None, None, None))
    dirs = np.array([it[1] for it in items]).reshape(-1, 2)
    dists = np.array([it[2] for it in items])
    poses, err, problems = verify(part, start, goal, dirs, dists, [it[3] for it in items])
    if problems:
        raise PlanningError("the exact replay of the plan does not reach the goal: " + listed(problems))
    pushes = tuple(
        Push(kind=k, direction=(float(d[0]), float(d[1])), distance=dist,
             edge=part.polygon.edge_vertices(e), contact_vertex=None if pv is None else hull[pv],
             min_distance=mn, pose_after=tuple(float(x) for x in poses[i]), rotation=rot)
        for i, (k, d, dist, e, pv, mn, rot) in enumerate(items))
    if settings.workspace is not None:
        wsp.check_swept(part, settings.workspace, start, goal, items, poses)
    return make_plan(part, settings, start, goal, pushes, int(table["cls"][cand.row]),
                     int(table["turns"][cand.row]), err)


def make_plan(part: PushPart, settings: PushOptions, start, goal, pushes, cls: int, turns: int,
              err) -> PushPlan:
    """A :class:`PushPlan` carrying ``settings`` (the options ``part`` was
    prepared with: its margin, safety factor, support and slip bound; refused
    otherwise) and the distance rule and ``c`` range the part gave."""
    if (part.margin_deg, part.safety_factor, part.min_fence_mu) != (
            settings.margin_deg, settings.safety_factor, settings.min_fence_mu) \
            or part.support != settings.support.family:
        raise ValueError("settings: the part was prepared with other options (margin, safety "
                         "factor, support or fence friction bound) than the plan would record")
    from planning.pushing.plan import PLAN_CLASSES

    total = float(sum(p.distance for p in pushes))
    reo = [p.edge for p in pushes if p.kind == "reorient"]
    main = max(set(reo), key=lambda e: (reo.count(e), -reo.index(e))) if reo else None
    return PushPlan(
        vertices=tuple((float(a), float(b)) for a, b in part.polygon.vertices),
        com=(float(part.polygon.com[0]), float(part.polygon.com[1])),
        start=tuple(float(x) for x in start), goal=tuple(float(x) for x in goal), pushes=pushes,
        plan_class=PLAN_CLASSES[cls], reorient_edge=main, object_class=part.class_name,
        objective_value=float(len(pushes)) if settings.objective == "pushes" else total,
        total_distance=total, final_error=(float(err[0]), float(err[1])), options=settings,
        distance_rule=part.distance_rule, support_c=part.support_c, turns=turns)
