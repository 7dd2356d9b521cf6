"""Support families of a pushed part: where the support touches it and how
its weight is shared (body frame, origin at the centre of mass, metres).

A part resting on a flat support is carried by a set of contact points; their
normal loads balance its weight, so the loads' centroid lies under the centre
of mass.  What the quasi-static model needs of the support is the limit-surface
ratio ``c = sum w_i |p_i|`` of the loads ``w_i`` (fractions of the weight) at
the points ``p_i`` (:func:`kernels.quasistatic.limit_surface_ratio`).  A
*family* says which points and which loads a real part has; the same
definition is drawn by the quasi-static sampler (:mod:`robustness.samplers`)
and realised by the MuJoCo scene (:mod:`robustness.physics`):

``rigid``
    A rigid part on a rigid table rests on corners of its underside (the
    polygon's hull vertices), three of them in general: which three depends on
    the part's flatness errors.  Corner ``i`` protruding ``lift_i`` below the
    nominal face, the part rests on the facet of the lower hull of the lifted
    corners above its centre of mass, whose loads are the centre of mass's
    barycentric coordinates in that triangle (statically determinate):
    :func:`corner_weights`, the solution of the linear programme
    ``max sum lam_i lift_i`` s.t. ``sum lam_i p_i = 0, sum lam_i = 1, lam >= 0``
    (its vertices are the triangles; enumerated).  Only the ORDER of the lifts
    matters, not their size (the programme is homogeneous in ``lift``).
``uniform``
    A compliant pad: pressure over the whole footprint.  ``UNIFORM_FEET``
    points of a fixed quasi-uniform set in the polygon (:func:`uniform_points`;
    corners in place of some where the centre of mass is outside their hull),
    moved ``FOOT_INSET`` inside the outline, loaded as equal springs under a
    rigid body are: the minimum-norm loads that balance the weight
    (:func:`equilibrium_weights`, affine in position: uniform when the centre
    of mass is the points' centroid).
``ring``
    Pressure along the rim (a part with a raised edge, a dished underside):
    ``RING_FEET`` points equally spaced along the outline (corners in place of
    some where the centre of mass is outside their hull), inset like the
    uniform points, with equilibrium loads (:func:`ring_points`).
``tripod``
    Three feet on a circle of radius ``c`` about the centre of mass, an
    equilateral triangle turned to lie as deep inside the outline as possible
    (:func:`tripod_points`); loads ``1/3`` each.  A model of a support, kept for
    comparing the model with physics; the largest ``c`` that fits inside the
    outline is :func:`tripod_fit`.

Pure JAX, one part at a time (``jax.vmap`` at the call site), in the dtype of
the inputs; :func:`family_c_range` (host side, numpy float64) gives the range
of ``c`` a family can take on a part, for the planner's distances.
"""
from __future__ import annotations

import functools
import itertools
import math

import jax
import jax.numpy as jnp
import numpy as np

from kernels.families import ANY, ANY_COMPONENTS, CODES, FAMILY, PLAN_SUPPORTS, TABLE
from kernels.linsolve import det3, solve3


#: points of the uniform and ring families (besides the corners): what a count
#: costs and how far from the continuous pad or rim it leaves a plan is measured
#: by ``bench/support_points.py`` (its docstring has the figures)
UNIFORM_FEET = 25
RING_FEET = 24
#: the uniform and ring families stand on their feet alone (False, the default
#: since December 2026: closer to the continuous pad and rim and faster, per
#: ``bench/support_points.py``; a part whose centre of mass falls outside the
#: feet's hull stands on its corners in place of some feet,
#: :func:`standing_feet`), or on the feet and every corner (True, as before);
#: read when traced
FEET_AT_CORNERS = False
#: how far (m) the uniform, ring and tripod feet stay inside the outline
#: (at least the MuJoCo feet's radius, ``PhysicsSettings.foot_radius``)
FOOT_INSET = 1.0e-3
#: the ``any`` mixture's tripods take ``c`` uniform in [TRIPOD_MIN_FRACTION, 1] x tripod_fit
TRIPOD_MIN_FRACTION = 0.5
#: orientations tried when fitting a tripod inside the outline
TRIPOD_TRIALS = 72

_PHI3 = 1.2207440846057596


