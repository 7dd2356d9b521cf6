"""The pose-vector LP of Akella & Mason, section 4.2, and its closed form.

After the reorient sequence is fixed and the Peshkin lower bounds are moved to
the right-hand side (``b_i = m_i + e_i``, the appendix's substitution), the LP
reads::

    minimise   sum_k x_k
    subject to sum_k x_k u_k = T''     (two equality rows)
               x_k >= 0

where every column ``u_k`` is a unit push direction (world frame): the inward
normals of the stable edges at every orientation of the sequence, the reorient
directions among them.  A basic optimum has at most two non-zero columns, and
because all columns are unit vectors the optimum is closed-form: the columns
are points on the unit circle, the cost of reaching ``T''`` with columns ``a``
and ``b`` is ``|T''|`` divided by the distance along ``T''`` to the chord
``ab``, and that chord is farthest out for the nearest column on each side of
``T''``.  So the LP optimum uses the nearest column counter-clockwise and the
nearest clockwise of ``T''``; it is infeasible when they are pi or more apart
(the columns do not positively span ``T''``).

``objective="pushes"`` is the paper's proposed MILP extension: fewest pushes,
then shortest.  Extending a reorient push (a ``merged`` column: the reorient
edge's own normal right after a reorient) costs no push; any other column
used costs one.  By Caratheodory in the plane the lexicographic optimum again
uses at most two columns, one of four pairs: nearest merged on both sides,
nearest merged on one side and nearest other on the other (both ways), or the
nearest overall.

Functions here take one LP; the batched planner vmaps :func:`solve_jax`.
:func:`solve_cvxpy` is the reference solver (and the MILP reference for
``objective="pushes"``).
"""
from __future__ import annotations

import dataclasses
import math

import jax.numpy as jnp
import numpy as np

from kernels import wrap_angle, wrap_angle_np

# Length tolerances are relative to a length scale ``scale`` (m, the part's size):
ZERO_TARGET = 1e-13  # x scale: a residual translation this small needs no push
DROP = 1e-12         # x scale: a push shorter than this is dropped from the plan
DET_EPS = 1e-12      # columns closer than this to antiparallel do not span
TIE = 1e-12          # rad: columns this close in direction are ties, won by the lower rank


@dataclasses.dataclass(frozen=True)
class LPSolution:
    """Optimum of one pose LP (numpy).

    Attributes:
      feasible: whether the columns positively span the target.
      cost: sum of the weights (m); ``inf`` when infeasible.
      pushes: number of non-merged columns with weight above ``DROP``.
      weights: (K,) non-negative weight per column (m).
    """

    feasible: bool
    cost: float
    pushes: int
    weights: np.ndarray


# --------------------------------------------------------------------------
# Closed form, numpy (one LP)
# --------------------------------------------------------------------------
def _pair_np(angles, target, ia, ib):
    """The pair ``(ia, ib)`` of columns spanning ``target``: ``(ok, cost, xa, xb)``
    (python floats; ``angles`` a list, ``target`` a pair of floats)."""
    ca, sa = math.cos(angles[ia]), math.sin(angles[ia])
    cb, sb = math.cos(angles[ib]), math.sin(angles[ib])
    det = ca * sb - sa * cb
    if ia == ib or abs(det) < DET_EPS:
        # one column along the target (or antiparallel pair: infeasible unless aligned)
        if math.cos(angles[ia] - math.atan2(target[1], target[0])) > 1 - 1e-15:
            n = float(np.hypot(*target))
            return True, n, n, 0.0
        return False, math.inf, 0.0, 0.0
    xa = (target[0] * sb - target[1] * cb) / det
    xb = (ca * target[1] - sa * target[0]) / det
    if xa < -1e-12 or xb < -1e-12:
        return False, math.inf, 0.0, 0.0
    xa, xb = max(xa, 0.0), max(xb, 0.0)
    return True, xa + xb, xa, xb


