"""A pushed part prepared for planning: validation of the part and of the
planner settings, and the tables every planner reads, cached per part and
settings.

Per stable edge ``e`` and rotation sense (CW = 0, CCW = 1) of a reorient push
that lands ``e``: the pivot vertex, the alignment angle ``beta2``, the
maximum reorient angle, the step angle (after the margin and, for slip-aware
plans, the sticking limit), and the gain ``k`` of the distance rule, so that a
reorient of ``alpha`` rad needs ``k ln(tan(beta2/2) / tan((beta2 - alpha)/2))``
metres (:func:`kernels.polygon.peshkin_length`):

* ``"peshkin"`` (default): ``k = safety_factor (a^2 + rho^2) / rho``, ``a`` the
  part's radius: any support pressure distribution (Peshkin & Sanderson);
* ``"quasi-static"`` (``support={"c": [lo, hi]}``): ``a`` replaced by
  ``min(hi, a)``, the slowest rotation of the quasi-static model for every
  limit-surface ratio up to ``hi`` and every fence friction
  (:mod:`kernels.reorient`, claim 3).

Frames: the body frame of :mod:`kernels.polygon` (origin at the centre of mass),
metres and radians.
"""
from __future__ import annotations

import dataclasses
import functools
import math
import warnings
from typing import Optional

import jax
import jax.numpy as jnp
import numpy as np

from kernels import (as_points, CCW, CW, float64, make_polygon, max_reorient_table, model_gain,
                     object_class as classify_polygon, OBJECT_CLASS_NAMES, PartError, PartWarning,
                     peshkin_length_np, pivot_constants_np, PLANNED_FAMILIES, Polygon,
                     polygon_geometry, PolygonGeometry, step_angle, sticking_angle_limit)
from planning.pushing.options import (DEFAULTS, PlanSupport, check_margin_deg,
                                      check_min_fence_mu, check_safety_factor)

POS_TOL = 1e-9   # x part size: a plan must reach the goal position this closely (replayed)
ANG_TOL = 1e-9   # rad: and the goal orientation
SAME_ORIENTATION = 1e-12  # rad: start and goal orientations this close admit a translation plan
#: rad: every reorient push is long enough to turn this much beyond its planned
#: angle, so that the replay's rounding of the angles (~1e-15 rad) never leaves
#: it a hair short (a zero-slack push of exactly the minimum distance otherwise
#: stops short whenever rounding makes its start angle smaller)
REORIENT_GUARD = 1e-10
DISTANCE_RULES = ("peshkin", "quasi-static")


class PlanningError(RuntimeError):
    """No plan could be produced or verified; the message says why."""


