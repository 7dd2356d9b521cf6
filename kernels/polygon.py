"""Geometry of a convex polygonal part pushed by a fence (Akella & Mason 1992).

Two layers live here:

* :func:`make_polygon` validates a caller's part on the host (numpy + scipy):
  vertices in any order, optional centre of mass; returns a :class:`Polygon`
  whose hull is in CCW order and whose vertices are expressed in the **body
  frame** (origin at the centre of mass, axes those of the caller's frame).
* :func:`polygon_geometry` and the functions below it are pure JAX, written
  for one part and lifted with ``jax.vmap`` over perturbed vertex sets.

Conventions (see ``DESIGN.md``): metres and radians, angles CCW positive.
A planar pose ``(x, y, theta)`` maps body to world,
``p_world = R(theta) p_body + (x, y)``, i.e. ``(x, y)`` is the world position
of the centre of mass.  Edge ``e`` of a hull with ``n`` vertices runs from
body vertex ``e`` to vertex ``(e + 1) % n``; its outward normal has body-frame
angle ``nu[e]``.  Vertex ``k`` touches a fence whose outward direction (from
the part towards the fence, body frame) lies in its normal cone
``[nu[k-1], nu[k]]``.
"""
from __future__ import annotations

import dataclasses
import functools
import math
import warnings
from typing import Sequence

import jax
import jax.numpy as jnp
import numpy as np
from scipy.spatial import ConvexHull, QhullError

from kernels.errors import PartError, PartWarning, warn_implausible_size
from kernels.planar import TWO_PI, cross2, mod_2pi, wrap_angle

UNI_STABLE, BIPLUS_STABLE, NICE_STABLE = 0, 1, 2
OBJECT_CLASS_NAMES = ("uni-stable", "biplus-stable", "nice-stable")

CW, CCW = 0, 1

#: An edge whose centre-of-mass foot lies within this fraction of its length of
#: one of its ends is *marginal*: flush on the fence, the part balances on that
#: end vertex with the centre of mass straight above it, an unstable
#: equilibrium.  A marginal edge is not stable (the paper's "strictly inside",
#: made robust to rounding): no plan lands it, the replay stops at the
#: equilibrium (:attr:`kernels.push.PushOutcome.marginal`) and the push function
#: resolves it (:mod:`planning.pushing.stability`).
MARGINAL_FOOT = 1e-12


# --------------------------------------------------------------------------
# Host-side validation
# --------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True, eq=False)
class Polygon:
    """A validated convex polygonal part.

    Attributes:
      vertices: (m, 2) the caller's vertices, metres, caller's frame, as given.
      com: (2,) centre of mass in the caller's frame, metres.
      hull_index: caller indices of the hull vertices in CCW order (len n).
      body: (n, 2) hull vertices in the body frame (``vertices[hull_index] - com``).
      dropped: caller indices not on the hull (interior, reflex or collinear).
    """

    vertices: np.ndarray
    com: np.ndarray
    hull_index: tuple[int, ...]
    body: np.ndarray
    dropped: tuple[int, ...]

    @property
    def n(self) -> int:
        """Number of hull vertices (= number of edges)."""
        return len(self.hull_index)

    @functools.cached_property
    def size(self) -> float:
        """The part's largest extent (m): the longest distance between two hull
        vertices.  Every length tolerance of the push planner is relative to it
        (computed once per polygon: the planner asks for it per candidate)."""
        return hull_extent(self.body)

    def edge_vertices(self, e: int) -> tuple[int, int]:
        """Caller vertex indices ``(a, b)`` of hull edge ``e`` (from a to b, CCW)."""
        return (self.hull_index[e], self.hull_index[(e + 1) % self.n])

    def caller_edge_to_hull(self, edge: Sequence[int]) -> int:
        """Hull edge index of a caller vertex-index pair (either order)."""
        a, b = int(edge[0]), int(edge[1])
        for e in range(self.n):
            if {a, b} == set(self.edge_vertices(e)):
                return e
        raise PartError(f"edge {list(edge)} is not an edge of the part's hull; hull edges are "
                        f"{[list(self.edge_vertices(e)) for e in range(self.n)]}")

    def to_dict(self) -> dict:
        """Plain-JSON description: caller vertices and centre of mass."""
        return {"vertices": self.vertices.tolist(), "com": self.com.tolist()}


