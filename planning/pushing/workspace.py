"""Plans inside a rectangular workspace ``(xmin, xmax, ymin, ymax)`` (world
frame, metres): every pose of the plan, and the part swept during every push,
stays inside.

For a fixed reorientation sequence every position of the plan is affine in the
pose LP's push lengths ``w`` (:mod:`planning.pushing.pose_lp`), so the
workspace adds linear inequalities to the LP:

* after every push, the part at its orientation ``theta`` lies inside: its
  centre of mass lies in the workspace shrunk by the part's extent at
  ``theta`` (the extreme vertices, ``R(theta) v``);
* during a reorient push the part turns about the pivot ``P`` from
  ``theta_{i-1}`` to ``theta_i`` while ``P`` advances along the push direction
  ``d`` by at most the push's minimum distance ``m`` (the slowest rotation the
  distance rule allows completes by then), then translates.  The swept set lies
  in ``P0 + [0, m] d + {R(theta) (v_k - v_P)}``, ``theta`` over the arc and ``k``
  over the vertices: its bounding box is the pivot's segment plus the exact
  bounding box of every vertex's arc (:func:`arc_box`).  The translation that
  follows sweeps the hull of two parts that are inside (convexity);
* a translation push sweeps the hull of its start and end parts.

Where the closed-form optimum already satisfies them it is the optimum of the
constrained LP too; otherwise :func:`solve_in_workspace` solves the LP with
HiGHS (scipy) and polishes the equality rows on the optimum's support.
:func:`swept_boxes` bounds the swept part of a finished plan push by push (the
check every plan with a workspace passes).
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from kernels import rot2_np
from planning.pushing.part import PlanningError


# A reorient's pivot is taken to advance its minimum distance times 1 + SWEEP_GUARD
# while the part turns (the rotation may complete a rounding later): the LP rows
# and the check of a finished plan use the same length.
SWEEP_GUARD = 1e-9


def part_extent(body: np.ndarray, theta: float) -> np.ndarray:
    """``(min x, max x, min y, max y)`` of the part's vertices about its centre
    of mass at orientation ``theta`` (m)."""
    w = body @ rot2_np(theta).T
    return np.array([w[:, 0].min(), w[:, 0].max(), w[:, 1].min(), w[:, 1].max()])


def arc_box(points: np.ndarray, theta_a: float, theta_b: float) -> np.ndarray:
    """Bounding box ``(min x, max x, min y, max y)`` of the points ``R(theta) p``
    for ``theta`` between ``theta_a`` and ``theta_b`` (rad, either order): each
    point's arc, its end points and the axis crossings inside it."""
    lo, hi = min(theta_a, theta_b), max(theta_a, theta_b)
    r = np.hypot(points[:, 0], points[:, 1])
    phi = np.arctan2(points[:, 1], points[:, 0])
    box = np.array([np.inf, -np.inf, np.inf, -np.inf])
    for t in (lo, hi):
        w = points @ rot2_np(t).T
        box = np.array([min(box[0], w[:, 0].min()), max(box[1], w[:, 0].max()),
                        min(box[2], w[:, 1].min()), max(box[3], w[:, 1].max())])
    # an arc through angle q (absolute) reaches the axis extreme at q = 0, pi/2, pi, 3pi/2
    for q, (idx, sign, comp) in zip((0.0, 0.5 * math.pi, math.pi, 1.5 * math.pi),
                                    ((1, 1, 0), (3, 1, 1), (0, -1, 0), (2, -1, 1))):
        # does phi_k + theta hit q (mod 2 pi) for some theta in [lo, hi]?
        first = lo + np.remainder(q - phi - lo, 2 * math.pi)
        hit = first <= hi
        if np.any(hit):
            val = sign * r[hit].max()
            box[idx] = max(box[idx], val) if sign > 0 else min(box[idx], val)
    return box


@dataclasses.dataclass(frozen=True)
class Events:
    """The pushes of one candidate in execution order, as affine maps of the
    LP weights: push ``q`` moves the centre of mass by ``const[q] + w[col[q]] *
    unit[q]`` (``col`` -1: no weight) and ends at orientation ``theta[q]``;
    reorient pushes carry their swept box about the pivot's start
    (``sweep[q]``, NaN for translations) and the pivot's body offset."""

    const: np.ndarray    # (Q, 2)
    col: np.ndarray      # (Q,)
    unit: np.ndarray     # (Q, 2)
    theta: np.ndarray    # (Q,)
    sweep: np.ndarray    # (Q, 4) box of the swept part relative to the pivot's start, or NaN
    pivot_off: np.ndarray  # (Q, 2) R(theta_before) v_pivot (pivot's start relative to the com)


