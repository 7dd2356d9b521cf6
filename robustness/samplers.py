"""Perturbation samplers: what the supplier makes and what the robot does.

Each sampler draws ``n`` perturbations from an explicit ``jax.random`` key and
returns ``(batched_params, in_axes)``, the way mujoco_playground's domain
randomizers do: ``batched_params`` is a frozen pytree dataclass whose sampled
fields have a leading axis of length ``n``; ``in_axes`` is the same dataclass
holding ``0`` on those fields and ``None`` on the fields that were not sampled
(a zero tolerance leaves the nominal value, unbatched), ready for
``jax.vmap(f, in_axes=(in_axes,))(batched_params)``.  All functions are pure:
the same key gives the same draws, bit for bit on the same machine.

Three groups, each drawn from its own sub-key (``jax.random.fold_in(key, g)``,
g = 0 geometry, 1 friction, 2 execution), so that changing one group's
settings never changes another group's draws:

* **geometry** (:class:`GeometryTolerance`): an offset of every coordinate of
  every vertex of the caller's list (metres, part frame), uniform in the box
  ``[-tau_v, tau_v]`` or Gaussian with ``sigma_v`` truncated to that box; an
  offset of the centre of mass, uniform in the disc (ball) or the box of
  half-width ``tau_com``.  Offsets never leave the box, so the analytic bounds
  of :mod:`robustness.bounds` (box tolerances) apply.  A perturbed polygon may
  stop being convex in the nominal vertex order (:func:`polygon_hull_changed`);
  a perturbed polyhedron's hull may change its faces
  (:func:`polyhedron_combinatorics_changed`): the evaluation reports both per
  sample and never pretends the nominal combinatorics still hold.
* **friction** (:class:`FrictionRange`): the fence-part coefficient ``mu_f``
  (uniform in a range); the support pressure distribution: ``support_points``
  points uniform in the part's nominal (body-frame) polygon with
  Dirichlet(``weight_concentration``) weights (an integer), giving the
  limit-surface ratio ``c = m_max / f_max`` (m, ``0 < c <= a``) through
  :func:`kernels.quasistatic.limit_surface_ratio`; the support coefficient
  ``mu_s`` (uniform in a range).  ``mu_s`` is recorded but CANCELS OUT of the
  quasi-static kinematics: both the support force and the support moment
  scale with ``mu_s``, so the motion depends only on their ratio ``c`` (and on
  ``mu_f`` at the fence).
* **execution** (:class:`ExecutionTolerance`): the start-pose error ``(dx, dy,
  dtheta)``; per push, the fence angle error (the push direction is rotated by
  it), a relative and an absolute push-distance error
  (``distance' = distance * (1 + rel) + abs``); per tumble, a small planar
  slip ``(dx, dy, dtheta)`` applied to the part after it lands.  Uniform in
  the boxes by default, or truncated Gaussians (``sigma = half-width / 2``).

Units: metres, radians; a relative distance error is a fraction.
"""
from __future__ import annotations

import dataclasses
import functools
from typing import Any, Optional, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from kernels.precision import float64
from robustness.tolerances import ExecutionTolerance, FrictionRange, GeometryTolerance

GEOMETRY, FRICTION, EXECUTION = 0, 1, 2


# --------------------------------------------------------------------------
# Sampled parameters (JAX pytrees)
# --------------------------------------------------------------------------
@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class GeometryParams:
    """One part's geometry perturbation.

    Attributes:
      vertex_offset: (m, d) offset of each caller vertex, part frame, m.
      com_offset: (d,) offset of the centre of mass, part frame, m.
    """

    vertex_offset: Any
    com_offset: Any


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class FrictionParams:
    """One sample's friction.

    Attributes:
      mu_f: () fence-part coefficient.
      mu_s: () support coefficient (cancels out of quasi-static kinematics).
      c: () limit-surface ratio ``m_max / f_max``, m.
      support_points: (S, 2) support points, body frame (relative to the
        centre of mass), m; zeros when ``c`` was drawn directly.
      support_weights: (S,) their weights (sum 1).
    """

    mu_f: Any
    mu_s: Any
    c: Any
    support_points: Any
    support_weights: Any


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class ExecutionParams:
    """One sample's execution errors.

    Attributes:
      start_offset: (3,) start-pose error ``(dx m, dy m, dtheta rad)``.
      fence_angle: (P,) fence angle error per push, rad.
      distance_rel: (P,) relative push-distance error per push.
      distance_abs: (P,) absolute push-distance error per push, m.
      tumble_slip: (L, 3) slip ``(dx m, dy m, dtheta rad)`` after each tumble.
    """

    start_offset: Any
    fence_angle: Any
    distance_rel: Any
    distance_abs: Any
    tumble_slip: Any


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class PerturbationParams:
    """Everything one Monte-Carlo sample perturbs."""

    geometry: GeometryParams
    friction: FrictionParams
    execution: ExecutionParams