@functools.lru_cache(maxsize=None)
def kronecker_points(n: int) -> np.ndarray:
    """(n, 3) a fixed quasi-uniform sequence in the unit cube (Kronecker, the
    generalised golden ratio in 3D), float64."""
    return np.mod(0.5 + np.outer(np.arange(1, n + 1), [1 / _PHI3, 1 / _PHI3 ** 2, 1 / _PHI3 ** 3]),
                  1.0)


def _edges(body):
    """Outward unit normals (h, 2) and offsets (h,) of a CCW polygon
    ``{x: n_e . x <= d_e}``; ``d_e`` is the origin's distance to edge ``e``."""
    body = jnp.asarray(body)
    e = jnp.roll(body, -1, axis=0) - body
    n = jnp.stack([e[:, 1], -e[:, 0]], -1) / jnp.linalg.norm(e, axis=1, keepdims=True)
    return n, jnp.einsum("ei,ei->e", n, body)


def _inset(points, body, inset: float):
    """``points`` scaled about the origin so that the scaled outline lies at
    least ``inset`` inside ``body`` (never below half size)."""
    _, d = _edges(body)
    lam = jnp.clip(1.0 - inset / jnp.maximum(jnp.min(d), 1e-300), 0.5, 1.0)
    return lam * points


def standing_feet(feet, body):
    """The feet a part stands on: ``feet`` (F, 2; body frame, the centre of
    mass at the origin; m) when the centre of mass is inside their hull, else
    the same feet with ``h`` of them (indices ``round(i F / h)``, spread over
    the sequence) replaced by the corners of ``body`` (h, 2, CCW, the centre
    of mass inside), so that the centre of mass stands inside whatever the
    feet (a part overhanging its pad rests on its corners).  The centre of
    mass is outside the feet's hull when their directions from it leave a
    gap of at least pi.  With :data:`FEET_AT_CORNERS`, or on a part of more
    corners than feet (``h > F``, a rounded outline), it stands on its
    corners and the feet, (h + F, 2), always (:func:`family_point_count`)."""
    feet, body = jnp.asarray(feet), jnp.asarray(body)
    F, h = feet.shape[0], body.shape[0]
    if FEET_AT_CORNERS or h > F:
        return jnp.concatenate([body.astype(feet.dtype), feet])
    ang = jnp.sort(jnp.arctan2(feet[:, 1], feet[:, 0]))
    gaps = jnp.diff(ang, append=ang[:1] + 2.0 * math.pi)
    outside = jnp.max(gaps) >= math.pi
    idx = np.round(np.arange(h) * F / h).astype(np.int64)
    return jnp.where(outside, feet.at[idx].set(body.astype(feet.dtype)), feet)


def uniform_points(body, inset: float = FOOT_INSET):
    """(UNIFORM_FEET, 2) points spread over the CCW polygon ``body`` (h
    vertices; body frame, the centre of mass inside; m): a fixed Kronecker
    sequence mapped through the triangle fan from the origin (a triangle
    chosen by area, a point uniform in it), corners in place of some of them
    when the centre of mass falls outside their hull (:func:`standing_feet`),
    all moved ``inset`` inside the outline.  With :data:`FEET_AT_CORNERS`, or
    more corners than feet, (h + UNIFORM_FEET, 2): the corners and the
    sequence."""
    body = jnp.asarray(body)
    u = jnp.asarray(kronecker_points(UNIFORM_FEET), body.dtype)
    nxt = jnp.roll(body, -1, axis=0)
    area = jnp.maximum(0.5 * (body[:, 0] * nxt[:, 1] - body[:, 1] * nxt[:, 0]), 0.0)
    cdf = jnp.cumsum(area) / jnp.sum(area)
    tri = jnp.minimum(jnp.searchsorted(cdf, u[:, 0], side="right"), body.shape[0] - 1)
    a, b = jnp.sqrt(u[:, 1]), u[:, 2]          # uniform in the triangle (0, v_i, v_i+1)
    pts = (a * (1.0 - b))[:, None] * body[tri] + (a * b)[:, None] * nxt[tri]
    return _inset(standing_feet(pts, body), body, inset)


