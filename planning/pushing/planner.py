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

Two implementations share these rules: :func:`plan_pose` (one problem,
readable numpy, LP by the closed form or by cvxpy) and
:func:`plan_pose_batch` (many start/goal pairs of one part, JAX, jit + vmap).
They agree plan for plan (tested).

Frames: world frame, metres, radians CCW.  Pose ``(x, y, theta)``:
``p_world = R(theta) (p - com) + (x, y)``.
"""
from __future__ import annotations

import dataclasses
import functools
import math
from typing import Optional

import jax
import jax.numpy as jnp
import numpy as np

from kernels import polygon as pg
from kernels.push import replay_pushes
from planning.pushing import pose_lp
from planning.pushing.plan import PLAN_CLASSES, Push, PushPlan, angle_error

jax.config.update("jax_enable_x64", True)

POS_TOL = 1e-9   # m: a plan must reach the goal position this closely (replayed)
ANG_TOL = 1e-9   # rad: and the goal orientation
SAME_ORIENTATION = 1e-12  # rad: start and goal orientations this close admit a translation plan
OBJECTIVES = ("distance", "pushes")
SOLVERS = ("closed_form", "cvxpy")


class PlanningError(RuntimeError):
    """No plan could be produced or verified; the message says why."""


# --------------------------------------------------------------------------
# Part preparation (host side)
# --------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True, eq=False)
class PushPart:
    """A validated part with the planner's tables (numpy, float64, body frame).

    Attributes:
      polygon: the validated :class:`kernels.polygon.Polygon`.
      geom: its :class:`kernels.polygon.PolygonGeometry` (JAX float64).
      stable: hull indices of the stable edges, increasing.
      max_reorient: (n, 2) maximum reorient angles (rad), columns CW, CCW.
      step: (n, 2) step angles (rad) after the margin.
      object_class: 0 uni-, 1 biplus-, 2 nice-stable.
      margin: margin angle (rad); safety_factor: Peshkin multiplier.
    """

    polygon: pg.Polygon
    geom: pg.PolygonGeometry
    stable: tuple[int, ...]
    max_reorient: np.ndarray
    step: np.ndarray
    object_class: int
    margin: float
    safety_factor: float

    @property
    def n(self) -> int:
        return self.polygon.n

    @property
    def body(self) -> np.ndarray:
        return self.polygon.body

    @property
    def nu(self) -> np.ndarray:
        return np.asarray(self.geom.nu)

    @property
    def class_name(self) -> str:
        return pg.OBJECT_CLASS_NAMES[self.object_class]


def _check_number(value, field: str, lo=None, hi=None, lo_open=False, hint="") -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{field}: expected a number, got {value!r}") from None
    if not math.isfinite(v):
        raise ValueError(f"{field}: must be finite, got {v}")
    if lo is not None and (v < lo or (lo_open and v == lo)):
        raise ValueError(f"{field}: must be {'>' if lo_open else '>='} {lo}, got {v}{hint}")
    if hi is not None and v >= hi:
        raise ValueError(f"{field}: must be < {hi}, got {v}{hint}")
    return v


def check_pose(pose, field: str) -> np.ndarray:
    """Validate a pose ``(x, y, theta)``; returns a float64 array."""
    try:
        arr = np.asarray(pose, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{field}: expected (x, y, theta) numbers, got {pose!r}") from None
    if arr.shape[-1:] != (3,):
        raise ValueError(f"{field}: expected (x, y, theta) (m, m, rad), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{field}: holds NaN or inf; give finite x, y (m) and theta (rad)")
    return arr


@functools.lru_cache(maxsize=64)
def _prepare_cached(vkey: bytes, vshape, ckey, margin_deg: float, safety_factor: float) -> PushPart:
    vertices = np.frombuffer(vkey, dtype=np.float64).reshape(vshape)
    com = None if ckey is None else np.frombuffer(ckey, dtype=np.float64)
    poly = pg.make_polygon(vertices, com)
    margin = math.radians(margin_deg)
    geom, mx, step, cls = _part_tables(jnp.asarray(poly.body), margin)
    stable = tuple(int(e) for e in np.flatnonzero(np.asarray(geom.stable)))
    return PushPart(polygon=poly, geom=geom, stable=stable, max_reorient=np.asarray(mx),
                    step=np.asarray(step), object_class=int(cls), margin=margin,
                    safety_factor=float(safety_factor))


@jax.jit
def _part_tables(body, margin):
    geom = pg.polygon_geometry(body)
    mx = pg.max_reorient_table(geom)
    return geom, mx, pg.step_angle(mx, margin), pg.object_class(geom)


def prepare_part(vertices, com=None, margin_deg: float = 7.0, safety_factor: float = 1.15) -> PushPart:
    """Validate a part and the planner settings and build the planner's tables.

    Args:
      vertices: (m, 2) part vertices (m), any order (non-convex: hull, with a warning).
      com: optional centre of mass (m), default the area centroid.
      margin_deg: margin angle in degrees, 0 < margin < 90.
      safety_factor: multiplier of the Peshkin distance, >= 1.
    """
    margin_deg = _check_number(margin_deg, "margin_deg", 0.0, 90.0, lo_open=True,
                               hint="; at zero a reorient from the divergent orientation needs an "
                                    "infinite push (the paper uses 7 degrees)")
    safety_factor = _check_number(safety_factor, "safety_factor", 1.0,
                                  hint="; below 1 the Peshkin guarantee is lost (paper: 1.15)")
    v = pg._as_points(vertices, "vertices", 2)
    ckey = None
    if com is not None:
        c = np.asarray(com, dtype=np.float64)
        if c.shape != (2,):
            raise pg.PartError(f"com: expected [x, y], got shape {c.shape}")
        if not np.all(np.isfinite(c)):
            raise pg.PartError("com: holds NaN or inf; give a finite centre of mass in metres")
        ckey = c.tobytes()
    return _prepare_cached(np.ascontiguousarray(v).tobytes(), v.shape, ckey, margin_deg, safety_factor)


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
    if abs(angle_error(theta0, thetag)) <= SAME_ORIENTATION:
        regular.append(_Candidate("translation", -1, np.array([theta0]), np.zeros(0, int),
                                  np.zeros(0), False))
    for s in part.stable:
        for sense in (pg.CW, pg.CCW):
            regular.append(_rotation_candidate(part, theta0, thetag, s, sense, False))
    for s in part.stable:
        for sense in (pg.CW, pg.CCW):
            singular.append(_rotation_candidate(part, theta0, thetag, s, sense, True))
    return regular, singular


def _omega(part: PushPart) -> np.ndarray:
    """Body-frame angle of each stable edge's push direction (into the edge)."""
    return part.nu[list(part.stable)] + math.pi


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
        m[i] = _peshkin_np(part, cand.edge, k, cand.alphas[i])
        rp, rn = _rot(cand.thetas[i]), _rot(cand.thetas[i + 1])
        th = cand.thetas[i + 1] + part.nu[cand.edge] + math.pi
        shift += rp @ body[k] - rn @ body[k] + m[i] * np.array([math.cos(th), math.sin(th)])
    target = np.asarray(goal[:2]) - np.asarray(start[:2]) - shift
    omega = _omega(part)
    angles = (cand.thetas[:, None] + omega[None, :]).ravel()
    ns = len(part.stable)
    merged = np.zeros((r + 1, ns), bool)
    if cand.edge >= 0:
        merged[1:, part.stable.index(cand.edge)] = True
    return angles, merged.ravel(), target, m, pivots