def constraint_rows(ev: Events, body: np.ndarray, start_xy, n_cols: int):
    """Linear constraints ``A w <= b`` that keep the plan inside the workspace,
    written as ``(A_lo, b_lo, A_hi, b_hi)``: for every constrained quantity
    ``q(w) = a + G w`` (x or y) the lower bound ``q >= lo`` and upper ``q <= hi``
    become rows; returned as ``(G (R, K), a (R,), kind (R,) 0..3)`` with kind
    0 min x, 1 max x, 2 min y, 3 max y: the quantity is the extreme coordinate
    of the part (after a push) or of the swept box (during a reorient push)."""
    Q = len(ev.col)
    G_rows, a_rows, kinds = [], [], []
    pos_a = np.asarray(start_xy, float).copy()
    pos_G = np.zeros((2, n_cols))
    for q in range(Q):
        prev_a, prev_G = pos_a.copy(), pos_G.copy()
        pos_a = pos_a + ev.const[q]
        if ev.col[q] >= 0:
            pos_G[:, ev.col[q]] += ev.unit[q]
        ext = part_extent(body, ev.theta[q])
        for kind in range(4):
            comp = kind // 2
            G_rows.append(pos_G[comp].copy())
            a_rows.append(pos_a[comp] + ext[kind])
            kinds.append(kind)
        if not np.isnan(ev.sweep[q, 0]):
            for kind in range(4):
                comp = kind // 2
                G_rows.append(prev_G[comp].copy())
                a_rows.append(prev_a[comp] + ev.pivot_off[q, comp] + ev.sweep[q, kind])
                kinds.append(kind)
    return np.array(G_rows).reshape(-1, n_cols), np.array(a_rows), np.array(kinds, int)


def violation(G, a, kinds, workspace, w) -> float:
    """Largest amount (m) by which the quantities ``a + G w`` leave the workspace."""
    q = a + G @ w
    bound = np.asarray(workspace)[kinds]
    lower = kinds % 2 == 0
    over = np.where(lower, bound - q, q - bound)
    return float(over.max()) if len(over) else 0.0


def needed_box(G, a, kinds, w) -> np.ndarray:
    """The smallest workspace ``(xmin, xmax, ymin, ymax)`` (m) that holds the plan of weights ``w``."""
    q = a + G @ w
    return np.array([q[kinds == 0].min(), q[kinds == 1].max(), q[kinds == 2].min(), q[kinds == 3].max()])


def solve_in_workspace(cols: np.ndarray, target: np.ndarray, G, a, kinds, workspace, tol: float):
    """Minimise ``sum w`` subject to ``cols w = target``, ``w >= 0`` and the
    workspace rows (HiGHS via scipy).  Returns the weights (K,) or None when
    infeasible.  The equality rows are polished on the optimum's support (a
    least-norm correction of the solver's ~1e-9 residual) and the result is
    checked against every row to ``tol`` (m)."""
    from scipy.optimize import linprog

    ws = np.asarray(workspace, float)
    lower = kinds % 2 == 0
    # q = a + G w ; lower: q >= lo  <=>  -G w <= a - lo ; upper: G w <= hi - a
    A_ub = np.where(lower[:, None], -G, G)
    b_ub = np.where(lower, a - ws[kinds], ws[kinds] - a)
    res = linprog(np.ones(cols.shape[1]), A_ub=A_ub, b_ub=b_ub, A_eq=cols, b_eq=target,
                  bounds=(0, None), method="highs",
                  options=dict(primal_feasibility_tolerance=1e-10, dual_feasibility_tolerance=1e-10))
    if res.status != 0 or res.x is None:
        return None
    w = np.maximum(res.x, 0.0)
    support = np.flatnonzero(w > 1e-12 * max(1.0, float(np.abs(target).sum())))
    if len(support):
        A = cols[:, support]
        resid = target - cols @ w
        corr, *_ = np.linalg.lstsq(A, resid, rcond=None)
        w[support] = np.maximum(w[support] + corr, 0.0)
    if np.hypot(*(cols @ w - target)) > tol or violation(G, a, kinds, ws, w) > tol:
        return None
    return w