def as_points(values, field: str, dim: int) -> np.ndarray:
    """``values`` as an (m, ``dim``) float64 array of finite points (m), else a
    :class:`PartError` naming ``field``."""
    try:
        arr = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise PartError(f"{field}: expected a list of [x, y{', z' if dim == 3 else ''}] numbers ({exc})") from None
    if arr.ndim != 2 or arr.shape[1] != dim:
        raise PartError(f"{field}: expected shape (m, {dim}), got {arr.shape}; give one "
                        f"[{', '.join('xyz'[:dim])}] row per vertex")
    if not np.all(np.isfinite(arr)):
        bad = sorted(set(np.argwhere(~np.isfinite(arr))[:, 0].tolist()))
        raise PartError(f"{field}: rows {bad} hold NaN or inf; give finite coordinates in metres")
    return arr


def hull_extent(points: np.ndarray) -> float:
    """Largest distance (m) between two of the given points (the diameter of a
    polygon given by its vertices)."""
    p = np.asarray(points, dtype=np.float64)
    diff = p[:, None, :] - p[None, :, :]
    return float(np.sqrt(np.max(np.sum(diff * diff, axis=-1))))


def polygon_area_centroid(ccw_points: np.ndarray) -> tuple[float, np.ndarray]:
    """Signed area (m^2, positive for CCW) and area centroid (m) of a simple polygon."""
    p = np.asarray(ccw_points, dtype=np.float64)
    q = np.roll(p, -1, axis=0)
    cross = p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]
    area = 0.5 * cross.sum()
    centroid = ((p + q) * cross[:, None]).sum(axis=0) / (6.0 * area)
    return float(area), centroid


def make_polygon(vertices, com=None) -> Polygon:
    """Validate a polygonal part and put it in its body frame.

    Args:
      vertices: (m, 2) vertex coordinates in metres, any order.  Points that
        are not vertices of the convex hull are dropped with a
        :class:`PartWarning` naming them (a non-convex part is pushed like its
        convex hull, assumption 2 of the paper).
      com: optional (2,) centre of mass in the same frame; default: the area
        centroid of the hull.  It must lie strictly inside the hull.

    Returns:
      A :class:`Polygon`.

    Raises:
      PartError: NaN/inf, fewer than 3 non-collinear points, zero area, or a
        centre of mass outside the part; the message names the field and fix.

    Warns:
      PartWarning: points dropped (above), or a part whose size is implausible
        for coordinates in metres (:func:`kernels.errors.warn_implausible_size`:
        a part written in millimetres); it is still accepted as metres.
    """
    pts = as_points(vertices, "vertices", 2)
    m = len(pts)
    if m < 3:
        raise PartError(f"vertices: a polygon needs at least 3 vertices, got {m}")
    scale = float(np.max(np.abs(pts - pts.mean(axis=0)))) or 1.0
    try:
        hull = ConvexHull(pts)
    except QhullError:
        raise PartError("vertices: the points are collinear or coincident (zero area); give at "
                        "least 3 points that are not on one line") from None
    idx = [int(i) for i in hull.vertices]  # CCW for 2-D hulls
    hp = pts[idx]
    area, centroid = polygon_area_centroid(hp)
    if area < 0:
        idx.reverse()
        hp = pts[idx]
        area = -area
    if area <= 1e-14 * scale * scale:
        raise PartError("vertices: the polygon has zero area; give at least 3 points that are not "
                        "on one line")
    dropped = tuple(sorted(set(range(m)) - set(idx)))
    warn_implausible_size(hull_extent(hp))
    if dropped:
        warnings.warn(f"vertices: points {list(dropped)} are not vertices of the convex hull "
                      "(interior, reflex or collinear); the part is treated as its convex hull",
                      PartWarning, stacklevel=2)
    if com is None:
        c = centroid
    else:
        c = as_points([com], "com", 2)[0] if np.ndim(com) == 1 else None
        if c is None:
            raise PartError(f"com: expected [x, y], got shape {np.shape(com)}")
    # strictly inside: positive distance to every edge line
    q = np.roll(hp, -1, axis=0)
    e = q - hp
    rel = c[None, :] - hp
    cross = e[:, 0] * rel[:, 1] - e[:, 1] * rel[:, 0]
    dist = cross / np.linalg.norm(e, axis=1)
    if np.min(dist) <= 1e-12 * scale:
        raise PartError(f"com: the centre of mass {c.tolist()} is not strictly inside the part "
                        f"(signed distance to the nearest edge {np.min(dist):.3g} m); give a "
                        "centre of mass inside the polygon, or omit it to use the area centroid")
    return Polygon(vertices=pts, com=np.asarray(c, dtype=np.float64), hull_index=tuple(idx),
                   body=hp - c[None, :], dropped=dropped)