def _peshkin_np(part: PushPart, edge: int, pivot: int, alpha: float) -> float:
    """numpy twin of :func:`kernels.polygon.peshkin_distance` (times the safety factor)."""
    v = part.body[pivot]
    u = np.array([math.cos(part.nu[edge]), math.sin(part.nu[edge])])
    c = math.hypot(v[0], v[1])
    radius = float(np.max(np.hypot(part.body[:, 0], part.body[:, 1])))
    beta2 = math.atan2(abs(u[0] * v[1] - u[1] * v[0]), float(u @ v))
    k = (radius ** 2 + c ** 2) / c
    return part.safety_factor * k * (math.log(math.tan(0.5 * beta2)) - math.log(math.tan(0.5 * (beta2 - alpha))))


def _rot(theta: float) -> np.ndarray:
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s], [s, c]])


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
    ang_err = angle_error(float(final[2]), float(goal[2]))
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
    omega = _omega(part)
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


# --------------------------------------------------------------------------
# Batched planner (JAX)
# --------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True, eq=False)
class PushPlanBatch:
    """Plans for many start/goal pairs of one part (numpy arrays, leading axis B).

    Attributes:
      part: the prepared part; starts, goals: (B, 3) poses.
      objective, margin_deg: settings.
      ok: (B,) plan found and verified by replay.
      plan_class: (B,) index into ``PLAN_CLASSES``; reorient_edge: (B,) hull edge (-1 none).
      total_distance: (B,) m; n_pushes: (B,).
      kind: (B, P) 0 none / 1 translate / 2 reorient; angle (B, P) world angle of
      the fence direction (rad; ``direction`` gives unit vectors);
      distance (B, P) m; edge (B, P) hull edge; contact (B, P) hull vertex or -1;
      min_distance (B, P) m; pose_after (B, P, 3) replayed; final_error (B, 2).
    """

    part: PushPart
    starts: np.ndarray
    goals: np.ndarray
    objective: str
    margin_deg: float
    ok: np.ndarray
    plan_class: np.ndarray
    reorient_edge: np.ndarray
    total_distance: np.ndarray
    n_pushes: np.ndarray
    kind: np.ndarray
    angle: np.ndarray
    distance: np.ndarray
    edge: np.ndarray
    contact: np.ndarray
    min_distance: np.ndarray
    pose_after: np.ndarray
    final_error: np.ndarray

    def __len__(self) -> int:
        return len(self.ok)

    @property
    def direction(self) -> np.ndarray:
        """(B, P, 2) unit fence directions, world frame (computed from ``angle``)."""
        return np.stack([np.cos(self.angle), np.sin(self.angle)], -1)

    def plan(self, b: int) -> PushPlan:
        """The b-th plan as a :class:`PushPlan` (raises PlanningError if not ok)."""
        if not self.ok[b]:
            raise PlanningError(f"plan {b}: no verified plan (final error {self.final_error[b].tolist()})")
        poly = self.part.polygon
        hull = poly.hull_index
        pushes = []
        for i in range(self.kind.shape[1]):
            k = int(self.kind[b, i])
            if k == 0:
                continue
            reo = k == 2
            pushes.append(Push(
                kind="reorient" if reo else "translate",
                direction=(math.cos(self.angle[b, i]), math.sin(self.angle[b, i])),
                distance=float(self.distance[b, i]), edge=poly.edge_vertices(int(self.edge[b, i])),
                contact_vertex=hull[int(self.contact[b, i])] if reo else None,
                min_distance=float(self.min_distance[b, i]) if reo else None,
                pose_after=tuple(float(x) for x in self.pose_after[b, i])))
        total = float(sum(p.distance for p in pushes))
        re = int(self.reorient_edge[b])
        return PushPlan(
            vertices=tuple((float(a), float(c)) for a, c in poly.vertices),
            com=(float(poly.com[0]), float(poly.com[1])),
            start=tuple(float(x) for x in self.starts[b]), goal=tuple(float(x) for x in self.goals[b]),
            pushes=tuple(pushes), plan_class=PLAN_CLASSES[int(self.plan_class[b])],
            reorient_edge=None if re < 0 else poly.edge_vertices(re),
            object_class=self.part.class_name, objective=self.objective,
            objective_value=float(len(pushes)) if self.objective == "pushes" else total,
            total_distance=total, margin_deg=self.margin_deg,
            safety_factor=self.part.safety_factor,
            final_error=(float(self.final_error[b, 0]), float(self.final_error[b, 1])))

    def to_plans(self) -> list[PushPlan]:
        """All plans (raises on the first that is not ok)."""
        return [self.plan(b) for b in range(len(self))]