def ring_points(body, inset: float = FOOT_INSET):
    """(RING_FEET, 2) points on the outline of the CCW polygon ``body`` (h
    vertices, m), equally spaced by arc length (half a spacing from vertex
    0), corners in place of some of them when the centre of mass falls
    outside their hull (:func:`standing_feet`), all moved ``inset`` inside
    it.  With :data:`FEET_AT_CORNERS`, or more corners than feet,
    (h + RING_FEET, 2): the corners and the rim."""
    body = jnp.asarray(body)
    nxt = jnp.roll(body, -1, axis=0)
    length = jnp.linalg.norm(nxt - body, axis=1)
    cum = jnp.concatenate([jnp.zeros(1, body.dtype), jnp.cumsum(length)])
    s = (jnp.arange(RING_FEET, dtype=body.dtype) + 0.5) / RING_FEET * cum[-1]
    e = jnp.clip(jnp.searchsorted(cum, s, side="right") - 1, 0, body.shape[0] - 1)
    t = ((s - cum[e]) / jnp.maximum(length[e], 1e-300))[:, None]
    rim = body[e] * (1.0 - t) + nxt[e] * t
    return _inset(standing_feet(rim, body), body, inset)


def _tripod_dirs(rot):
    a = rot + jnp.arange(3) * (2.0 * math.pi / 3.0)
    return jnp.stack([jnp.cos(a), jnp.sin(a)], -1)


def _tripod_reach(body, inset: float):
    """Per trial rotation (TRIPOD_TRIALS,): the largest circumradius whose
    three feet lie ``inset`` inside ``body``; and the rotations."""
    body = jnp.asarray(body)
    n, d = _edges(body)
    rots = jnp.arange(TRIPOD_TRIALS, dtype=body.dtype) * (2.0 * math.pi / 3.0 / TRIPOD_TRIALS)
    dirs = jax.vmap(_tripod_dirs)(rots)                          # (T, 3, 2)
    nu = jnp.einsum("tki,ei->tke", dirs, n)                      # (T, 3, h)
    reach = jnp.where(nu > 1e-12, (d - inset)[None, None] / jnp.where(nu > 1e-12, nu, 1.0),
                      jnp.inf)
    return jnp.min(reach, axis=(1, 2)), rots


def tripod_fit(body, inset: float = FOOT_INSET):
    """() the largest tripod circumradius (m) whose feet fit ``inset`` inside
    the CCW polygon ``body`` (body frame, origin at the centre of mass)."""
    reach, _ = _tripod_reach(body, inset)
    return jnp.maximum(jnp.max(reach), 0.0)


def tripod_points(c, body, inset: float = FOOT_INSET):
    """(3, 2) feet of circumradius ``c`` (m) about the centre of mass, turned
    to lie as deep inside ``body`` as possible (of ``TRIPOD_TRIALS``
    rotations, the one that fits the largest tripod)."""
    reach, rots = _tripod_reach(body, inset)
    return c * _tripod_dirs(rots[jnp.argmax(reach)])


#: semi-smooth Newton iterations of :func:`equilibrium_weights` (the active set
#: settles in a few; the property test checks 1e-9 m of balance)
EQUILIBRIUM_ITERATIONS = 40