def _side_nearest(delta: list, mask: list, ccw: bool) -> int:
    """Index of the nearest present column on the CCW side (``ccw``: delta >= 0)
    or the CW side (delta <= 0), -1 if none; columns within ``TIE`` rad of the
    nearest are ties, won by the first in column order.  Python lists: the
    planner solves thousands of LPs of a few columns each, where numpy's
    per-call cost was most of a plan's time (60 % for a uni-stable part)."""
    inf = math.inf
    if ccw:
        dist = [d if (m and d >= 0) else inf for d, m in zip(delta, mask)]
    else:
        dist = [-d if (m and d <= 0) else inf for d, m in zip(delta, mask)]
    best = min(dist, default=inf)
    if best == inf:
        return -1
    cut = best + TIE
    for i, d in enumerate(dist):
        if d <= cut:
            return i
    return -1   # not reached


def solve_closed_form(angles, mask, merged, target, objective="distance", scale=1.0) -> LPSolution:
    """Closed-form optimum of one pose LP (numpy, float64).

    Args:
      angles: (K,) world-frame angles of the unit columns (rad).
      mask: (K,) bool, column present.
      merged: (K,) bool, column extends a reorient push (free for ``pushes``).
      target: (2,) right-hand side ``T''`` (m, world frame).
      objective: ``"distance"`` or ``"pushes"``.
      scale: length scale (m) of the tolerances ``ZERO_TARGET`` and ``DROP``.
    """
    angles = np.asarray(angles, np.float64)
    mask = np.asarray(mask, bool)
    merged = np.asarray(merged, bool) & mask
    target = np.asarray(target, np.float64)
    k = len(angles)
    if np.hypot(*target) <= ZERO_TARGET * scale:
        return LPSolution(True, 0.0, 0, np.zeros(k))
    delta = wrap_angle_np(angles - math.atan2(target[1], target[0])).tolist()
    ang, tgt = angles.tolist(), target.tolist()
    mask_l, merged_l = mask.tolist(), merged.tolist()
    drop = DROP * scale

    def pair(sel_a, sel_b):
        a = _side_nearest(delta, sel_a, True)
        b = _side_nearest(delta, sel_b, False)
        if a < 0 or b < 0:
            return None
        ok, cost, xa, xb = _pair_np(ang, tgt, a, b)
        if not ok:
            return None
        w = {a: xa + xb} if a == b else {a: xa, b: xb}
        npush = sum(1 for i, x in w.items() if x > drop and not merged_l[i])
        return npush, cost, w

    if objective == "distance":
        options = [pair(mask_l, mask_l)]
    elif objective == "pushes":
        other = [m and not g for m, g in zip(mask_l, merged_l)]
        options = [pair(merged_l, merged_l), pair(merged_l, other), pair(other, merged_l),
                   pair(mask_l, mask_l)]
    else:
        raise ValueError(f"objective: expected 'distance' or 'pushes', got {objective!r}")
    options = [o for o in options if o is not None]
    if not options:
        return LPSolution(False, math.inf, 0, np.zeros(k))
    key = (lambda o: (o[0], o[1])) if objective == "pushes" else (lambda o: o[1])
    best = min(options, key=key)
    w = np.zeros(k)
    for i, x in best[2].items():
        w[i] = x
    return LPSolution(True, best[1], best[0], w)


# --------------------------------------------------------------------------
# Closed form, JAX (one LP; vmap it)
# --------------------------------------------------------------------------
def _first_nearest_jax(dist, rank):
    best = jnp.min(dist)
    tie = dist <= best + TIE
    return jnp.argmin(jnp.where(tie, rank, jnp.iinfo(jnp.int32).max)), jnp.isfinite(best)


def _nearest_jax(delta, mask, rank):
    ccw = jnp.where(mask & (delta >= 0), delta, jnp.inf)
    cw = jnp.where(mask & (delta <= 0), -delta, jnp.inf)
    a, oka = _first_nearest_jax(ccw, rank)
    b, okb = _first_nearest_jax(cw, rank)
    return a, oka, b, okb