# --------------------------------------------------------------------------
# Drawing helpers
# --------------------------------------------------------------------------
# Each group draws ONE block of uniforms, shape (n, width), from its key and
# transforms slices of it (inverse CDFs): one random-bits call per group keeps
# compilation fast, and the block's layout does not depend on which
# tolerances are zero, so e.g. changing tau_com leaves the vertex draws as
# they were.
def _open01(u, dtype):
    """Uniforms moved into the open interval (0, 1) (for logs and ndtri)."""
    tiny = jnp.finfo(dtype).eps
    return jnp.clip(u, tiny, 1.0 - tiny)


def _box_from_u(u, half: float, distribution: str, sigma: Optional[float], dtype):
    """Offsets in [-half, half] from uniforms ``u``: uniform, or a Gaussian of
    std ``sigma`` (default half / 2) truncated to the box (inverse CDF)."""
    if half == 0.0:
        return jnp.zeros(u.shape, dtype)
    if distribution == "uniform":
        return (2.0 * u - 1.0) * half
    sd = 0.5 * half if sigma is None else float(sigma)
    if sd == 0.0:
        return jnp.zeros(u.shape, dtype)
    lim = half / sd
    lo = jax.scipy.special.ndtr(jnp.asarray(-lim, dtype))
    hi = jax.scipy.special.ndtr(jnp.asarray(lim, dtype))
    z = jax.scipy.special.ndtri(_open01(lo + u * (hi - lo), dtype))
    return sd * jnp.clip(z, -lim, lim)


def _ball_from_u(u, radius: float, dtype):
    """Uniform in the ball (disc) of ``radius`` from uniforms ``u`` (n, dim+1)."""
    dim = u.shape[1] - 1
    g = jax.scipy.special.ndtri(_open01(u[:, :dim], dtype))
    g = g / jnp.maximum(jnp.linalg.norm(g, axis=1, keepdims=True), jnp.finfo(dtype).tiny)
    return g * (radius * u[:, dim:] ** (1.0 / dim))


def _batched(x, n: int, half_is_zero: bool, shape: tuple, dtype):
    """(value, axis): unbatched zeros with axis None when the tolerance is zero."""
    if half_is_zero or n == 0:
        return jnp.zeros(shape, dtype), None
    return x, 0


def _sample_geometry(key, n: int, tol: GeometryTolerance, n_vertices: int, dim: int,
                     dtype=jnp.float64):
    mv = n_vertices * dim
    u = jax.random.uniform(key, (n, mv + dim + 1), dtype)
    dv = _box_from_u(u[:, :mv], float(tol.tau_v), tol.distribution,
                     tol.sigma if tol.distribution == "gaussian" else None, dtype)
    dv, av = _batched(dv.reshape(n, n_vertices, dim), n, tol.tau_v == 0.0, (n_vertices, dim), dtype)
    uc = u[:, mv:]
    if tol.com_shape == "box":
        dc = (2.0 * uc[:, :dim] - 1.0) * tol.tau_com
    else:
        dc = _ball_from_u(uc, float(tol.tau_com), dtype)
    dc, ac = _batched(dc, n, tol.tau_com == 0.0, (dim,), dtype)
    return GeometryParams(dv, dc), GeometryParams(av, ac)


def _range_from_u(u, n: int, rng: tuple, dtype):
    lo, hi = rng
    if hi == lo or n == 0:
        return jnp.asarray(lo, dtype), None
    return lo + u * (hi - lo), 0