@functools.partial(jax.jit, static_argnames="iterations")
def equilibrium_weights(points, iterations: int = EQUILIBRIUM_ITERATIONS):
    """(S,) loads (fractions of the weight) of equal springs that can lift
    off, under a rigid body standing on ``points`` (S, 2; m, the centre of
    mass at the origin): ``w_i = max(0, a + b . p_i)`` (the support's plane,
    tilted by the centre of mass's offset; feet it leaves carry nothing) with
    ``sum w = 1`` and ``sum w p = 0``.  That is the minimum-norm ``w >= 0``
    balancing the weight, solved through its concave dual
    ``max l . (1, 0, 0) - |max(0, X l)|^2 / 2`` by semi-smooth Newton steps
    with a backtracking line search (step lengths ``2^-j``, j < 12, tried at
    once) from the all-in-contact solution (affine loads, uniform when the centre
    of mass is the points' centroid).  Compiled once per shape: the physics
    layer calls it once per sample, and an uncompiled loop compiled a new
    executable each time (memory maps grew until LLVM failed)."""
    p = jnp.asarray(points)
    scale = jnp.maximum(jnp.max(jnp.abs(p)), 1e-300)
    X = jnp.concatenate([jnp.ones((p.shape[0], 1), p.dtype), p / scale], axis=1)   # (S, 3)
    b = jnp.asarray([1.0, 0.0, 0.0], p.dtype)
    ridge = 1e-13 * jnp.eye(3, dtype=p.dtype)
    lam0 = solve3(X.T @ X + ridge, b)

    ts = 2.0 ** -jnp.arange(12, dtype=p.dtype)           # candidate step lengths

    def dual(lam):
        return b @ lam - 0.5 * jnp.sum(jnp.maximum(X @ lam, 0.0) ** 2)

    def step(_, lam):
        z = X @ lam
        on = (z > 0).astype(p.dtype)
        grad = b - X.T @ jnp.maximum(z, 0.0)
        hess = (X * on[:, None]).T @ X + ridge
        d = solve3(hess, grad)
        gs = jax.vmap(lambda t: dual(lam + t * d))(ts)
        ok = gs >= dual(lam) + 1e-4 * ts * (grad @ d)
        return lam + ts[jnp.argmax(ok)] * jnp.any(ok) * d

    lam = jax.lax.fori_loop(0, int(iterations), step, lam0)
    w = jnp.maximum(X @ lam, 0.0)
    return w / jnp.sum(w)


def _triples(h: int) -> np.ndarray:
    return np.asarray(list(itertools.combinations(range(h), 3)), np.int32).reshape(-1, 3)


def _corner_triangles(corners, tol):
    """Every corner triangle ``idx`` (T, 3), the centre of mass's barycentric
    coordinates ``lam`` (T, 3) in it and whether it holds the centre of mass
    (``valid``: non-degenerate, every coordinate >= ``-tol``)."""
    p = jnp.asarray(corners)
    idx = jnp.asarray(_triples(p.shape[0]))                     # (T, 3)
    P = p[idx]                                                   # (T, 3, 2)
    A = jnp.concatenate([jnp.swapaxes(P, 1, 2), jnp.ones((idx.shape[0], 1, 3), p.dtype)], 1)
    det = det3(A)
    size = jnp.maximum(jnp.max(jnp.abs(p)), 1e-300)
    ok_det = jnp.abs(det) > 1e-9 * size * size
    Asafe = jnp.where(ok_det[:, None, None], A, jnp.eye(3, dtype=p.dtype))
    lam = solve3(Asafe, jnp.broadcast_to(jnp.asarray([0.0, 0.0, 1.0], p.dtype),
                                         (idx.shape[0], 3)))
    return idx, lam, ok_det & jnp.all(lam >= -tol, axis=1)


def corner_weights(corners, lift):
    """(h,) loads of a rigid part resting on its corners (module docstring).

    Args:
      corners: (h, 2) hull vertices, body frame (origin at the centre of mass), m.
      lift: (h,) how far each corner protrudes below the nominal face (any
        scale; only the order matters).

    Returns:
      (h,) the centre of mass's barycentric coordinates in the triangle of
      corners that carries the part (three non-zero in general), summing to 1.
    """
    p = jnp.asarray(corners)
    lift = jnp.asarray(lift, p.dtype)
    # a centre of mass on a triangle's edge (a rectangle's diagonal) is inside, in float32 too
    idx, lam, valid = _corner_triangles(p, 100.0 * jnp.finfo(p.dtype).eps)
    score = jnp.where(valid, jnp.einsum("tk,tk->t", lam, lift[idx]), -jnp.inf)
    best = jnp.argmax(score)
    w = jnp.zeros(p.shape[0], p.dtype).at[idx[best]].add(jnp.maximum(lam[best], 0.0))
    return w / jnp.sum(w)


def family_points(family: str, body, c=None):
    """The support points of a feet family (uniform, ring, tripod) on ``body``
    (body frame, m); rigid: the hull corners themselves."""
    if family == "uniform":
        return uniform_points(body)
    if family == "ring":
        return ring_points(body)
    if family == "tripod":
        return tripod_points(c, body)
    if family == "rigid":
        return jnp.asarray(body)
    raise ValueError(f"family: expected one of {tuple(f.name for f in TABLE if f.feet)}, "
                     f"got {family!r}")