def _candidate_table(part: PushPart) -> tuple[dict, int]:
    """Static candidate list in the numpy reference's order (translation, then
    (edge, CW/CCW) regular, then (edge, CW/CCW) singular) with everything that
    does not depend on the start and goal precomputed: step angles, the
    singular pre-step, pivots, and the Peshkin distances of full steps."""
    rows = [dict(cls=0, s=0, sidx=0, sense=0, sing=0, trans=1, step=1.0, pre=0.0, piv=0, piv_pre=0,
                 m_step=0.0, m_pre=0.0, k_main=1.0, lt_main=0.0, b2_main=1.0)]
    for sing in (0, 1):
        for sidx, s in enumerate(part.stable):
            for sense in (pg.CW, pg.CCW):
                step = float(part.step[s, sense])
                pre = float(min(part.step[s, 0], part.step[s, 1])) if sing else 0.0
                piv = s if sense == pg.CW else (s + 1) % part.n
                piv_pre = (s + 1) % part.n if sense == pg.CW else s
                v = part.body[piv]
                u = np.array([math.cos(part.nu[s]), math.sin(part.nu[s])])
                c = math.hypot(*v)
                radius = float(np.max(np.hypot(part.body[:, 0], part.body[:, 1])))
                b2 = math.atan2(abs(u[0] * v[1] - u[1] * v[0]), float(u @ v))
                rows.append(dict(cls=(3 if sing else 1) + sense, s=s, sidx=sidx, sense=sense,
                                 sing=sing, trans=0, step=step, pre=pre, piv=piv, piv_pre=piv_pre,
                                 m_step=_peshkin_np(part, s, piv, step),
                                 m_pre=_peshkin_np(part, s, piv_pre, pre) if sing else 0.0,
                                 k_main=part.safety_factor * (radius ** 2 + c ** 2) / c,
                                 lt_main=math.log(math.tan(0.5 * b2)), b2_main=b2))
    table = {k: np.array([r[k] for r in rows]) for k in rows[0]}
    r_max = max(int(math.ceil((2 * math.pi + r["pre"]) / r["step"])) + r["sing"]
                for r in rows if not r["trans"])
    return table, r_max


