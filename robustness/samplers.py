"""Perturbation samplers: what the supplier makes and what the robot does.

Each sampler draws ``n`` perturbations from an explicit ``jax.random`` key and
returns them as :class:`Draws`, the way mujoco_playground's domain randomizers
do: ``draws.params`` is a frozen pytree dataclass whose sampled fields have a
leading axis of length ``n``; ``draws.in_axes`` is the same dataclass holding
``0`` on those fields and ``None`` on the fields that were not sampled (a zero
tolerance leaves the nominal value, unbatched), ready for
``jax.vmap(f, in_axes=(draws.in_axes,))(draws.params)``.  All functions are pure:
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
  (uniform in a range); the part's support, a family of :mod:`kernels.support`
  (``any``, the default, draws one of rigid / uniform / ring / tripod per sample;
  rigid draws the corners' flatness ranks, which pick the three corners the part
  rests on; its own uniforms, ``fold_in(key, 7)``, so the ``points`` family's
  draws are unchanged) giving ``c`` and the per-sample ``family`` code; or, for
  the ``points`` family, the support pressure distribution: ``support_points``
  points uniform in the part's nominal (body-frame) polygon with
  Dirichlet(``weight_concentration``) weights (an integer), tilted so that the
  pressure's centroid lies under the centre of mass as it must for a part at
  rest (:mod:`robustness.support`; with 3 or more points), giving the
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

Compilation: the sampler is compiled once per *structure* (distributions,
which tolerances are zero, point counts), the tolerance values being traced
arguments; the sample count is padded to a bucket (:func:`sample_bucket`)
and the per-push / per-tumble columns to a power of two
(:func:`steps_bucket`), the draws cut back after; threefry's draws are
prefix-stable, so a sample's numbers do not depend on the bucket, but the
per-push draws do depend on the plan's length bucket.  Only the columns a
draw uses are computed (:mod:`robustness.uniforms`: not a zero tolerance's,
not the ``points`` family's under another family, not the per-step columns
past the plan's length above 16 steps, :func:`drawn_steps`); they are the
numbers the whole block would hold.  So a study that sweeps
tolerances, sample counts and plan lengths reuses a handful of compiled
samplers (compiling one takes seconds).

Units: metres, radians; a relative distance error is a fraction.
"""
from __future__ import annotations