def support_from_u(u, body, n_points: int, concentration: int, dtype):
    """Support pressure distributions from uniforms ``u`` (n, S (3 + k)): points
    uniform in the convex polygon ``body`` (body frame, CCW, the centre of mass
    strictly inside; triangle fan from it, a triangle chosen by area) and
    Dirichlet(k, ..., k) weights (normalised sums of k unit exponentials).
    Every point lies in the part, so ``c = sum w |p| <= a`` (the largest vertex
    radius), the range in which the quasi-static kernel's rotation is at least
    Peshkin's bound.  The pressure centroid is not forced under the centre of
    mass: the ellipsoidal limit surface about the centre of mass uses only
    ``c``.

    Returns ``(points (n, S, 2), weights (n, S))``.
    """
    n = u.shape[0]
    S, k = int(n_points), int(concentration)
    body = jnp.asarray(body, dtype)
    nxt = jnp.roll(body, -1, axis=0)
    area = jnp.maximum(0.5 * (body[:, 0] * nxt[:, 1] - body[:, 1] * nxt[:, 0]), 0.0)
    cdf = jnp.cumsum(area) / jnp.sum(area)
    ut = u[:, :S]
    tri = jnp.minimum(jnp.searchsorted(cdf, ut * cdf[-1], side="right"), body.shape[0] - 1)
    uv = u[:, S:3 * S].reshape(n, S, 2)
    flip = jnp.sum(uv, axis=-1, keepdims=True) > 1.0
    uv = jnp.where(flip, 1.0 - uv, uv)
    pts = uv[..., :1] * body[tri] + uv[..., 1:] * nxt[tri]
    ue = _open01(u[:, 3 * S:3 * S + S * k].reshape(n, S, k), dtype)
    g = jnp.sum(-jnp.log(ue), axis=-1)
    w = g / jnp.sum(g, axis=-1, keepdims=True)
    return pts, w


def _sample_friction(key, body, n: int, rng: FrictionRange, has_body: bool, dtype=jnp.float64):
    S, k = int(rng.support_points), int(rng.weight_concentration)
    u = jax.random.uniform(key, (n, 3 + S * (3 + k)), dtype)
    mu_f, a_f = _range_from_u(u[:, 0], n, rng.mu_f, dtype)
    mu_s, a_s = _range_from_u(u[:, 1], n, rng.mu_s, dtype)
    if rng.c is not None:
        c, a_c = _range_from_u(u[:, 2], n, rng.c, dtype)
        pts, a_p = jnp.zeros((S, 2), dtype), None
        w, a_w = jnp.full((S,), 1.0 / S, dtype), None
    elif not has_body or n == 0:
        c, a_c = jnp.asarray(jnp.nan, dtype), None
        pts, a_p = jnp.zeros((S, 2), dtype), None
        w, a_w = jnp.full((S,), 1.0 / S, dtype), None
    else:
        from kernels.quasistatic import limit_surface_ratio

        pts, w = support_from_u(u[:, 3:], body, S, k, dtype)
        c = jax.vmap(limit_surface_ratio)(pts, w).astype(dtype)
        a_c = a_p = a_w = 0
    return (FrictionParams(mu_f, mu_s, c, pts, w),
            FrictionParams(a_f, a_s, a_c, a_p, a_w))


def _sample_execution(key, n: int, tol: ExecutionTolerance, n_pushes: int = 0,
                      n_tumbles: int = 0, dtype=jnp.float64):
    P, L = int(n_pushes), int(n_tumbles)
    u = jax.random.uniform(key, (n, 3 + 3 * P + 3 * L), dtype)
    dist = tol.distribution

    def box(cols, half):
        return _box_from_u(cols, float(half), dist, None, dtype)

    halves = jnp.asarray([tol.start_xy, tol.start_xy, tol.start_theta], dtype)
    if dist == "uniform":
        start = (2.0 * u[:, :3] - 1.0) * halves
    else:
        start = jnp.stack([box(u[:, 0], tol.start_xy), box(u[:, 1], tol.start_xy),
                           box(u[:, 2], tol.start_theta)], axis=1)
    start, a_start = _batched(start, n, tol.start_xy == 0.0 and tol.start_theta == 0.0, (3,), dtype)
    fence, a_fence = _batched(box(u[:, 3:3 + P], tol.fence_angle), n, tol.fence_angle == 0.0 or P == 0,
                              (P,), dtype)
    rel, a_rel = _batched(box(u[:, 3 + P:3 + 2 * P], tol.distance_rel), n,
                          tol.distance_rel == 0.0 or P == 0, (P,), dtype)
    ab, a_ab = _batched(box(u[:, 3 + 2 * P:3 + 3 * P], tol.distance_abs), n,
                        tol.distance_abs == 0.0 or P == 0, (P,), dtype)
    us = u[:, 3 + 3 * P:].reshape(n, L, 3)
    slip = jnp.concatenate([box(us[..., :2], tol.tumble_slip_xy),
                            box(us[..., 2:], tol.tumble_slip_theta)], axis=-1)
    slip, a_slip = _batched(slip, n, (tol.tumble_slip_xy == 0.0 and tol.tumble_slip_theta == 0.0)
                            or L == 0, (L, 3), dtype)
    return (ExecutionParams(start, fence, rel, ab, slip),
            ExecutionParams(a_start, a_fence, a_rel, a_ab, a_slip))