def family_point_count(family: str, n_corners: int, n_sampled: int) -> int:
    """How many support points :func:`family_support` builds for ``family`` on a
    part of ``n_corners`` hull corners (``points``: the ``n_sampled`` sampled)."""
    def feet(count):    # the corners too with FEET_AT_CORNERS or more corners than feet
        return count + (n_corners if FEET_AT_CORNERS or n_corners > count else 0)

    return {"rigid": n_corners, "uniform": feet(UNIFORM_FEET), "ring": feet(RING_FEET),
            "tripod": 3, "points": n_sampled}[family]


def family_c_range(family: str, body) -> tuple[float, float]:
    """The range (m) of the limit-surface ratio ``c`` that a family can give
    the nominal part ``body`` (CCW, body frame, the centre of mass at the
    origin), host side in float64: ``rigid`` over every corner triangle that
    holds the centre of mass; ``uniform``, ``ring`` one value; ``any`` from
    ``TRIPOD_MIN_FRACTION`` of the largest fitting tripod to the largest of
    the others (corners included)."""
    b = np.asarray(body, np.float64)
    with jax.enable_x64(True):
        bj = jnp.asarray(b)
        if family == "rigid":
            idx, lam, valid = (np.asarray(a) for a in _corner_triangles(bj, 1e-12))
            lam = np.maximum(lam[valid], 0.0)
            r = np.linalg.norm(b, axis=1)[idx[valid]]
            cs = np.sum(lam * r, axis=1) / np.sum(lam, axis=1)
            return float(cs.min()), float(cs.max())
        row = FAMILY.get(family)
        if row is not None and row.planned and not row.varies:   # uniform, ring: one value
            pts = np.asarray(family_points(family, bj))
            w = np.asarray(equilibrium_weights(jnp.asarray(pts)))
            c = float(w @ np.linalg.norm(pts, axis=1))
            return c, c
        if family == ANY:
            lo = TRIPOD_MIN_FRACTION * float(tripod_fit(bj))
            his = [family_c_range(f, b)[1] for f in ANY_COMPONENTS if FAMILY[f].planned]
            return lo, max(his)
    raise ValueError(f"family: expected one of {', '.join(PLAN_SUPPORTS)}, got {family!r}")


def family_support(families: tuple, code, body, c, lift, points, weights):
    """The support points and loads of one sample (one part; ``jax.vmap`` over
    samples), padded to one shape whatever its family, for the exact limit
    surface (:mod:`kernels.quasistatic_points`).

    Args:
      families: static tuple of the family names the batch may hold (one
        for a fixed family, :data:`ANY_COMPONENTS` under ``any``); only those
        are built.
      code: () int32, the sample's family (:data:`CODES`).
      body: (h, 2) the (perturbed) hull, CCW, body frame (origin at the centre
        of mass), m: the corners and the feet are the sampled part's.
      c: () the tripod's circumradius, m.
      lift: (h,) corner flatness ranks (rigid).
      points, weights: (S, 2), (S,) the ``points`` family's sampled support.

    Returns:
      ``(points (T, 2), weights (T,))``: the family's points with their loads
      (rigid: the corners, :func:`corner_weights`; uniform, ring, tripod: the
      feet with :func:`equilibrium_weights`; points: as sampled), zero loads
      on the padding; ``T`` the largest count among ``families``.
    """
    body = jnp.asarray(body)
    built = []
    for fam in families:
        if fam == "rigid":
            built.append((fam, body, corner_weights(body, lift)))
        elif fam == "points":
            built.append((fam, jnp.asarray(points, body.dtype), jnp.asarray(weights, body.dtype)))
        else:
            pts = family_points(fam, body, c)
            built.append((fam, pts, equilibrium_weights(pts)))
    T = max(p.shape[0] for _, p, _ in built)

    def pad(p, w):
        k = T - p.shape[0]
        return (jnp.concatenate([p, jnp.zeros((k, 2), p.dtype)]),
                jnp.concatenate([w, jnp.zeros((k,), w.dtype)]))

    out_p, out_w = pad(*built[0][1:])
    for fam, p, w in built[1:]:
        pp, ww = pad(p, w)
        sel = code == CODES[fam]
        out_p = jnp.where(sel, pp, out_p)
        out_w = jnp.where(sel, ww, out_w)
    return out_p, out_w