import dataclasses
import functools
from typing import Any, Optional, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from kernels import float64
from robustness.support import centre_weights, support_from_u
from robustness.tolerances import ExecutionTolerance, FrictionRange, GeometryTolerance
from robustness.uniforms import uniform_columns

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
        centre of mass), m; zeros when ``c`` was drawn directly (or not kept).
      support_weights: (S,) their weights (sum 1).
      family: () int32 code of the sample's support family
        (:data:`kernels.support.CODES`; per sample under ``support: any``).
      corner_lift: (h,) how far each hull corner of the nominal part
        protrudes below its face (order only: a rank of flatness errors) for
        the rigid family; zeros otherwise.
    """

    mu_f: Any
    mu_s: Any
    c: Any
    support_points: Any
    support_weights: Any
    family: Any = None
    corner_lift: Any = None


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


@functools.partial(jax.tree_util.register_dataclass, data_fields=["params"],
                   meta_fields=["in_axes", "n"])
@dataclasses.dataclass(frozen=True)
class Draws:
    """``n`` Monte-Carlo samples of a :class:`Sampler` (mjx's rule: the arrays
    traced, the layout static).

    Attributes:
      params: :class:`PerturbationParams`; the sampled fields have a leading
        axis of length ``n``, the others hold the nominal value, unbatched.
      in_axes: the same dataclass holding ``0`` on the sampled fields and
        ``None`` on the others, ready for
        ``jax.vmap(f, in_axes=(draws.in_axes,))(draws.params)``.
      n: the number of samples.
    """

    params: PerturbationParams
    in_axes: PerturbationParams
    n: int

    def _map(self, fn):
        return jax.tree_util.tree_map(fn, self.params, self.in_axes, is_leaf=lambda x: x is None)

    def broadcast(self) -> PerturbationParams:
        """Every field with a leading axis of length ``n`` (unbatched ones repeated)."""
        return self._map(self.rows)

    def take(self, i) -> PerturbationParams:
        """Sample ``i`` (or the samples of an index array); unbatched fields as they are."""
        return self._map(lambda x, a: x if a is None else x[i])

    def slice(self, start: int, stop: int) -> "Draws":
        """Samples ``start:stop`` (within ``0..n``)."""
        start, stop = max(0, int(start)), min(self.n, int(stop))
        return Draws(self._map(lambda x, a: x if a is None else x[start:stop]), self.in_axes,
                     max(0, stop - start))

    def astype(self, dtype) -> "Draws":
        """Floating fields cast to ``dtype`` (integer codes kept)."""
        def cast(x):
            x = jnp.asarray(x)
            return x.astype(dtype) if jnp.issubdtype(x.dtype, jnp.floating) else x

        return Draws(jax.tree_util.tree_map(cast, self.params), self.in_axes, self.n)

    def rows(self, x, axis):
        """One field of :attr:`params` (with its axis in :attr:`in_axes`) as ``n`` rows."""
        x = jnp.asarray(x)
        return x if axis == 0 else jnp.broadcast_to(x, (self.n,) + x.shape)


# --------------------------------------------------------------------------
# Drawing helpers
# --------------------------------------------------------------------------
# Each group draws ONE block of uniforms, shape (n, width), from its key and
# transforms slices of it (inverse CDFs): one random-bits call per group keeps
# compilation fast, and the block's layout does not depend on which
# tolerances are zero, so e.g. changing tau_com leaves the vertex draws as
# they were.
#
# Compiled once per STRUCTURE, not per value: the tolerance values are traced
# arguments (``values`` dicts of scalars), so a study that sweeps tau_v or a
# friction range reuses one compiled sampler; what changes array shapes or
# vmap axes is static (:class:`Structure`: distributions, which tolerances
# are zero, point counts).  The sample count is padded to a bucket
# (:func:`sample_bucket`) and the draws cut back to ``n``: JAX's threefry
# draws are prefix-stable (the first ``n`` rows of an ``(N, w)`` block do not
# depend on ``N``), so the samples are those of an exact-size draw.
def _draw(key, n: int, width: int, pieces: dict, dtype):
    """Named column ranges of the group's block ``uniform(key, (n, width))``:
    ``pieces`` maps a name to ``(start, stop, wanted)``; only the wanted ranges
    are computed (:func:`robustness.uniforms.uniform_columns`: the same numbers
    as the full block's), an unwanted one is zeros (its values are discarded)."""
    cols = [c for a, b, w in pieces.values() if w for c in range(a, b)]
    sub = uniform_columns(key, n, width, cols, dtype)
    out, at = {}, 0
    for name, (a, b, w) in pieces.items():
        if w:
            out[name], at = sub[:, at:at + b - a], at + b - a
        else:
            out[name] = jnp.zeros((n, b - a), dtype)
    return out


def _open01(u, dtype):
    """Uniforms moved into the open interval (0, 1) (for logs and ndtri)."""
    tiny = jnp.finfo(dtype).eps
    return jnp.clip(u, tiny, 1.0 - tiny)


def _box_from_u(u, half, zero: bool, distribution: str, sigma, dtype):
    """Offsets in [-half, half] from uniforms ``u``: uniform, or a Gaussian of
    std ``sigma`` (``None``: half / 2) truncated to the box (inverse CDF).
    ``zero`` (static): the offsets are 0 (a zero half-width or std)."""
    if zero:
        return jnp.zeros(u.shape, dtype)
    if distribution == "uniform":
        return (2.0 * u - 1.0) * half
    sd = 0.5 * half if sigma is None else sigma
    lim = half / sd
    lo = jax.scipy.special.ndtr(-lim)
    hi = jax.scipy.special.ndtr(lim)
    z = jax.scipy.special.ndtri(_open01(lo + u * (hi - lo), dtype))
    return sd * jnp.clip(z, -lim, lim)


def _ball_from_u(u, radius, dtype):
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


@dataclasses.dataclass(frozen=True)
class Structure:
    """What changes the shapes, vmap axes or code of the draws (static and
    hashable: the compiled sampler's key; the tolerance values are traced).
    ``*_zero``: the tolerance is zero (the field is not drawn: unbatched
    nominal value); ``*_const``: a range of zero width."""

    # geometry
    geometry_distribution: str
    com_shape: str
    vertex_zero: bool
    has_sigma_v: bool
    com_zero: bool
    # friction
    support_points: int
    weight_concentration: int
    c_given: bool
    mu_f_const: bool
    mu_s_const: bool
    c_const: bool
    support: str
    # execution
    execution_distribution: str
    start_zero: bool
    start_xy_zero: bool
    start_theta_zero: bool
    fence_zero: bool
    rel_zero: bool
    abs_zero: bool
    slip_zero: bool
    slip_xy_zero: bool
    slip_theta_zero: bool

    @classmethod
    def of(cls, sampler: "Sampler") -> "Structure":
        """The structure of ``sampler``'s draws."""
        g, f, e = sampler.geometry, sampler.friction, sampler.execution
        gauss = g.distribution == "gaussian"
        return cls(
            geometry_distribution=g.distribution, com_shape=g.com_shape,
            vertex_zero=g.tau_v == 0.0 or (gauss and g.sigma == 0.0),
            has_sigma_v=gauss and g.sigma_v is not None, com_zero=g.tau_com == 0.0,
            support_points=int(f.support_points), weight_concentration=int(f.weight_concentration),
            c_given=f.c is not None, mu_f_const=f.mu_f[0] == f.mu_f[1],
            mu_s_const=f.mu_s[0] == f.mu_s[1], c_const=f.c is not None and f.c[0] == f.c[1],
            support=f.support,
            execution_distribution=e.distribution,
            start_zero=e.start_xy == 0.0 and e.start_theta == 0.0, start_xy_zero=e.start_xy == 0.0,
            start_theta_zero=e.start_theta == 0.0, fence_zero=e.fence_angle == 0.0,
            rel_zero=e.distance_rel == 0.0, abs_zero=e.distance_abs == 0.0,
            slip_zero=e.tumble_slip_xy == 0.0 and e.tumble_slip_theta == 0.0,
            slip_xy_zero=e.tumble_slip_xy == 0.0, slip_theta_zero=e.tumble_slip_theta == 0.0)


def _values(sampler: "Sampler") -> dict:
    """The tolerance values (traced scalars of the compiled sampler)."""
    g, f, e = sampler.geometry, sampler.friction, sampler.execution
    c = f.c if f.c is not None else (0.0, 0.0)
    return {k: float(v) for k, v in dict(
        tau_v=g.tau_v, sigma_v=g.sigma, tau_com=g.tau_com, mu_f_lo=f.mu_f[0], mu_f_hi=f.mu_f[1],
        mu_s_lo=f.mu_s[0], mu_s_hi=f.mu_s[1], c_lo=c[0], c_hi=c[1], start_xy=e.start_xy,
        start_theta=e.start_theta, fence_angle=e.fence_angle, distance_rel=e.distance_rel,
        distance_abs=e.distance_abs, tumble_slip_xy=e.tumble_slip_xy,
        tumble_slip_theta=e.tumble_slip_theta).items()}


def _sample_geometry(key, n: int, st: Structure, val: dict, n_vertices: int, dim: int,
                     dtype=jnp.float64):
    distribution, com_shape, v_zero = st.geometry_distribution, st.com_shape, st.vertex_zero
    has_sigma, com_zero = st.has_sigma_v, st.com_zero
    mv = n_vertices * dim
    u = _draw(key, n, mv + dim + 1, dict(v=(0, mv, not v_zero), c=(mv, mv + dim + 1, not com_zero)),
              dtype)
    dv = _box_from_u(u["v"], val["tau_v"], v_zero, distribution,
                     val["sigma_v"] if has_sigma else None, dtype)
    dv, av = _batched(dv.reshape(n, n_vertices, dim), n, v_zero, (n_vertices, dim), dtype)
    uc = u["c"]
    if com_shape == "box":
        dc = (2.0 * uc[:, :dim] - 1.0) * val["tau_com"]
    else:
        dc = _ball_from_u(uc, val["tau_com"], dtype)
    dc, ac = _batched(dc, n, com_zero, (dim,), dtype)
    return GeometryParams(dv, dc), GeometryParams(av, ac)


def _range_from_u(u, n: int, lo, hi, const: bool, dtype):
    if const or n == 0:
        return jnp.asarray(lo, dtype), None
    return lo + u * (hi - lo), 0


def _family_c(key, body, n: int, family: str, dtype):
    """``(c, a_c, code, a_code, lift, a_lift)`` of a named family on the nominal
    ``body`` (:mod:`kernels.support`): rigid corners with lifts drawn uniform
    (their order picks the triangle), the uniform pad and the rim (one ``c``,
    unbatched), and under ``any`` a component per sample, in equal parts, whose
    tripod has ``c`` uniform in ``[TRIPOD_MIN_FRACTION, 1] x tripod_fit``."""
    from kernels import (ANY_COMPONENTS, CODES, corner_weights, equilibrium_weights, FAMILIES,
                         FAMILY, family_points, limit_surface_ratio, tripod_fit,
                         TRIPOD_MIN_FRACTION)

    h = body.shape[0]
    mixed = family not in FAMILIES   # any: a component per sample
    u = _draw(key, n, 2 + h, dict(comp=(0, 1, mixed), tri=(1, 2, mixed),
                                  lift=(2, 2 + h, mixed or family == "rigid")), dtype)
    lift = u["lift"]

    def fixed(name):
        pts = family_points(name, body)
        return limit_surface_ratio(pts, equilibrium_weights(pts)).astype(dtype)

    def rigid():
        w = jax.vmap(corner_weights, in_axes=(None, 0))(body, lift)
        return jax.vmap(limit_surface_ratio, in_axes=(None, 0))(body, w).astype(dtype)

    def tripod():   # under any: c uniform in [TRIPOD_MIN_FRACTION, 1] x tripod_fit
        fit = tripod_fit(body)
        return (fit * (TRIPOD_MIN_FRACTION + (1.0 - TRIPOD_MIN_FRACTION)
                       * u["tri"][:, 0])).astype(dtype)

    zeros = jnp.zeros((h,), dtype)
    if family == "rigid":
        return rigid(), 0, jnp.int32(CODES["rigid"]), None, lift, 0
    row = FAMILY.get(family)   # None: the any mixture
    if row is not None and not row.varies and not row.c_given:   # the pad, the rim: the part's c
        return fixed(family), None, jnp.int32(CODES[family]), None, zeros, None
    # any: the components of kernels.support.ANY_COMPONENTS in equal parts
    comp = jnp.minimum((u["comp"][:, 0] * len(ANY_COMPONENTS)).astype(jnp.int32),
                       len(ANY_COMPONENTS) - 1)
    per_sample = {"rigid": rigid, "tripod": tripod}
    cs = jnp.stack([per_sample[f]() if f in per_sample else jnp.broadcast_to(fixed(f), (n,))
                    for f in ANY_COMPONENTS], axis=1)
    c = jnp.take_along_axis(cs, comp[:, None], axis=1)[:, 0]
    codes = jnp.asarray([CODES[f] for f in ANY_COMPONENTS], jnp.int32)[comp]
    return c, 0, codes, 0, lift, 0


def _sample_friction(key, body, n: int, st: Structure, val: dict, has_body: bool,
                     dtype=jnp.float64, keep_support: bool = True):
    from kernels import CODES

    S, k, c_given = st.support_points, st.weight_concentration, st.c_given
    mu_f_const, mu_s_const, c_const, family = st.mu_f_const, st.mu_s_const, st.c_const, st.support
    body_c = has_body and n > 0
    w_all = 3 + S * (3 + k)
    u = _draw(key, n, w_all, dict(
        mu_f=(0, 1, not mu_f_const), mu_s=(1, 2, not mu_s_const),
        c=(2, 3, body_c and c_given and not c_const),
        pts=(3, w_all, body_c and not c_given and family == "points")), dtype)
    mu_f, a_f = _range_from_u(u["mu_f"][:, 0], n, val["mu_f_lo"], val["mu_f_hi"], mu_f_const, dtype)
    mu_s, a_s = _range_from_u(u["mu_s"][:, 0], n, val["mu_s_lo"], val["mu_s_hi"], mu_s_const, dtype)
    h = body.shape[0]
    code, a_code = jnp.int32(CODES.get(family, CODES["rigid"])), None
    lift, a_lift = jnp.zeros((h,), dtype), None
    pts, a_p = jnp.zeros((S, 2), dtype), None
    w, a_w = jnp.full((S,), 1.0 / S, dtype), None
    if not has_body or n == 0:
        c, a_c = jnp.asarray(jnp.nan, dtype), None
    elif c_given:               # the tripod family: c drawn directly
        c, a_c = _range_from_u(u["c"][:, 0], n, val["c_lo"], val["c_hi"], c_const, dtype)
    elif family == "points":
        from kernels import limit_surface_ratio

        pts, w = support_from_u(u["pts"], body, S, k, dtype)
        if S >= 3:   # the pressure's centroid under the centre of mass (a part at rest)
            w = jax.vmap(centre_weights)(pts, w)
        c = jax.vmap(limit_surface_ratio)(pts, w).astype(dtype)
        a_c = a_p = a_w = 0
        if not keep_support:   # only c is wanted: the points are not materialised
            pts, a_p = jnp.zeros((S, 2), dtype), None
            w, a_w = jnp.full((S,), 1.0 / S, dtype), None
    else:                       # a named family (its own uniforms: the points' draws unchanged)
        c, a_c, code, a_code, lift, a_lift = _family_c(jax.random.fold_in(key, 7), body, n,
                                                       family, dtype)
    return (FrictionParams(mu_f, mu_s, c, pts, w, code, lift),
            FrictionParams(a_f, a_s, a_c, a_p, a_w, a_code, a_lift))


def _sample_execution(key, n: int, st: Structure, val: dict, n_pushes: int = 0,
                      n_tumbles: int = 0, dtype=jnp.float64, drawn_pushes: Optional[int] = None,
                      drawn_tumbles: Optional[int] = None):
    """``n_pushes`` / ``n_tumbles``: the block's per-step columns (the plan's
    length bucket, :func:`steps_bucket`: the layout); ``drawn_*``: how many of
    them are drawn (:func:`drawn_steps`; default all)."""
    dist, start_zero, xy_zero, th_zero = (st.execution_distribution, st.start_zero,
                                          st.start_xy_zero, st.start_theta_zero)
    fence_zero, rel_zero, abs_zero = st.fence_zero, st.rel_zero, st.abs_zero
    slip_zero, sxy_zero, sth_zero = st.slip_zero, st.slip_xy_zero, st.slip_theta_zero
    P, L = int(n_pushes), int(n_tumbles)   # bucketed (steps_bucket): cut to the plan's after
    Pd = P if drawn_pushes is None else int(drawn_pushes)
    Ld = L if drawn_tumbles is None else int(drawn_tumbles)
    u = _draw(key, n, 3 + 3 * P + 3 * L, dict(
        start=(0, 3, not start_zero),
        fence=(3, 3 + Pd, not fence_zero and Pd > 0),
        rel=(3 + P, 3 + P + Pd, not rel_zero and Pd > 0),
        abs=(3 + 2 * P, 3 + 2 * P + Pd, not abs_zero and Pd > 0),
        slip=(3 + 3 * P, 3 + 3 * P + 3 * Ld, not slip_zero and Ld > 0)), dtype)

    def box(cols, half, zero):
        return _box_from_u(cols, half, zero, dist, None, dtype)

    us0 = u["start"]
    if dist == "uniform":
        halves = jnp.stack([val["start_xy"], val["start_xy"], val["start_theta"]]).astype(dtype)
        start = (2.0 * us0 - 1.0) * halves
    else:
        start = jnp.stack([box(us0[:, 0], val["start_xy"], xy_zero),
                           box(us0[:, 1], val["start_xy"], xy_zero),
                           box(us0[:, 2], val["start_theta"], th_zero)], axis=1)
    start, a_start = _batched(start, n, start_zero, (3,), dtype)
    fence, a_fence = _batched(box(u["fence"], val["fence_angle"], fence_zero), n,
                              fence_zero or Pd == 0, (Pd,), dtype)
    rel, a_rel = _batched(box(u["rel"], val["distance_rel"], rel_zero), n,
                          rel_zero or Pd == 0, (Pd,), dtype)
    ab, a_ab = _batched(box(u["abs"], val["distance_abs"], abs_zero), n,
                        abs_zero or Pd == 0, (Pd,), dtype)
    us = u["slip"].reshape(n, Ld, 3)
    slip = jnp.concatenate([box(us[..., :2], val["tumble_slip_xy"], sxy_zero),
                            box(us[..., 2:], val["tumble_slip_theta"], sth_zero)], axis=-1)
    slip, a_slip = _batched(slip, n, slip_zero or Ld == 0, (Ld, 3), dtype)
    return (ExecutionParams(start, fence, rel, ab, slip),
            ExecutionParams(a_start, a_fence, a_rel, a_ab, a_slip))


# --------------------------------------------------------------------------
# Compiled entry points
# --------------------------------------------------------------------------
def sample_bucket(n: int) -> int:
    """Sample count the sampler draws for ``n`` (the draws are cut back to
    ``n``): the next power of two up to 4096 (drawing is cheap there), above
    it ``n`` rounded up to its 4 leading binary digits (at most 1/8 more), so
    that nearby sample counts share one compiled sampler."""
    n = int(n)
    if n <= 4096:
        return 1 << max(0, n - 1).bit_length() if n else 0
    shift = max(0, n.bit_length() - 4)
    return -(-n // (1 << shift)) << shift


def steps_bucket(k: int) -> int:
    """Per-push (per-tumble) columns the sampler draws for a plan of ``k``
    steps: the next power of two (0 for none).  Plans of lengths in one
    bucket share a compiled sampler; the draws of step ``i`` depend on the
    bucket, not on ``k``."""
    k = int(k)
    return 1 << max(0, k - 1).bit_length() if k else 0


def drawn_steps(k: int) -> int:
    """Per-push (per-tumble) columns of the bucket (:func:`steps_bucket`) that
    the sampler computes for a plan of ``k`` steps: the whole bucket up to 16
    steps (plans of lengths in one bucket share a compiled sampler), above it
    ``k`` rounded up to its 4 leading binary digits (at most 1/8 more than the
    plan needs; a 200-tumble plan draws 208 of its bucket's 256).  The numbers
    of step ``i`` are the same either way (:func:`robustness.uniforms.uniform_columns`)."""
    k = int(k)
    if k <= 16:
        return steps_bucket(k)
    shift = max(0, k.bit_length() - 4)
    return min(steps_bucket(k), -(-k // (1 << shift)) << shift)


@functools.lru_cache(maxsize=128)
def _staged(static: tuple):
    """The sampler compiled once per static structure: ``(key, body, values)
    -> params``; the (Python) in_axes are captured while it is traced."""
    box = {}

    def arrays(key, body, values):
        p, a = _sample_all(key, body, values, *static)
        box["axes"] = a
        return p

    return jax.jit(arrays), box


def _sample_all(key, body, values, n, st, n_vertices, dim, n_pushes, n_tumbles, has_body,
                dtype, keep_support=True, drawn_pushes=None, drawn_tumbles=None):
    g, ga = _sample_geometry(jax.random.fold_in(key, GEOMETRY), n, st, values, n_vertices, dim,
                             dtype)
    f, fa = _sample_friction(jax.random.fold_in(key, FRICTION), body, n, st, values, has_body,
                             dtype, keep_support)
    e, ea = _sample_execution(jax.random.fold_in(key, EXECUTION), n, st, values, n_pushes,
                              n_tumbles, dtype, drawn_pushes, drawn_tumbles)
    return PerturbationParams(g, f, e), PerturbationParams(ga, fa, ea)


def _dtype(dtype):
    return jnp.dtype(dtype).type


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
               n_tumbles: int = 0, body=None, dtype=jnp.float64, keep_support: bool = True,
               exact_steps: bool = True):
        """Draw ``n`` perturbations (:class:`Draws`).

        ``body``: the nominal body-frame polygon for the support points (push
        parts), ``None`` for tumbled polyhedra.  ``keep_support=False``: return
        the sampled ``c`` but not the support points and weights it came from
        (unbatched placeholders; the same draws, less memory: the evaluation
        uses only ``c``).  ``exact_steps=False``: the per-push and per-tumble
        fields keep every column the sampler drew (:func:`drawn_steps`, at
        least the plan's steps: the first ones are the same numbers, the rest
        are draws no step uses) instead of a copy cut to the plan's length;
        for consumers that take only the plan's steps
        (:func:`robustness.replay.run_tumble`, :func:`parameter_columns`).
        """
        dt = _dtype(dtype)
        has_body = body is not None
        b = jnp.asarray(body, dt) if has_body else jnp.zeros((3, 2), dt)
        n, P, L = int(n), int(n_pushes), int(n_tumbles)
        N, Pb, Lb = sample_bucket(n), steps_bucket(P), steps_bucket(L)
        Pd, Ld = drawn_steps(P), drawn_steps(L)
        # one compiled call for the three groups, per structure (values are traced)
        jitted, box = _staged((N, Structure.of(self), int(n_vertices), int(dim), Pb, Lb, has_body,
                               dt, bool(keep_support), Pd, Ld))
        vals = {k: jnp.asarray(v, dt) for k, v in _values(self).items()}
        draws = Draws(jitted(key, b, vals), box["axes"], N)
        if N != n:
            draws = draws.slice(0, n)
        if exact_steps and (Pd, Ld) != (P, L):
            draws = _cut_steps(draws, P, L)
        return draws


# --------------------------------------------------------------------------
# Batch helpers
# --------------------------------------------------------------------------
def _cut_steps(draws: Draws, P: int, L: int) -> Draws:
    """Per-push fields cut to ``P`` pushes, per-tumble fields to ``L`` tumbles."""
    e, ea = draws.params.execution, draws.in_axes.execution

    def cut(x, axis, k):
        return x[:, :k] if axis == 0 else x[:k]

    e = ExecutionParams(start_offset=e.start_offset,
                        fence_angle=cut(e.fence_angle, ea.fence_angle, P),
                        distance_rel=cut(e.distance_rel, ea.distance_rel, P),
                        distance_abs=cut(e.distance_abs, ea.distance_abs, P),
                        tumble_slip=cut(e.tumble_slip, ea.tumble_slip, L))
    return dataclasses.replace(draws, params=dataclasses.replace(draws.params, execution=e))


# --------------------------------------------------------------------------
# Flat columns
# --------------------------------------------------------------------------
def support_names(family, n: int, has_support) -> np.ndarray:
    """(n,) support family names of the samples (``None`` where there is no
    support: a tumbled polyhedron)."""
    from kernels import FAMILIES

    code = np.broadcast_to(np.asarray(family, np.int64), (n,))
    names = np.asarray(FAMILIES, dtype=object)[code]
    return np.where(np.broadcast_to(has_support, (n,)), names, None)


#: The per-vertex and per-push draws, stored as list columns of the ``samples`` table.
LIST_COLUMNS = ("dv_m", "fence_angle_err_rad", "push_dist_rel_err", "push_dist_abs_err_m")


def parameter_lists(draws: Draws, *, n_vertices: int, dim: int, n_pushes: int = 0,
                    **_) -> dict:
    """The per-vertex and per-push draws as ``(n, k)`` float64 arrays, one per
    list column of the ``samples`` table (:data:`LIST_COLUMNS`): ``dv_m`` holds
    each sample's vertex offsets x, y (, z) vertex after vertex (m); the
    per-push columns one value per push (rad, relative, m).  The same numbers as
    :func:`parameter_columns`' flat columns, without names to parse."""
    p, n = draws.broadcast(), draws.n
    g, e = p.geometry, p.execution
    dv = np.asarray(g.vertex_offset, dtype=np.float64)[:, :n_vertices, :dim]
    out = {"dv_m": dv.reshape(n, n_vertices * dim)}
    for name, arr in (("fence_angle_err_rad", e.fence_angle), ("push_dist_rel_err", e.distance_rel),
                      ("push_dist_abs_err_m", e.distance_abs)):
        out[name] = np.asarray(arr, dtype=np.float64)[:, :n_pushes]
    return out


@jax.jit
def _slip_sums_in_order(slip, k):
    x = slip.astype(jnp.float64)
    return jax.lax.fori_loop(1, k, lambda i, acc: acc + x[:, i], x[:, 0])


def slip_sums(slip, k: Optional[int] = None) -> np.ndarray:
    """``(n, 3)`` sums over the first ``k`` tumbles (default all) of the slips
    ``(n, L, 3)`` (m, m, rad), in float64: the bits of
    ``np.asarray(slip, np.float64)[:, :k].sum(axis=1)``.

    numpy adds the rows of a C-ordered ``(n, L, 3)`` array one after the other
    (its reduction loop runs over the contiguous last axis, so no pairwise
    summation), and so does this compiled loop, without copying the ``(n, L, 3)``
    slips to the host (4x faster for 200 tumbles); numpy's own sum where 64-bit
    floats are off in JAX, or for an empty axis.
    """
    L = np.shape(slip)[1]
    k = L if k is None else int(k)
    if not 0 <= k <= L:
        raise ValueError(f"k: expected 0..{L} tumbles, got {k}")
    if not jax.config.jax_enable_x64 or k == 0 or np.shape(slip)[0] == 0:
        return np.asarray(slip, dtype=np.float64)[:, :k].sum(axis=1)
    return np.asarray(_slip_sums_in_order(jnp.asarray(slip), jnp.asarray(k, jnp.int32)))


def parameter_columns(draws: Draws, *, n_vertices: int, dim: int, n_pushes: int = 0,
                      n_tumbles: int = 0,
                      max_pushes: Optional[int] = None, max_tumbles: Optional[int] = None,
                      vertex_names: Optional[Sequence[int]] = None) -> dict:
    """Flatten sampled parameters to named columns (numpy float64, length n).

    Column names carry units (see ``results/README.md``): ``dv{i}_{x,y,z}_m``,
    ``dcom_{x,y,z}_m``, ``mu_f``, ``mu_s``, ``c_m``, ``support`` (the sample's
    support family), ``start_dx_m``,
    ``start_dy_m``, ``start_dtheta_rad``, ``fence_angle_err_rad_p{k}``,
    ``push_dist_rel_err_p{k}``, ``push_dist_abs_err_m_p{k}``,
    ``slip_dx_m_t{k}`` / ``slip_dy_m_t{k}`` / ``slip_dtheta_rad_t{k}``
    (tumble slips are summarised as their sums ``slip_sum_*`` when there are
    more than ``max_tumbles`` tumbles; ``max_tumbles`` defaults to 0: sums
    only).  Per-push columns are padded with NaN up to ``max_pushes``.  The
    draws' per-step fields may carry more columns than ``n_pushes`` /
    ``n_tumbles`` (``Sampler.sample(exact_steps=False)``): only the plan's are read.
    """
    p, n = draws.broadcast(), draws.n
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
    cols["support"] = support_names(f.family, n, np.isfinite(cols["c_m"]))
    so = np.asarray(e.start_offset, dtype=np.float64)
    cols["start_dx_m"], cols["start_dy_m"], cols["start_dtheta_rad"] = so[:, 0], so[:, 1], so[:, 2]
    P = n_pushes if max_pushes is None else max_pushes
    for name, arr in (("fence_angle_err_rad", e.fence_angle), ("push_dist_rel_err", e.distance_rel),
                      ("push_dist_abs_err_m", e.distance_abs)):
        a = np.asarray(arr, dtype=np.float64)
        for k in range(P):
            cols[f"{name}_p{k}"] = a[:, k] if k < n_pushes else np.full(n, np.nan)
    T = 0 if max_tumbles is None else max_tumbles
    if n_tumbles and n_tumbles <= T:
        sl = np.asarray(e.tumble_slip, dtype=np.float64)
        for k in range(n_tumbles):
            cols[f"slip_dx_m_t{k}"] = sl[:, k, 0]
            cols[f"slip_dy_m_t{k}"] = sl[:, k, 1]
            cols[f"slip_dtheta_rad_t{k}"] = sl[:, k, 2]
    tot = slip_sums(e.tumble_slip, n_tumbles) if n_tumbles else np.zeros((n, 3))
    cols["slip_sum_dx_m"], cols["slip_sum_dy_m"], cols["slip_sum_dtheta_rad"] = tot[:, 0], tot[:, 1], tot[:, 2]
    return cols