# --------------------------------------------------------------------------
# Compiled entry points
# --------------------------------------------------------------------------
@functools.lru_cache(maxsize=128)
def _staged(fn, static: tuple):
    """``fn(*dynamic, *static) -> (params, axes)`` compiled once per static
    settings: the arrays come from a jitted call, the (Python) axes are
    captured while it is traced."""
    box = {}

    def arrays(*dynamic):
        p, a = fn(*dynamic, *static)
        box["axes"] = a
        return p

    return jax.jit(arrays), box


def _run_staged(fn, dynamic: tuple, static: tuple):
    jitted, box = _staged(fn, static)
    params = jitted(*dynamic)
    return params, box["axes"]


def _dtype(dtype):
    return jnp.dtype(dtype).type


def _sample_all(key, body, n, sampler, n_vertices, dim, n_pushes, n_tumbles, has_body, dtype):
    g, ga = _sample_geometry(jax.random.fold_in(key, GEOMETRY), n, sampler.geometry, n_vertices,
                             dim, dtype)
    f, fa = _sample_friction(jax.random.fold_in(key, FRICTION), body, n, sampler.friction,
                             has_body, dtype)
    e, ea = _sample_execution(jax.random.fold_in(key, EXECUTION), n, sampler.execution, n_pushes,
                              n_tumbles, dtype)
    return PerturbationParams(g, f, e), PerturbationParams(ga, fa, ea)


@dataclasses.dataclass(frozen=True)
class Sampler:
    """All three groups of perturbations for one plan.

    Attributes:
      geometry: :class:`GeometryTolerance`.
      friction: :class:`FrictionRange`.
      execution: :class:`ExecutionTolerance`.
    """

    geometry: GeometryTolerance = GeometryTolerance()
    friction: FrictionRange = FrictionRange()
    execution: ExecutionTolerance = ExecutionTolerance()

    @float64
    def sample(self, key, n: int, *, n_vertices: int, dim: int, n_pushes: int = 0,
               n_tumbles: int = 0, body=None, dtype=jnp.float64):
        """Draw ``n`` perturbations; returns ``(PerturbationParams, in_axes)``.

        ``body``: the nominal body-frame polygon for the support points (push
        parts), ``None`` for tumbled polyhedra.
        """
        dt = _dtype(dtype)
        has_body = body is not None
        b = jnp.asarray(body, dt) if has_body else jnp.zeros((3, 2), dt)
        # one compiled call for the three groups (same draws as the three functions)
        return _run_staged(_sample_all, (key, b), (int(n), self, int(n_vertices), int(dim),
                                                   int(n_pushes), int(n_tumbles), has_body, dt))

    def is_zero(self) -> bool:
        """True when every tolerance is zero (the nominal part and execution)."""
        g, e = self.geometry, self.execution
        return (g.tau_v == 0 and g.tau_com == 0 and all(
            getattr(e, f.name) == 0 for f in dataclasses.fields(e) if f.name != "distribution"))


# --------------------------------------------------------------------------
# Batch helpers
# --------------------------------------------------------------------------
def broadcast(params, in_axes, n: int):
    """Give every unbatched field (axis ``None``) a leading axis of length n."""
    return jax.tree_util.tree_map(
        lambda x, a: x if a == 0 else jnp.broadcast_to(x, (n,) + jnp.shape(x)),
        params, in_axes, is_leaf=lambda x: x is None)