def smallest_scale(cols: np.ndarray, target: np.ndarray, G, a, kinds, workspace) -> float:
    """The least factor ``s`` by which ``workspace``, scaled about its centre,
    holds a plan of this candidate (its push lengths free: the LP in
    ``(w, s)``, minimise ``s`` subject to ``cols w = target``, ``w >= 0`` and
    every row inside the scaled workspace; HiGHS via scipy).  ``inf`` when the
    solver finds none."""
    from scipy.optimize import linprog

    ws = np.asarray(workspace, float)
    centre = np.array([0.5 * (ws[0] + ws[1])] * 2 + [0.5 * (ws[2] + ws[3])] * 2)
    half = np.array([0.5 * (ws[1] - ws[0])] * 2 + [0.5 * (ws[3] - ws[2])] * 2)
    lower = kinds % 2 == 0
    # lower: a + G w >= c - s h  <=>  -G w - h s <= a - c ;  upper: G w - h s <= c - a
    A_ub = np.c_[np.where(lower[:, None], -G, G), -half[kinds]]
    b_ub = np.where(lower, a - centre[kinds], centre[kinds] - a)
    c = np.zeros(cols.shape[1] + 1)
    c[-1] = 1.0
    res = linprog(c, A_ub=A_ub, b_ub=b_ub, A_eq=np.c_[cols, np.zeros(2)], b_eq=target,
                  bounds=(0, None), method="highs")
    return float(res.x[-1]) if res.status == 0 and res.x is not None else math.inf


def smallest_workspace(found: list, workspace, tries: int = 16):
    """``(scale, box)``: the least scale (:func:`smallest_scale`) of ``workspace``
    about its centre over the candidates in ``found`` (``(needed box, cols,
    target, G, a, kinds)`` per candidate whose unconstrained optimum did not
    fit, as :func:`fit` records them; the ``tries`` with the smallest needed
    boxes are solved), and that scaled workspace ``(xmin, xmax, ymin, ymax)`` (m)."""
    ws = np.asarray(workspace, float)
    order = sorted(found, key=lambda f: (f[0][1] - f[0][0]) * (f[0][3] - f[0][2]))[:tries]
    scale = min((smallest_scale(*f[1:], ws) for f in order), default=math.inf)
    cx, cy = 0.5 * (ws[0] + ws[1]), 0.5 * (ws[2] + ws[3])
    hx, hy = 0.5 * (ws[1] - ws[0]) * scale, 0.5 * (ws[3] - ws[2]) * scale
    return scale, np.array([cx - hx, cx + hx, cy - hy, cy + hy])


def swept_boxes(body: np.ndarray, start, directions, poses_after, pivots, rotations,
                min_distances) -> np.ndarray:
    """Bounding boxes ``(Q, 4)`` ``(xmin, xmax, ymin, ymax)`` of the part swept by
    each push of a finished plan (m, world frame).

    Args:
      body: (n, 2) hull vertices, body frame.
      start: start pose; directions (Q, 2) unit push directions; poses_after
        (Q, 3) the replayed poses after each push.
      pivots: (Q,) body-frame pivot vertex of each reorient push, -1 for translations.
      rotations: (Q,) signed rotation of each push (rad); min_distances (Q,)
        the travel within which a reorient completes (m).

    A translation sweeps the hull of its end parts; a reorient push also the
    box of the module docstring around its rotation.
    """
    boxes = []
    pose = np.asarray(start, float)
    for d, end, piv, rot, mdist in zip(np.asarray(directions, float), np.asarray(poses_after, float),
                                       pivots, rotations, min_distances):
        b0 = part_extent(body, pose[2]) + np.repeat(pose[:2], 2)
        b1 = part_extent(body, end[2]) + np.repeat(end[:2], 2)
        box = np.array([min(b0[0], b1[0]), max(b0[1], b1[1]), min(b0[2], b1[2]), max(b0[3], b1[3])])
        if piv >= 0:
            v = body[piv]
            p0 = pose[:2] + rot2_np(pose[2]) @ v
            arc = arc_box(body - v, pose[2], pose[2] + rot)
            seg = np.array([min(0.0, mdist * d[0]), max(0.0, mdist * d[0]),
                            min(0.0, mdist * d[1]), max(0.0, mdist * d[1])])
            sw = np.repeat(p0, 2) + seg + arc
            box = np.array([min(box[0], sw[0]), max(box[1], sw[1]), min(box[2], sw[2]), max(box[3], sw[3])])
        boxes.append(box)
        pose = end
    return np.array(boxes).reshape(-1, 4)