# --------------------------------------------------------------------------
# Pure JAX geometry
# --------------------------------------------------------------------------
@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class PolygonGeometry:
    """Push geometry of one convex polygon, body frame (a JAX pytree).

    All fields are arrays (traced); the vertex count ``n`` is their static
    leading dimension.

    Attributes:
      body: (n, 2) CCW hull vertices relative to the centre of mass, metres.
      nu: (n,) body-frame angle of edge ``e``'s outward normal, rad in (-pi, pi].
      exterior: (n,) exterior (turning) angle at vertex ``k``, i.e. the width
        of its normal cone ``nu[k] - nu[k-1]`` mod 2 pi, rad in (0, pi).
      foot: (n,) position of the foot of the perpendicular from the centre of
        mass on edge ``e``, as a fraction of the edge from vertex ``e`` (0) to
        vertex ``e+1`` (1).
      height: (n,) distance from the centre of mass to edge ``e``'s line, m.
      stable: (n,) bool, edge ``e`` is stable: its foot lies strictly inside,
        more than :data:`MARGINAL_FOOT` from either end.
      marginal: (n,) bool, edge ``e`` is marginal: its foot lies within
        :data:`MARGINAL_FOOT` of an end (not stable; see :data:`MARGINAL_FOOT`).
      radius: () radius of the smallest circle about the centre of mass that
        encloses the part, m.
    """

    body: jax.Array
    nu: jax.Array
    exterior: jax.Array
    foot: jax.Array
    height: jax.Array
    stable: jax.Array
    marginal: jax.Array
    radius: jax.Array


def polygon_geometry(body) -> PolygonGeometry:
    """Push geometry of a convex polygon from its CCW body-frame vertices.

    Args:
      body: (n, 2) CCW vertices relative to the centre of mass (metres).

    Returns:
      :class:`PolygonGeometry`; pure and vmap-able over a batch of vertex sets
      with the same ``n``.
    """
    body = jnp.asarray(body)
    nxt = jnp.roll(body, -1, axis=0)
    e = nxt - body
    nu = wrap_angle(jnp.arctan2(-e[:, 0], e[:, 1]))  # outward normal (ey, -ex), in (-pi, pi]
    exterior = mod_2pi(nu - jnp.roll(nu, 1))
    foot = jnp.sum(-body * e, axis=1) / jnp.sum(e * e, axis=1)
    height = cross2(e, -body) / jnp.linalg.norm(e, axis=1)
    stable = (foot > MARGINAL_FOOT) & (foot < 1.0 - MARGINAL_FOOT)
    marginal = (jnp.abs(foot) <= MARGINAL_FOOT) | (jnp.abs(foot - 1.0) <= MARGINAL_FOOT)
    radius = jnp.max(jnp.linalg.norm(body, axis=1))
    return PolygonGeometry(body=body, nu=nu, exterior=exterior, foot=foot, height=height,
                           stable=stable, marginal=marginal, radius=radius)