def _progression_deltas(a, sigma, count, psi):
    """Nearest terms of an arithmetic progression of column angles.

    The columns ``a + sigma t`` (rad), ``t = 1..count``, ``0 < |sigma| < pi``,
    span less than 5 pi.  Relative to direction ``psi`` the terms that can be
    nearest on either side are both ends and the terms on each side of every
    crossing of a multiple of 2 pi; there are at most two crossings.  Returns
    ``(t, delta)`` for those six terms, ``delta`` the term's angle relative to
    ``psi`` wrapped to (-pi, pi], computed with arithmetic only.
    """
    sg = jnp.sign(sigma)
    st = jnp.abs(sigma)
    y0 = sg * (a + sigma - psi)                               # term t = 1, mirrored to increase
    y0 = y0 - 2 * jnp.pi * jnp.floor(y0 / (2 * jnp.pi))       # in [0, 2 pi) (cheaper than remainder)
    c1 = jnp.ceil((2 * jnp.pi - y0) / st)
    c2 = jnp.ceil((4 * jnp.pi - y0) / st)
    last = jnp.maximum(count - 1, 0).astype(y0.dtype)
    off = jnp.clip(jnp.stack([jnp.zeros_like(c1), c1 - 1, c1, c2 - 1, c2, last]), 0, last)
    z = y0 + st * off - 2 * jnp.pi * ((off >= c1).astype(y0.dtype) + (off >= c2).astype(y0.dtype))
    z = jnp.where(z > jnp.pi, z - 2 * jnp.pi, z)
    return off.astype(jnp.int32) + 1, sg * z