def take(params, in_axes, i):
    """Sample ``i`` (or an index array) of a batch."""
    return jax.tree_util.tree_map(lambda x, a: x if a is None else x[i], params, in_axes,
                                  is_leaf=lambda x: x is None)


def slice_batch(params, in_axes, start: int, stop: int):
    """Samples ``start:stop`` of a batch (unbatched fields stay as they are)."""
    return jax.tree_util.tree_map(lambda x, a: x if a is None else x[start:stop], params, in_axes,
                                  is_leaf=lambda x: x is None)


# --------------------------------------------------------------------------
# Flat columns
# --------------------------------------------------------------------------
def parameter_columns(params: PerturbationParams, in_axes: PerturbationParams, n: int, *,
                      n_vertices: int, dim: int, n_pushes: int = 0, n_tumbles: int = 0,
                      max_pushes: Optional[int] = None, max_tumbles: Optional[int] = None,
                      vertex_names: Optional[Sequence[int]] = None) -> dict:
    """Flatten sampled parameters to named columns (numpy float64, length n).

    Column names carry units (see ``results/README.md``): ``dv{i}_{x,y,z}_m``,
    ``dcom_{x,y,z}_m``, ``mu_f``, ``mu_s``, ``c_m``, ``start_dx_m``,
    ``start_dy_m``, ``start_dtheta_rad``, ``fence_angle_err_rad_p{k}``,
    ``push_dist_rel_err_p{k}``, ``push_dist_abs_err_m_p{k}``,
    ``slip_dx_m_t{k}`` / ``slip_dy_m_t{k}`` / ``slip_dtheta_rad_t{k}``
    (tumble slips are summarised as their sums ``slip_sum_*`` when there are
    more than ``max_tumbles`` tumbles; ``max_tumbles`` defaults to 0: sums
    only).  Per-push columns are padded with NaN up to ``max_pushes``.
    """
    p = broadcast(params, in_axes, n)
    g, f, e = p.geometry, p.friction, p.execution
    axes = "xyz"[:dim]
    cols: dict = {}
    dv = np.asarray(g.vertex_offset, dtype=np.float64)
    names = list(range(n_vertices)) if vertex_names is None else list(vertex_names)
    for i, vi in enumerate(names):
        for j, a in enumerate(axes):
            cols[f"dv{vi}_{a}_m"] = dv[:, i, j]
    dc = np.asarray(g.com_offset, dtype=np.float64)
    for j, a in enumerate(axes):
        cols[f"dcom_{a}_m"] = dc[:, j]
    cols["mu_f"] = np.asarray(f.mu_f, dtype=np.float64)
    cols["mu_s"] = np.asarray(f.mu_s, dtype=np.float64)
    cols["c_m"] = np.asarray(f.c, dtype=np.float64)
    so = np.asarray(e.start_offset, dtype=np.float64)
    cols["start_dx_m"], cols["start_dy_m"], cols["start_dtheta_rad"] = so[:, 0], so[:, 1], so[:, 2]
    P = n_pushes if max_pushes is None else max_pushes
    for name, arr in (("fence_angle_err_rad", e.fence_angle), ("push_dist_rel_err", e.distance_rel),
                      ("push_dist_abs_err_m", e.distance_abs)):
        a = np.asarray(arr, dtype=np.float64)
        for k in range(P):
            cols[f"{name}_p{k}"] = a[:, k] if k < n_pushes else np.full(n, np.nan)
    sl = np.asarray(e.tumble_slip, dtype=np.float64)
    T = 0 if max_tumbles is None else max_tumbles
    if n_tumbles and n_tumbles <= T:
        for k in range(n_tumbles):
            cols[f"slip_dx_m_t{k}"] = sl[:, k, 0]
            cols[f"slip_dy_m_t{k}"] = sl[:, k, 1]
            cols[f"slip_dtheta_rad_t{k}"] = sl[:, k, 2]
    tot = sl.sum(axis=1) if n_tumbles else np.zeros((n, 3))
    cols["slip_sum_dx_m"], cols["slip_sum_dy_m"], cols["slip_sum_dtheta_rad"] = tot[:, 0], tot[:, 1], tot[:, 2]
    return cols