def radius_function(geom: PolygonGeometry, phi):
    """Radius function: distance (m) from the centre of mass to the supporting
    line whose outward normal has body-frame angle ``phi`` (rad); its local
    minima are the stable edges' normals."""
    u = jnp.stack([jnp.cos(phi), jnp.sin(phi)], axis=-1)
    return jnp.max(geom.body @ u.T, axis=0) if u.ndim == 2 else jnp.max(geom.body @ u)


def object_class(geom: PolygonGeometry):
    """Akella-Mason class: 0 uni-stable (one stable edge), 1 biplus-stable
    (several stable edges whose outward normals do not positively span the
    plane), 2 nice-stable (they do: every angular gap between consecutive
    stable normals is below pi)."""
    n_stable = jnp.sum(geom.stable)
    # largest CCW gap between consecutive stable normals
    ang = jnp.where(geom.stable, mod_2pi(geom.nu), jnp.inf)
    srt = jnp.sort(ang)
    valid = jnp.isfinite(srt)
    first = srt[0]
    last = jnp.max(jnp.where(valid, srt, -jnp.inf))
    nxt = jnp.concatenate([srt[1:], srt[:1]])
    gaps = jnp.where(valid & jnp.isfinite(nxt), nxt - srt, 0.0)
    gaps = jnp.concatenate([gaps, jnp.array([first + TWO_PI - last])])
    spans = jnp.max(gaps) < jnp.pi - 1e-12
    return jnp.where(n_stable <= 1, UNI_STABLE, jnp.where(spans, NICE_STABLE, BIPLUS_STABLE))


def pivot_vertex(n: int, edge, sense):
    """Vertex about which a reorient push onto ``edge`` rotates: its start
    vertex for a CW rotation, its end vertex for CCW."""
    return jnp.where(sense == CW, edge, (edge + 1) % n)


def alignment_angle(geom: PolygonGeometry, edge, sense):
    """beta2 (rad): at the end of a reorient push onto ``edge`` (edge flush
    with the fence), the angle between the push direction and the line from
    the pivot vertex to the centre of mass.  It is also the rotation that
    separates the flush orientation from the divergent one (centre of mass
    straight ahead of the pivot)."""
    n = geom.body.shape[0]
    v = geom.body[pivot_vertex(n, edge, sense)]
    u = jnp.stack([jnp.cos(geom.nu[edge]), jnp.sin(geom.nu[edge])])
    return jnp.arctan2(jnp.abs(cross2(u, v)), jnp.dot(u, v))


def max_reorient_angle(geom: PolygonGeometry, edge, sense):
    """Maximum reorient angle (rad) for a push that rotates the part in
    ``sense`` (CW=0 / CCW=1) about the pivot vertex until stable ``edge`` lies
    flush: the smaller of the angle to the divergent orientation and the
    exterior angle at the pivot (beyond which the neighbouring edge would touch
    the fence first).  Zero for an unstable edge."""
    n = geom.body.shape[0]
    ext = jnp.where(sense == CW, geom.exterior[edge], geom.exterior[(edge + 1) % n])
    ang = jnp.minimum(alignment_angle(geom, edge, sense), ext)
    return jnp.where(geom.stable[edge], ang, 0.0)


def max_reorient_table(geom: PolygonGeometry):
    """(n, 2) maximum reorient angles (rad) for every edge, columns CW, CCW."""
    n = geom.body.shape[0]
    edges = jnp.arange(n)
    return jnp.stack([jax.vmap(max_reorient_angle, (None, 0, None))(geom, edges, CW),
                      jax.vmap(max_reorient_angle, (None, 0, None))(geom, edges, CCW)], axis=1)