def solve_delta(delta, mask, merged, norm_t, objective="distance", rank=None, scale=1.0):
    """Closed-form optimum of one pose LP in JAX, with the columns given by
    their angle ``delta`` (rad, in (-pi, pi]) relative to the target direction
    and the target by its length ``norm_t`` (m).  Same rules as
    :func:`solve_closed_form`; ``objective`` is static.  No trigonometry but
    for the chosen pair: with ``da >= 0 >= db`` the weights are
    ``x_a = |T| sin(-db) / sin(da - db)``, ``x_b = |T| sin(da) / sin(da - db)``.

    Columns within ``TIE`` rad of the nearest on a side tie; the lowest
    ``rank`` (default: column order) wins, as in the numpy twin.  ``scale``
    (m) scales the length tolerances.

    Returns:
      ``(feasible, cost, pushes, idx_a, x_a, idx_b, x_b)``: the optimum puts
      weight ``x_a`` on column ``idx_a`` and ``x_b`` on ``idx_b`` (m).
    """
    merged = merged & mask
    zero = norm_t <= ZERO_TARGET * scale
    rank = jnp.arange(delta.shape[0]) if rank is None else rank

    def pair(sel_a, sel_b):
        a, oka, _, _ = _nearest_jax(delta, sel_a, rank)
        _, _, b, okb = _nearest_jax(delta, sel_b, rank)
        da, db = delta[a], delta[b]
        on_a, on_b = da == 0.0, (db == 0.0) & (da != 0.0)
        gap_sin = jnp.sin(da - db)
        spans = gap_sin > DET_EPS
        safe = jnp.where(spans, gap_sin, 1.0)
        xa = jnp.where(on_a, norm_t, jnp.where(on_b, 0.0, norm_t * jnp.sin(-db) / safe))
        xb = jnp.where(on_a, 0.0, jnp.where(on_b, norm_t, norm_t * jnp.sin(da) / safe))
        ok = oka & okb & (on_a | on_b | spans)
        xa, xb = jnp.maximum(xa, 0.0), jnp.maximum(xb, 0.0)
        npush = (jnp.where((xa > DROP * scale) & ~merged[a], 1, 0)
                 + jnp.where((xb > DROP * scale) & ~merged[b] & (a != b), 1, 0))
        return ok, jnp.where(ok, xa + xb, jnp.inf), npush, a, xa, b, xb

    if objective == "distance":
        options = [pair(mask, mask)]
    elif objective == "pushes":
        other = mask & ~merged
        options = [pair(merged, merged), pair(merged, other), pair(other, merged), pair(mask, mask)]
    else:
        raise ValueError(f"objective: expected 'distance' or 'pushes', got {objective!r}")
    ok, cost, npush, a, xa, b, xb = [jnp.stack(v) for v in zip(*options)]
    if objective == "pushes":
        best_n = jnp.min(jnp.where(ok, npush, jnp.iinfo(jnp.int32).max))
        i = jnp.argmin(jnp.where(ok & (npush == best_n), cost, jnp.inf))
    else:
        i = jnp.argmin(jnp.where(ok, cost, jnp.inf))
    feasible = ok[i] | zero
    return (feasible, jnp.where(zero, 0.0, cost[i]), jnp.where(zero, 0, npush[i]),
            a[i], jnp.where(zero, 0.0, xa[i]), b[i], jnp.where(zero, 0.0, xb[i]))


def solve_jax(angles, mask, merged, target, objective="distance", scale=1.0):
    """Closed-form optimum of one pose LP in JAX (same rules as
    :func:`solve_closed_form`; ``objective`` is static).  ``angles`` are the
    world angles of the unit columns (rad), ``target`` is ``T''`` (m).

    Returns:
      ``(feasible, cost, pushes, idx_a, x_a, idx_b, x_b)`` as :func:`solve_delta`.
    """
    psi = jnp.arctan2(target[1], target[0])
    delta = wrap_angle(angles - psi)
    return solve_delta(delta, mask, merged, jnp.hypot(target[0], target[1]), objective, scale=scale)