def _wrap(a):
    return -jnp.remainder(-a + jnp.pi, 2 * jnp.pi) + jnp.pi


def _wrap_near(a):
    """Wrap angles of a few turns to [-pi, pi] with a rounding instead of a
    remainder (the hot loop's column angles; ties at +-pi are immaterial there)."""
    return a - 2 * jnp.pi * jnp.round(a / (2 * jnp.pi))


@functools.lru_cache(maxsize=32)
def _plan_fn(part: PushPart, objective: str, singular: bool):
    """jit(vmap) of the batched planner over (starts, goals) -> compact plans.

    ``singular=False`` evaluates the translation and regular CW/CCW
    candidates; ``True`` the singularity handlers (run only for the pairs
    that the regular candidates cannot serve).
    """
    table, R = _candidate_table(part)
    keep = (table["sing"] == 1) if singular else (table["sing"] == 0)
    ns = len(part.stable)
    body = jnp.asarray(part.body)
    stable = jnp.asarray(np.array(part.stable))
    omega = jnp.asarray(_omega(part))
    cand = {k: jnp.asarray(v[keep]) for k, v in table.items()}
    rows_r = jnp.arange(1, R + 1)
    js = jnp.arange(ns)

    def rotv(th, v):
        c, s = jnp.cos(th), jnp.sin(th)
        return jnp.stack([c * v[0] - s * v[1], s * v[0] + c * v[1]])

    def unit(a):
        return jnp.stack([jnp.cos(a), jnp.sin(a)], -1)

    def eval_cand(theta0, thetag, T, c):
        trans = c["trans"] == 1
        sing = c["sing"]
        sgn = jnp.where(c["sense"] == pg.CCW, 1.0, -1.0)
        delta = jnp.remainder(sgn * (thetag - theta0), 2 * jnp.pi)
        delta = jnp.where(delta == 0.0, 2 * jnp.pi, delta)
        dp = delta + c["pre"]
        n = jnp.ceil(dp / c["step"] * (1 - 1e-12)).astype(jnp.int32)
        a_last = dp - (n - 1) * c["step"]
        r = jnp.where(trans, 0, n + sing)
        th1 = theta0 - sgn * c["pre"]
        base = jnp.where(sing == 1, th1, theta0)
        thf = theta0 + sgn * delta
        m_last = c["k_main"] * (c["lt_main"] - jnp.log(jnp.tan(0.5 * (c["b2_main"] - a_last))))
        sum_m = (n - 1) * c["m_step"] + m_last + sing * c["m_pre"]
        # centre-of-mass shifts telescope: sum_i R(th_{i-1}) v - R(th_i) v
        v, vp = body[c["piv"]], body[c["piv_pre"]]
        shift = rotv(base, v) - rotv(thf, v) + sing * (rotv(theta0, vp) - rotv(th1, vp))
        # Peshkin parts along the reorient directions: a geometric sum over the full steps
        sig = sgn * c["step"]
        k = (n - 1).astype(sig.dtype)
        geo = jnp.sin(0.5 * k * sig) / jnp.sin(0.5 * sig)
        ws = omega[c["sidx"]]
        shift = (shift + c["m_step"] * geo * unit(base + ws + 0.5 * (k + 1) * sig)
                 + m_last * unit(thf + ws) + sing * c["m_pre"] * unit(th1 + ws))
        target = jnp.where(trans, T, T - shift)
        sum_m = jnp.where(trans, 0.0, sum_m)
        psi = jnp.arctan2(target[1], target[0])
        # reduced column set, as angles relative to the target: per stable edge, the start,
        # pre-step and final orientations and the progression terms nearest the target
        t_prog, d_prog = jax.vmap(lambda w: _progression_deltas(base + w, sig, n - 1, psi))(omega)
        rows = jnp.concatenate([jnp.zeros((ns, 1), jnp.int32), jnp.ones((ns, 1), jnp.int32),
                                jnp.broadcast_to(r, (ns, 1)).astype(jnp.int32), sing + t_prog], 1)
        dlt = jnp.concatenate([_wrap_near(theta0 + omega - psi)[:, None],
                               _wrap_near(th1 + omega - psi)[:, None],
                               _wrap_near(thf + omega - psi)[:, None], d_prog], 1)
        valid = jnp.concatenate([jnp.ones((ns, 1), bool), jnp.broadcast_to(sing == 1, (ns, 1)),
                                 jnp.broadcast_to(~trans, (ns, 1)),
                                 jnp.broadcast_to((n >= 2) & ~trans, (ns, 6))], 1)
        merged = (js[:, None] == c["sidx"]) & (rows >= 1) & valid
        edges = jnp.broadcast_to(js[:, None], rows.shape)
        ok_c = jnp.where(trans, jnp.abs(_wrap(thetag - theta0)) <= SAME_ORIENTATION, True)
        rank = (rows * ns + edges).ravel()   # ties go to the earliest (orientation, edge), as in plan_pose
        feas, cost, npush, ia, xa, ib, xb = pose_lp.solve_delta(
            dlt.ravel(), valid.ravel(), merged.ravel(), jnp.hypot(target[0], target[1]), objective, rank)
        feas = feas & ok_c
        fl = lambda x: x.ravel()
        return dict(feas=feas, total=jnp.where(feas, sum_m + cost, jnp.inf), npush=r + npush, r=r,
                    a_last=a_last, m_last=m_last, th1=th1, base=base, thf=thf, sig=sig,
                    row_a=fl(rows)[ia], col_a=fl(edges)[ia], ang_a=psi + fl(dlt)[ia],
                    mrg_a=fl(merged)[ia], xa=xa,
                    row_b=fl(rows)[ib], col_b=fl(edges)[ib], ang_b=psi + fl(dlt)[ib],
                    mrg_b=fl(merged)[ib], xb=jnp.where(ia == ib, 0.0, xb))

    def plan_one(start, goal):
        theta0, thetag = start[2], goal[2]
        res = jax.vmap(eval_cand, in_axes=(None, None, None, 0))(theta0, thetag, goal[:2] - start[:2], cand)
        if objective == "pushes":
            bn = jnp.min(jnp.where(res["feas"], res["npush"], jnp.iinfo(jnp.int32).max))
            ci = jnp.argmin(jnp.where(res["feas"] & (res["npush"] == bn), res["total"], jnp.inf))
        else:
            ci = jnp.argmin(jnp.where(res["feas"], res["total"], jnp.inf))
        g = jax.tree_util.tree_map(lambda x: x[ci], res)
        c = jax.tree_util.tree_map(lambda x: x[ci], cand)
        r, sing = g["r"], c["sing"]
        # reorient pushes at rows 1..R (live up to r)
        is_pre = (sing == 1) & (rows_r == 1)
        is_last = rows_r == r
        th = jnp.where(is_pre, g["th1"], jnp.where(is_last, g["thf"], g["base"] + g["sig"] * (rows_r - sing)))
        m = jnp.where(is_pre, c["m_pre"], jnp.where(is_last, g["m_last"], c["m_step"]))
        ext = (jnp.where(g["mrg_a"] & (g["row_a"] == rows_r), g["xa"], 0.0)
               + jnp.where(g["mrg_b"] & (g["row_b"] == rows_r), g["xb"], 0.0))
        live = rows_r <= r
        # at most two translation pushes: the LP's basic columns that do not extend a reorient
        tr_live = jnp.stack([~g["mrg_a"] & (g["xa"] > pose_lp.DROP), ~g["mrg_b"] & (g["xb"] > pose_lp.DROP)])
        # execution order: reorient i, then the translations at orientation i by stable edge;
        # positions are counted, not sorted: a reorient follows the translations at earlier
        # orientations, a translation follows the reorients up to its orientation
        tr_row = jnp.stack([g["row_a"], g["row_b"]])
        tr_key = tr_row * (ns + 1) + jnp.stack([g["col_a"], g["col_b"]])
        n_before_reo = jnp.sum(tr_live[None, :] & (tr_row[None, :] < rows_r[:, None]), axis=1)
        pos_reo = jnp.where(live, rows_r - 1 + n_before_reo, R + 2)
        other_first = tr_live[::-1] & ((tr_key[::-1] < tr_key) | ((tr_key[::-1] == tr_key) & (jnp.arange(2) == 1)))
        pos_tr = jnp.where(tr_live, jnp.minimum(tr_row, r) + other_first, R + 2)
        pos = jnp.concatenate([pos_reo, pos_tr])
        used_in = jnp.concatenate([live, tr_live]) & g["feas"]
        pos = jnp.where(used_in, pos, R + 2)

        def place(vals, fill):
            return jnp.full(R + 2, fill, vals.dtype).at[pos].set(vals, mode="drop")

        piv = jnp.where(is_pre, c["piv_pre"], c["piv"])
        used = place(used_in, False)
        kind = place(jnp.concatenate([jnp.full(R, 2), jnp.ones(2, jnp.int32)]), 0)
        ang = place(_wrap(jnp.concatenate([th + omega[c["sidx"]], jnp.stack([g["ang_a"], g["ang_b"]])])), 0.0)
        dist = place(jnp.concatenate([m + ext, jnp.stack([g["xa"], g["xb"]])]), 0.0)
        edge = place(jnp.concatenate([jnp.full(R, c["s"]), stable[jnp.stack([g["col_a"], g["col_b"]])]]), -1)
        contact = place(jnp.concatenate([piv, jnp.full(2, -1)]), -1)
        mind = place(jnp.concatenate([m, jnp.zeros(2)]), 0.0)
        return dict(feasible=g["feas"], plan_class=c["cls"],
                    reorient_edge=jnp.where(c["trans"] == 1, -1, c["s"]), n_pushes=jnp.sum(used),
                    kind=kind, angle=ang, distance=dist, edge=edge, contact=contact, min_distance=mind)

    return jax.jit(jax.vmap(plan_one)), R + 2