# --------------------------------------------------------------------------
# The planner's use of the above (a candidate of planning.pushing.planner)
# --------------------------------------------------------------------------
def events(part, cand) -> Events:
    """The candidate's pushes in execution order as affine maps of the LP weights
    (reorient i, then the translations at orientation i by stable edge)."""
    ns = len(part.stable)
    sidx = {e: i for i, e in enumerate(part.stable)}
    const, col, unit, theta, sweep, poff = [], [], [], [], [], []
    for i, th in enumerate(cand.thetas):
        if i >= 1:
            st = cand.steps[i - 1]
            c = (i) * ns + sidx[st.edge]
            piv = int(part.pivot[st.edge, st.sense])
            v = part.body[piv]
            d = np.array([math.cos(cand.angles[c]), math.sin(cand.angles[c])])
            arc = arc_box(part.body - v, cand.thetas[i - 1], th)
            m = max(float(cand.need[i - 1]), float(cand.least[i - 1]) * (1.0 + SWEEP_GUARD))
            seg = np.array([min(0.0, m * d[0]), max(0.0, m * d[0]), min(0.0, m * d[1]), max(0.0, m * d[1])])
            const.append(cand.shifts[i - 1]); col.append(c); unit.append(d); theta.append(th)
            sweep.append(seg + arc); poff.append(rot2_np(cand.thetas[i - 1]) @ v)
        for j in range(ns):
            c = i * ns + j
            if cand.merged[c]:
                continue
            const.append(np.zeros(2)); col.append(c); theta.append(th)
            unit.append(np.array([math.cos(cand.angles[c]), math.sin(cand.angles[c])]))
            sweep.append(np.full(4, np.nan)); poff.append(np.zeros(2))
    return Events(np.array(const).reshape(-1, 2), np.array(col, int), np.array(unit).reshape(-1, 2),
                      np.array(theta), np.array(sweep).reshape(-1, 4), np.array(poff).reshape(-1, 2))


def outside(box, ws, tol: float) -> bool:
    """True when the box ``(xmin, xmax, ymin, ymax)`` (m) leaves the workspace
    ``ws`` by more than ``tol`` (m) on some side."""
    return bool(box[0] < ws[0] - tol or box[1] > ws[1] + tol or box[2] < ws[2] - tol
                or box[3] > ws[3] + tol)


def pose_box(part, pose) -> np.ndarray:
    """Bounding box ``(xmin, xmax, ymin, ymax)`` (m, world) of the part at ``pose``."""
    return part_extent(part.body, float(pose[2])) + np.repeat(np.asarray(pose[:2], float), 2)


def check_inside(part, ws, pose, field: str) -> None:
    """Raise ValueError (naming ``workspace``) if the part at ``pose`` is not inside."""
    ext = pose_box(part, pose)
    if outside(ext, ws, part.pos_tol(*pose[:2])):
        raise ValueError(f"workspace: the part at the {field} pose {_numbers(pose)} spans "
                         f"x [{ext[0]:.6g}, {ext[1]:.6g}], y [{ext[2]:.6g}, {ext[3]:.6g}] m, not inside "
                         f"the workspace {_numbers(ws)}; give a workspace (--workspace, planner.workspace) "
                         f"that holds the {field} pose")


def fit(part, cand, w, ws, start, boxes):
    """The candidate's LP optimum inside the workspace: the closed form's if it
    fits, else the constrained LP's; None when none fits.  Appends ``(box the
    unconstrained optimum needs, LP data)`` to ``boxes`` (for the error
    message's :func:`smallest_workspace`)."""
    ev = events(part, cand)
    G, a, kinds = constraint_rows(ev, part.body, np.asarray(start[:2], float), len(cand.angles))
    tol = part.pos_tol(*start[:2])
    if violation(G, a, kinds, ws, w) <= tol:
        return w
    cols = np.stack([np.cos(cand.angles), np.sin(cand.angles)])
    boxes.append((needed_box(G, a, kinds, w), cols, cand.target, G, a, kinds))
    return solve_in_workspace(cols, cand.target, G, a, kinds, ws, tol)


def plan_tol(part, start, goal, total: float) -> float:
    """Tolerance (m) of the swept check of a finished plan from ``start`` to
    ``goal`` pushing ``total`` (m): the fit's (a plan on the workspace's edge
    may leave it by ``pos_tol`` at the start) plus the replay's (the pose error
    the planner's verification allows)."""
    return float(part.pos_tol(*np.asarray(start[:2], float))
                 + part.pos_tol(math.hypot(*start[:2]), math.hypot(*goal[:2]), total))


def check_swept(part, ws, start, goal, items, poses) -> None:
    """The swept-part check of a plan with a workspace (raises PlanningError)."""
    boxes = swept_boxes(part.body, start, [it[1] for it in items], poses,
                            [-1 if it[4] is None else it[4] for it in items],
                            [0.0 if it[6] is None else it[6] for it in items],
                            [0.0 if it[5] is None else it[5] * (1.0 + SWEEP_GUARD) for it in items])
    tol = plan_tol(part, start, goal, sum(it[2] for it in items))
    for i, b in enumerate(boxes):
        if outside(b, ws, tol):
            raise PlanningError(f"push {i} sweeps the part over x [{b[0]:.6g}, {b[1]:.6g}], y "
                                f"[{b[2]:.6g}, {b[3]:.6g}] m, outside the workspace {_numbers(ws)}")


def _numbers(values) -> str:
    """``[a, b, ...]`` with 6 significant digits (messages)."""
    return "[" + ", ".join(f"{float(x):.6g}" for x in values) + "]"