def step_angle(max_reorient, margin):
    """Step angle (rad) of the angle-eating heuristic: the maximum reorient
    angle less the margin, the margin never taking more than half of it (so
    that parts whose every reorient angle is smaller than the margin stay
    plannable)."""
    return max_reorient - jnp.minimum(margin, 0.5 * max_reorient)


def peshkin_distance(geom: PolygonGeometry, edge, sense, alpha, safety_factor=1.0):
    """Push distance (m) guaranteed to complete a reorient push of ``alpha``
    rad onto ``edge`` rotating in ``sense``, times ``safety_factor``
    (:func:`peshkin_length` with the pivot's constants)."""
    n = geom.body.shape[0]
    v = geom.body[pivot_vertex(n, edge, sense)]
    beta2 = alignment_angle(geom, edge, sense)
    return peshkin_length(safety_factor * peshkin_gain(geom.radius, jnp.linalg.norm(v)),
                          beta2 - alpha, beta2)


def peshkin_gain(radius, rho):
    """``k = (a^2 + rho^2) / rho`` (m) of :func:`peshkin_length`: ``a`` the radius
    of the smallest circle about the centre of mass enclosing the part, ``rho``
    the distance from the pivot vertex to the centre of mass (m; JAX or numpy)."""
    return (radius * radius + rho * rho) / rho


def peshkin_length(k, beta1, beta2):
    """Worst-case push distance (m) that turns ``beta`` from ``beta1`` to ``beta2`` (rad).

    Derivation (Peshkin & Sanderson 1988, restated for a fence that does not
    slip on the part).  While the fence touches only the pivot vertex P, the
    part rotates about P as P advances with the fence.  Let ``beta`` be the
    angle between the push direction and the line from P to the centre of
    mass C, ``rho = |PC|`` and ``a`` the radius of the smallest circle about C
    enclosing the part.  Whatever the (unknown) support pressure distribution,
    quasi-static equilibrium of the support friction bounds the rotation per
    unit push from below: ``d beta / d s >= rho sin(beta) / (a^2 + rho^2)``.
    Integrating from ``beta1`` to ``beta2`` gives the worst-case distance
    ``s = k ln(tan(beta2/2) / tan(beta1/2))`` with ``k = (a^2 + rho^2) / rho``
    (:func:`peshkin_gain`).  For a reorient push of ``alpha`` onto an edge,
    ``beta2`` is the edge's :func:`alignment_angle` and ``beta1 = beta2 - alpha``.
    Assumptions: quasi-static motion, Coulomb friction with uniform coefficient
    on the support, no slip at the fence, a normal push, and
    ``0 < beta1 <= beta2 < pi`` (the start is on the convergent side of the
    divergent orientation).  The distance diverges as ``beta1`` approaches 0
    (the divergent orientation) - hence the margin angle.  The paper multiplies
    it by a safety factor of 1.15.  JAX; :func:`peshkin_length_np` is its twin.
    """
    return k * (jnp.log(jnp.tan(0.5 * beta2)) - jnp.log(jnp.tan(0.5 * beta1)))


def peshkin_length_np(k, beta1, beta2):
    """numpy / float twin of :func:`peshkin_length`."""
    return k * (np.log(np.tan(0.5 * beta2)) - np.log(np.tan(0.5 * beta1)))


def pivot_constants_np(body: np.ndarray, nu_edge: float, pivot: int) -> tuple[float, float]:
    """``(k, beta2)`` of a reorient push onto the edge whose outward normal has
    body-frame angle ``nu_edge`` (rad), pivoting on body vertex ``pivot``:
    :func:`peshkin_gain` (m) and the :func:`alignment_angle` (rad); numpy, float64."""
    v = np.asarray(body[pivot], np.float64)
    u = np.array([math.cos(nu_edge), math.sin(nu_edge)])
    radius = float(np.max(np.hypot(body[:, 0], body[:, 1])))
    beta2 = math.atan2(abs(float(cross2(u, v))), float(u @ v))
    return float(peshkin_gain(radius, math.hypot(v[0], v[1]))), beta2