class WorkspaceError(PlanningError):
    """No plan fits the workspace.  ``scale``: the least factor found by which
    the workspace, scaled about its centre, holds a plan (``inf``: none found);
    ``smallest``: that workspace ``(xmin, xmax, ymin, ymax)`` (m), or None."""

    def __init__(self, message: str, scale: float = math.inf, smallest=None):
        super().__init__(message)
        self.scale = scale
        self.smallest = None if smallest is None else tuple(float(x) for x in smallest)


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
      step: (n, 2) step angles (rad): the maximum reorient angle less the
        margin, and for slip-aware plans at most the sticking limit; 0 where
        no reorient push onto the edge in that sense is allowed.
      pivot: (n, 2) hull vertex the part turns about (CW: the edge's start, CCW: its end).
      beta2: (n, 2) alignment angles (rad) of those pivots.
      gain: (n, 2) gains ``k`` (m) of the distance rule, safety factor included.
      stick_limit: (n, 2) largest reorient angle (rad) that sticks for every
        support in the range at ``min_fence_mu`` (``inf`` when not slip-aware).
      object_class: 0 uni-, 1 biplus-, 2 nice-stable.
      margin: margin angle (rad); safety_factor: multiplier of the distance rule;
        margin_deg: the margin as given (degrees).
      support_c: ``(lo, hi)`` limit-surface ratio range (m) or None.
      support: what the distances assume of the support: ``"any"``, a family
        name, or ``"c"`` (the range given).
      min_fence_mu: lower bound of the fence friction for slip-aware plans, or None.
      distance_rule: ``"peshkin"`` or ``"quasi-static"``.
      rate_c: the ratio (m) whose sticking rate the replay uses (``min(hi, a)``),
        None for Peshkin's bound.
      warnings_seen: warnings raised while validating the part (re-issued on
        every :func:`prepare_part`, although the part is cached).
    """

    polygon: Polygon
    geom: PolygonGeometry
    stable: tuple[int, ...]
    max_reorient: np.ndarray
    step: np.ndarray
    pivot: np.ndarray
    beta2: np.ndarray
    gain: np.ndarray
    stick_limit: np.ndarray
    object_class: int
    margin: float
    safety_factor: float
    margin_deg: float = DEFAULTS.margin_deg
    support_c: Optional[tuple[float, float]] = None
    support: str = "any"
    min_fence_mu: Optional[float] = None
    distance_rule: str = "peshkin"
    rate_c: Optional[float] = None
    warnings_seen: tuple = ()

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
    def size(self) -> float:
        """The part's largest extent (m); length tolerances are relative to it."""
        return self.polygon.size

    @property
    def class_name(self) -> str:
        return OBJECT_CLASS_NAMES[self.object_class]

    @property
    def omega(self) -> np.ndarray:
        """Body-frame angle (rad) of the push direction into each stable edge
        (the edge's outward normal turned by pi), in the order of ``stable``."""
        return self.nu[list(self.stable)] + math.pi

    def pos_tol(self, *lengths):
        """Position tolerance (m) of a replayed plan: ``POS_TOL`` times the part's
        size, plus the rounding of world coordinates as long as the sum of
        ``lengths`` (m; floats or arrays, which give an array)."""
        total = sum(np.abs(np.asarray(x, float)) for x in lengths) if lengths else 0.0
        return POS_TOL * self.size + 64.0 * np.finfo(float).eps * total

    @property
    def longest_plan(self) -> float:
        """The longest total push distance (m) a plan may have: world coordinates
        round by about ``64 eps`` per metre pushed, so longer plans (push
        directions that nearly cancel, pushes of many km for a part of cm) could
        not be replayed to ``POS_TOL`` of the part's size in float64; about 7e4
        part sizes.  Candidates past it are not plans."""
        return POS_TOL * self.size / (64.0 * np.finfo(float).eps)

    def reorient_min(self, edge, sense, alpha):
        """Least distance (m) that completes a reorient of ``alpha`` rad onto hull
        ``edge`` in ``sense`` under the distance rule, times the safety factor.
        Scalars give a float; arrays of one shape (``edge``, ``sense`` ints) an array."""
        b2 = self.beta2[edge, sense]
        return peshkin_length_np(self.gain[edge, sense], b2 - np.asarray(alpha, float), b2)

    def reorient_need(self, edge, sense, alpha):
        """The distance (m) a plan gives a reorient of ``alpha`` rad at least:
        :meth:`reorient_min` of ``alpha`` plus ``REORIENT_GUARD``
        (:func:`guarded_start`).  Scalars or arrays, as :meth:`reorient_min`."""
        b2 = self.beta2[edge, sense]
        return peshkin_length_np(self.gain[edge, sense], guarded_start(b2, np.asarray(alpha, float)), b2)

    def peshkin(self, edge: int, pivot: int, alpha: float) -> float:
        """:meth:`reorient_min` for the pivot ``pivot`` (kept for callers that name it)."""
        sense = CW if pivot == edge else CCW
        return self.reorient_min(edge, sense, alpha)


def guarded_start(beta2, alpha, xp=np):
    """The angle ``beta1`` (rad) from which a plan's reorient push of ``alpha``
    rad onto an edge of alignment angle ``beta2`` is given its distance: the
    planned start less ``REORIENT_GUARD`` (at most half the angle left to the
    divergent orientation), so the push turns a hair beyond its plan.  ``xp``:
    ``numpy`` or ``jax.numpy`` (the batched planner's twin uses the same rule)."""
    return beta2 - alpha - xp.minimum(REORIENT_GUARD, 0.5 * (beta2 - alpha))


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


def check_support(support):
    """Validate ``support`` (:meth:`PlanSupport.of`: ``None`` / ``"any"``, a
    family name of :data:`kernels.PLANNED_FAMILIES`, ``{"c": [lo, hi]}`` /
    ``(lo, hi)`` in m, or a :class:`~planning.pushing.options.PlanSupport`).

    Returns ``(family, c_range)``: ``("any", None)``, ``(family, None)`` (the
    range comes from the part) or ``("c", (lo, hi))``."""
    s = PlanSupport.of(support)
    return s.family, s.c


def _tables(part_geom, body, margin, safety, support_c, min_mu):
    """Per (edge, sense) pivot, beta2, gain, sticking limit and step angle."""
    n = len(body)
    stable = np.asarray(part_geom.stable)
    nu = np.asarray(part_geom.nu)
    mx = np.asarray(max_reorient_table(part_geom))
    margin_step = np.asarray(step_angle(jnp.asarray(mx), margin))
    radius = float(np.max(np.hypot(body[:, 0], body[:, 1])))
    rate_c = None if support_c is None else min(support_c[1], radius)
    pivot = np.zeros((n, 2), int)
    beta2 = np.ones((n, 2))
    gain = np.ones((n, 2))
    stick = np.full((n, 2), math.inf)
    step = np.zeros((n, 2))
    for e in range(n):
        for sense in (CW, CCW):
            piv = e if sense == CW else (e + 1) % n
            k, b2 = pivot_constants_np(body, float(nu[e]), piv)
            rho = float(math.hypot(*body[piv]))
            if rate_c is not None:
                k = model_gain(rate_c, rho)
            pivot[e, sense], beta2[e, sense], gain[e, sense] = piv, b2, safety * k
            if not stable[e]:
                continue
            st = float(margin_step[e, sense])
            if min_mu is not None:
                stick[e, sense] = sticking_angle_limit(rho, support_c[0], b2, min_mu)
                st = min(st, stick[e, sense] - 2.0 * REORIENT_GUARD)
            step[e, sense] = max(st, 0.0)
    return mx, step, pivot, beta2, gain, stick, rate_c


@functools.lru_cache(maxsize=64)
def _prepare_cached(vkey: bytes, vshape, ckey, margin_deg: float, safety_factor: float,
                    family, support_c, min_mu) -> PushPart:
    vertices = np.frombuffer(vkey, dtype=np.float64).reshape(vshape)
    com = None if ckey is None else np.frombuffer(ckey, dtype=np.float64)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always", PartWarning)
        poly = make_polygon(vertices, com)
    if family in PLANNED_FAMILIES:   # every c the family gives this part
        from kernels import family_c_range

        support_c = family_c_range(family, np.asarray(poly.body))
    if min_mu is not None and support_c is None:
        raise ValueError("min_fence_mu: slip-aware plans need the support's limit-surface ratio "
                         f"range: give support={{'c': [lo, hi]}} (m) or a family "
                         f"({', '.join(PLANNED_FAMILIES)}) too (whether the fence contact sticks "
                         "depends on it)")
    margin = math.radians(margin_deg)
    geom, cls = _part_geometry(jnp.asarray(poly.body))
    mx, step, pivot, beta2, gain, stick, rate_c = _tables(geom, poly.body, margin, safety_factor,
                                                          support_c, min_mu)
    stable = tuple(int(e) for e in np.flatnonzero(np.asarray(geom.stable)))
    return PushPart(polygon=poly, geom=geom, stable=stable, max_reorient=mx, step=step,
                    pivot=pivot, beta2=beta2, gain=gain, stick_limit=stick, object_class=int(cls),
                    margin=margin, safety_factor=float(safety_factor), margin_deg=float(margin_deg),
                    support_c=support_c, support=family,
                    min_fence_mu=min_mu,
                    distance_rule="peshkin" if support_c is None else "quasi-static",
                    rate_c=rate_c, warnings_seen=tuple((w.message, w.category) for w in seen))


@jax.jit
def _part_geometry(body):
    geom = polygon_geometry(body)
    return geom, classify_polygon(geom)


@float64
def prepare_part(vertices, com=None, margin_deg: float = DEFAULTS.margin_deg,
                 safety_factor: float = DEFAULTS.safety_factor, *,
                 support=None, min_fence_mu: Optional[float] = None) -> PushPart:
    """Validate a part and the planner settings and build the planner's tables.

    Args:
      vertices: (m, 2) part vertices (m), any order (non-convex: hull, with a warning).
      com: optional centre of mass (m), default the area centroid.
      margin_deg: margin angle in degrees, 0 < margin < 90.
      safety_factor: multiplier of the reorient distance rule, >= 1.
      support: ``None`` / ``"any"`` (Peshkin's bound: distances valid for every
        support), a family ``"rigid"``, ``"uniform"`` or ``"ring"``
        (:mod:`kernels.support`: distances valid for every ``c`` that family
        gives this part) or ``{"c": [lo, hi]}`` (m, the support's
        limit-surface ratio range); but for ``any``, reorient distances follow
        the quasi-static model (module docstring).
      min_fence_mu: optional lower bound (>= 0) of the fence friction
        coefficient: only reorient pushes whose fence contact sticks throughout
        for every ``c`` in the support range are allowed (needs ``support``).
    """
    margin_deg = check_margin_deg(margin_deg)
    safety_factor = check_safety_factor(safety_factor)
    family, support_c = check_support(support)
    if min_fence_mu is not None:
        min_fence_mu = check_min_fence_mu(min_fence_mu)
    v = as_points(vertices, "vertices", 2)
    ckey = None
    if com is not None:
        c = np.asarray(com, dtype=np.float64)
        if c.shape != (2,):
            raise PartError(f"com: expected [x, y], got shape {c.shape}")
        if not np.all(np.isfinite(c)):
            raise PartError("com: holds NaN or inf; give a finite centre of mass in metres")
        ckey = c.tobytes()
    part = _prepare_cached(np.ascontiguousarray(v).tobytes(), v.shape, ckey, margin_deg,
                           safety_factor, family, support_c, min_fence_mu)
    for message, category in part.warnings_seen:
        warnings.warn(message, category, stacklevel=3)
    return part
