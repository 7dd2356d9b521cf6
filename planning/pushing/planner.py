"""The Akella-Mason pose planner: fence pushes that take a convex polygon from
any start pose to any goal pose.

Plan classes (paper section 5): a *translation* plan when the start and goal
orientations agree; a *CW* and a *CCW* plan for every stable edge (the reorient
pushes land that edge, the angle-eating heuristic splits the rotation into
step-angle reorientations and a final smaller one); when none of these is
feasible, the *singularity handlers*: a reorient in the opposite sense by the
smaller of the edge's two step angles, then the main sequence.  For each
candidate the pose-vector LP (:mod:`planning.pushing.pose_lp`) fixes the push lengths;
the best candidate by the objective is the plan.  Every plan is replayed by
the exact kinematics (:func:`kernels.push.replay_pushes`) before it is
returned.

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

import jax
import jax.numpy as jnp
import numpy as np

from kernels import polygon as pg
from kernels.planar import angle_distance, rot2_np
from kernels.precision import float64
from kernels.push import replay_pushes
from planning.pushing import pose_lp
from planning.pushing.part import (ANG_TOL, OBJECTIVES, POS_TOL, SAME_ORIENTATION, PlanningError,
                                   PushPart, check_pose, prepare_part)
from planning.pushing.plan import Push, PushPlan

SOLVERS = ("closed_form", "cvxpy")


# --------------------------------------------------------------------------
# Candidates (numpy reference)
# --------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class _Candidate:
    plan_class: str
    edge: int               # hull index of the reorient edge (-1: translation)
    thetas: np.ndarray      # (r+1,) orientations, thetas[0] = start
    senses: np.ndarray      # (r,) CW=0 / CCW=1 per reorient push
    alphas: np.ndarray      # (r,) reorient angles (rad)
    singular: bool


def _rotation_candidate(part: PushPart, theta0: float, thetag: float, s: int, sense: int,
                        singular: bool) -> _Candidate:
    sgn = 1.0 if sense == pg.CCW else -1.0
    step = float(part.step[s, sense])
    pre = float(min(part.step[s, 0], part.step[s, 1])) if singular else 0.0
    delta = float(np.remainder(sgn * (thetag - theta0), 2 * math.pi))
    if delta == 0.0:
        delta = 2 * math.pi
    dp = delta + pre
    n = int(math.ceil(dp / step * (1 - 1e-12)))
    alphas = [step] * (n - 1) + [dp - (n - 1) * step]
    incs = [sgn * a for a in alphas]
    senses = [sense] * n
    if singular:
        alphas = [pre] + alphas
        incs = [-sgn * pre] + incs
        senses = [1 - sense] + senses
    thetas = theta0 + np.concatenate([[0.0], np.cumsum(incs)])
    thetas[-1] = theta0 + sgn * delta
    name = ("singular-" if singular else "") + pg.SENSE_NAMES[sense]
    return _Candidate(name, s, thetas, np.array(senses), np.array(alphas), singular)


def _candidates(part: PushPart, theta0: float, thetag: float) -> tuple[list, list]:
    regular, singular = [], []
    if angle_distance(theta0, thetag) <= SAME_ORIENTATION:
        regular.append(_Candidate("translation", -1, np.array([theta0]), np.zeros(0, int),
                                  np.zeros(0), False))
    for s in part.stable:
        for sense in (pg.CW, pg.CCW):
            regular.append(_rotation_candidate(part, theta0, thetag, s, sense, False))
    for s in part.stable:
        for sense in (pg.CW, pg.CCW):
            singular.append(_rotation_candidate(part, theta0, thetag, s, sense, True))
    return regular, singular


def _candidate_lp(part: PushPart, cand: _Candidate, start, goal):
    """Columns, right-hand side and Peshkin bounds of a candidate (numpy)."""
    body = part.body
    r = len(cand.alphas)
    m = np.zeros(r)
    shift = np.zeros(2)
    pivots = np.zeros(r, int)
    for i in range(r):
        k = cand.edge if cand.senses[i] == pg.CW else (cand.edge + 1) % part.n
        pivots[i] = k
        m[i] = part.peshkin(cand.edge, k, cand.alphas[i])
        rp, rn = rot2_np(cand.thetas[i]), rot2_np(cand.thetas[i + 1])
        th = cand.thetas[i + 1] + part.nu[cand.edge] + math.pi
        shift += rp @ body[k] - rn @ body[k] + m[i] * np.array([math.cos(th), math.sin(th)])
    target = np.asarray(goal[:2]) - np.asarray(start[:2]) - shift
    omega = part.omega
    angles = (cand.thetas[:, None] + omega[None, :]).ravel()
    ns = len(part.stable)
    merged = np.zeros((r + 1, ns), bool)
    if cand.edge >= 0:
        merged[1:, part.stable.index(cand.edge)] = True
    return angles, merged.ravel(), target, m, pivots


# --------------------------------------------------------------------------
# Replay and verification
# --------------------------------------------------------------------------
@jax.jit
def _replay_jit(geom, pose, directions, distances):
    return replay_pushes(geom, pose, directions, distances)


def _verify(part: PushPart, start, goal, directions, distances, edges):
    """Replay pushes (padded to a multiple of 8 to bound recompiles)."""
    p = len(distances)
    pad = max(8, -(-p // 8) * 8)
    dirs = np.zeros((pad, 2))
    dirs[:, 0] = 1.0
    dists = np.zeros(pad)
    if p:
        dirs[:p] = directions
        dists[:p] = distances
    final, outs = _replay_jit(part.geom, jnp.asarray(start), jnp.asarray(dirs), jnp.asarray(dists))
    final = np.asarray(final)
    poses = np.asarray(outs.pose)[:p]
    landed = np.asarray(outs.edge)[:p]
    pos_err = float(np.hypot(*(final[:2] - np.asarray(goal[:2]))))
    ang_err = angle_distance(final[2], goal[2])
    problems = []
    for i, (got, want) in enumerate(zip(landed, edges)):
        if int(got) != int(want):
            problems.append(f"push {i} ended on edge {int(got)} instead of {int(want)}")
    if pos_err >= POS_TOL:
        problems.append(f"position error {pos_err:.3e} m >= {POS_TOL:g} m")
    if ang_err >= ANG_TOL:
        problems.append(f"angle error {ang_err:.3e} rad >= {ANG_TOL:g} rad")
    return poses, (pos_err, ang_err), problems


# --------------------------------------------------------------------------
# Single problem (numpy reference, closed form or cvxpy)
# --------------------------------------------------------------------------
@float64
def plan_pose(vertices, start, goal, com=None, margin_deg: float = 7.0,
              safety_factor: float = 1.15, objective: str = "distance",
              solver: str = "closed_form") -> PushPlan:
    """Plan normal fence pushes taking the part from ``start`` to ``goal``.

    Args:
      vertices: (m, 2) part vertices (m, part frame), any order.
      start, goal: poses ``(x, y, theta)`` (m, m, rad), world frame.
      com: centre of mass (m, part frame), default the area centroid.
      margin_deg: margin angle (degrees) taken off each maximum reorient angle.
      safety_factor: multiplier of the Peshkin distance (paper 1.15).
      objective: ``"distance"`` (total push distance, the paper's LP) or
        ``"pushes"`` (fewest pushes, then shortest: the paper's MILP idea).
      solver: ``"closed_form"`` or ``"cvxpy"`` (reference) for each LP.

    Returns:
      A :class:`~planning.pushing.plan.PushPlan` whose exact replay reaches the
      goal within 1e-9 m and 1e-9 rad.

    Raises:
      ValueError / PartError: bad input, naming the field.
      PlanningError: no candidate is feasible, or the replay disagrees.
    """
    if objective not in OBJECTIVES:
        raise ValueError(f"objective: expected one of {OBJECTIVES}, got {objective!r}")
    if solver not in SOLVERS:
        raise ValueError(f"solver: expected one of {SOLVERS}, got {solver!r}")
    start = check_pose(start, "start")
    goal = check_pose(goal, "goal")
    part = prepare_part(vertices, com, margin_deg, safety_factor)
    solve = pose_lp.solve_closed_form if solver == "closed_form" else pose_lp.solve_cvxpy
    regular, singular = _candidates(part, float(start[2]), float(goal[2]))
    best = None
    for group in (regular, singular):
        for cand in group:
            angles, merged, target, m, pivots = _candidate_lp(part, cand, start, goal)
            sol = solve(angles, np.ones(len(angles), bool), merged, target, objective)
            if not sol.feasible:
                continue
            total = float(m.sum() + sol.cost)
            n_push = len(m) + sol.pushes
            key = (n_push, total) if objective == "pushes" else (total,)
            if best is None or key < best[0]:
                best = (key, cand, sol, m, pivots, total)
        if best is not None:
            break
    if best is None:
        raise PlanningError(
            f"no feasible pose plan for this {part.class_name} part from {start.tolist()} to "
            f"{goal.tolist()}: no candidate's push directions positively span the required "
            "translation (this contradicts the paper's completeness proof; please report it)")
    _, cand, sol, m, pivots, total = best
    return _assemble(part, start, goal, cand, sol.weights, m, pivots, objective, margin_deg)


def _assemble(part: PushPart, start, goal, cand: _Candidate, weights, m, pivots, objective,
              margin_deg) -> PushPlan:
    ns = len(part.stable)
    w = np.asarray(weights).reshape(len(cand.thetas), ns)
    omega = part.omega
    hull = part.polygon.hull_index
    s_idx = part.stable.index(cand.edge) if cand.edge >= 0 else -1
    items = []  # (kind, direction, distance, hull edge, pivot, min)
    for i, th in enumerate(cand.thetas):
        if i >= 1:
            ang = th + omega[s_idx]
            items.append(("reorient", (math.cos(ang), math.sin(ang)), float(m[i - 1] + w[i, s_idx]),
                          cand.edge, int(pivots[i - 1]), float(m[i - 1])))
        for j, e in enumerate(part.stable):
            if (i >= 1 and j == s_idx) or w[i, j] <= pose_lp.DROP:
                continue
            ang = th + omega[j]
            items.append(("translate", (math.cos(ang), math.sin(ang)), float(w[i, j]), e, None, None))
    dirs = np.array([it[1] for it in items]).reshape(-1, 2)
    dists = np.array([it[2] for it in items])
    poses, err, problems = _verify(part, start, goal, dirs, dists, [it[3] for it in items])
    if problems:
        raise PlanningError("the exact replay of the plan does not reach the goal: "
                            + "; ".join(problems))
    pushes = tuple(
        Push(kind=k, direction=(float(d[0]), float(d[1])), distance=dist,
             edge=part.polygon.edge_vertices(e), contact_vertex=None if pv is None else hull[pv],
             min_distance=mn, pose_after=tuple(float(x) for x in poses[i]))
        for i, (k, d, dist, e, pv, mn) in enumerate(items))
    total = float(sum(p.distance for p in pushes))
    return PushPlan(
        vertices=tuple((float(a), float(b)) for a, b in part.polygon.vertices),
        com=(float(part.polygon.com[0]), float(part.polygon.com[1])),
        start=tuple(float(x) for x in start), goal=tuple(float(x) for x in goal), pushes=pushes,
        plan_class=cand.plan_class,
        reorient_edge=None if cand.edge < 0 else part.polygon.edge_vertices(cand.edge),
        object_class=part.class_name, objective=objective,
        objective_value=float(len(pushes)) if objective == "pushes" else total,
        total_distance=total, margin_deg=float(margin_deg), safety_factor=part.safety_factor,
        final_error=err)