@functools.lru_cache(maxsize=64)
def _replay_fn(part: PushPart, length: int):
    """jit(vmap) of the exact replay of ``length`` pushes, with per-plan checks."""
    geom = part.geom

    def one(start, goal, angles, dists, edges, kinds):
        dirs = jnp.stack([jnp.cos(angles), jnp.sin(angles)], -1)
        final, outs = replay_pushes(geom, start, dirs, dists)
        landed = jnp.all(jnp.where(kinds > 0, outs.edge == edges, True))
        pos_err = jnp.hypot(final[0] - goal[0], final[1] - goal[1])
        ang_err = jnp.abs(pg.wrap_angle(final[2] - goal[2]))
        return outs.pose, landed, jnp.stack([pos_err, ang_err])

    return jax.jit(jax.vmap(one))


def _blocks(n_items: int, size: int):
    for lo in range(0, n_items, size):
        yield lo, min(lo + size, n_items)


def _padded(arr: np.ndarray, size: int) -> np.ndarray:
    k = len(arr)
    if k == size:
        return arr
    return np.concatenate([arr, np.repeat(arr[-1:], size - k, 0)])


def plan_pose_batch(vertices, starts, goals, com=None, margin_deg: float = 7.0,
                    safety_factor: float = 1.15, objective: str = "distance",
                    chunk: Optional[int] = 1024) -> PushPlanBatch:
    """Plan many start/goal pairs of one part at once (JAX, float64).

    Same rules and results as :func:`plan_pose` (closed-form LP).  Per
    candidate the work is O(stable edges), independent of the number of
    reorient steps: the centre-of-mass shifts telescope, the Peshkin parts of
    the full steps are a geometric sum, and only the few columns of each
    arithmetic progression of push directions that can bracket the target are
    handed to the LP.  Every plan is then replayed by the exact kinematics
    (plans sorted by length so that each block replays only as many pushes
    as its longest plan).

    Args:
      vertices, com, margin_deg, safety_factor, objective: as :func:`plan_pose`.
      starts, goals: (B, 3) poses ``(x, y, theta)`` (m, m, rad), world frame.
      chunk: pairs per compiled call (bounds memory; the last block is padded
        so one compilation serves every block).

    Returns:
      A :class:`PushPlanBatch`; ``ok[b]`` says whether plan ``b`` was found
      and verified (``plan(b)`` raises for one that was not).
    """
    if objective not in OBJECTIVES:
        raise ValueError(f"objective: expected one of {OBJECTIVES}, got {objective!r}")
    starts = np.atleast_2d(check_pose(starts, "starts"))
    goals = np.atleast_2d(check_pose(goals, "goals"))
    if starts.shape != goals.shape or starts.ndim != 2:
        raise ValueError(f"starts/goals: expected two (B, 3) arrays, got {starts.shape} and {goals.shape}")
    B = len(starts)
    if B == 0:
        raise ValueError("starts: need at least one start/goal pair")
    part = prepare_part(vertices, com, margin_deg, safety_factor)
    size = min(B, int(chunk)) if chunk else B

    def run_plan(singular, sel):
        fn, P = _plan_fn(part, objective, singular)
        spans = list(_blocks(len(sel), size))
        # dispatch every block before reading any back: JAX runs them asynchronously
        pending = [fn(jnp.asarray(_padded(starts[sel[lo:hi]], size)),
                      jnp.asarray(_padded(goals[sel[lo:hi]], size))) for lo, hi in spans]
        blocks = [{k: np.asarray(v)[:hi - lo] for k, v in o.items()}
                  for o, (lo, hi) in zip(pending, spans)]
        return {k: np.concatenate([blk[k] for blk in blocks]) for k in blocks[0]}, P

    out, P = run_plan(False, np.arange(B))
    hard = np.flatnonzero(~out["feasible"])
    if len(hard):  # the singularity handlers, only where the regular candidates fail
        sub, _ = run_plan(True, hard)
        for k in out:
            out[k][hard] = sub[k]
    # replay, shortest plans first, each block only as long as its longest plan
    # (even lengths bound the number of compilations)
    used_len = max(1, int(out["n_pushes"].max()))
    out = {k: (v[:, :used_len] if v.ndim == 2 else v) for k, v in out.items()}
    order = np.argsort(out["n_pushes"], kind="stable")
    pose_after = np.zeros((B, used_len, 3))
    landed = np.zeros(B, bool)
    final_error = np.zeros((B, 2))
    pending = []
    for lo, hi in _blocks(B, size):
        idx = order[lo:hi]
        need = int(out["n_pushes"][idx].max())
        length = min(used_len, max(2, need + (need % 2)))
        rf = _replay_fn(part, length)
        args = [starts[idx], goals[idx], out["angle"][idx, :length], out["distance"][idx, :length],
                out["edge"][idx, :length], out["kind"][idx, :length]]
        pending.append((idx, length, rf(*[jnp.asarray(_padded(a, size)) for a in args])))
    for idx, length, (poses, lnd, err) in pending:
        k = len(idx)
        pose_after[idx, :length] = np.asarray(poses)[:k]
        landed[idx] = np.asarray(lnd)[:k]
        final_error[idx] = np.asarray(err)[:k]
    pose_after[out["kind"] == 0] = 0.0
    ok = out.pop("feasible") & landed & (final_error[:, 0] < POS_TOL) & (final_error[:, 1] < ANG_TOL)
    total = out["distance"].sum(axis=1)
    return PushPlanBatch(part=part, starts=starts, goals=goals, objective=objective,
                         margin_deg=float(margin_deg), ok=ok, total_distance=total,
                         pose_after=pose_after, final_error=final_error, **out)