# --------------------------------------------------------------------------
# Reference: cvxpy
# --------------------------------------------------------------------------
def solve_cvxpy(angles, mask, merged, target, objective="distance", paper_form=True,
                scale=1.0) -> LPSolution:
    """The same LP solved by cvxpy (reference solver), independently of the
    closed form: feasibility is the solver's verdict.

    With ``paper_form`` the two equality rows are the paper's projections on
    ``t'`` and ``t'_perp``; otherwise the x/y components.  ``objective="pushes"``
    is solved as the paper's MILP (binary per non-merged column, big-M), first
    minimising the number of pushes, then the distance at that number.  The
    big-M bound comes from the data alone: a lexicographic optimum is a basic
    solution of at most two columns ``a, b`` (Caratheodory in the plane), whose
    weights are at most ``|T''| / |sin(angle_a - angle_b)|``.
    """
    import cvxpy as cp

    angles = np.asarray(angles, np.float64)
    mask = np.asarray(mask, bool)
    merged = np.asarray(merged, bool) & mask
    target = np.asarray(target, np.float64)
    k = len(angles)
    idx = np.flatnonzero(mask)
    norm_t = float(np.hypot(*target))
    if norm_t <= ZERO_TARGET * scale:
        return LPSolution(True, 0.0, 0, np.zeros(k))
    if len(idx) == 0:
        return LPSolution(False, math.inf, 0, np.zeros(k))
    used = 1e-7 * norm_t   # solver tolerance: weights below this count as zero
    cols = np.stack([np.cos(angles[idx]), np.sin(angles[idx])])
    if paper_form:
        t_hat = target / norm_t
        t_perp = np.array([-t_hat[1], t_hat[0]])
        a_eq = np.stack([t_hat @ cols, t_perp @ cols])
        b_eq = np.array([norm_t, 0.0])
    else:
        a_eq, b_eq = cols, target
    x = cp.Variable(len(idx), nonneg=True)
    cons = [a_eq @ x == b_eq]
    if objective == "distance":
        prob = cp.Problem(cp.Minimize(cp.sum(x)), cons)
        prob.solve(solver=cp.HIGHS) if "HIGHS" in cp.installed_solvers() else prob.solve()
        if prob.status not in ("optimal", "optimal_inaccurate"):
            return LPSolution(False, math.inf, 0, np.zeros(k))
        w = np.zeros(k)
        w[idx] = np.maximum(x.value, 0.0)
        return LPSolution(True, float(prob.value), int(np.sum((w > used) & ~merged)), w)
    if objective != "pushes":
        raise ValueError(f"objective: expected 'distance' or 'pushes', got {objective!r}")
    free = merged[idx]
    z = cp.Variable(len(idx), boolean=True)
    # big-M: the lexicographic optimum is a basic solution of its support (at most two
    # columns a, b), whose weights are at most |T''| / |sin(angle_a - angle_b)|.
    diff = np.abs(np.sin(angles[idx][:, None] - angles[idx][None, :]))
    diff = diff[diff > DET_EPS]
    big_m = 1.01 * norm_t / (diff.min() if diff.size else 1.0) + norm_t
    link = [x[i] <= big_m * z[i] for i in range(len(idx)) if not free[i]]
    count = cp.sum(cp.hstack([z[i] for i in range(len(idx)) if not free[i]])) if (~free).any() else 0
    prob = cp.Problem(cp.Minimize(count), cons + link)
    prob.solve(solver=cp.HIGHS)
    if prob.status not in ("optimal", "optimal_inaccurate"):
        return LPSolution(False, math.inf, 0, np.zeros(k))
    n_best = int(round(prob.value))
    prob2 = cp.Problem(cp.Minimize(cp.sum(x)), cons + link + ([count <= n_best] if (~free).any() else []))
    prob2.solve(solver=cp.HIGHS)
    w = np.zeros(k)
    w[idx] = np.maximum(x.value, 0.0)
    return LPSolution(True, float(prob2.value), n_best, w)
