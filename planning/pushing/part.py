"""A pushed part prepared for planning: validation of the part and of the
planner settings, and the tables every planner reads (stable edges, maximum
reorient angles, step angles, object class), cached per part and settings.

Frames: the body frame of :mod:`kernels.polygon` (origin at the centre of mass),
metres and radians.
"""
from __future__ import annotations

import dataclasses
import functools
import math

import jax
import jax.numpy as jnp
import numpy as np

from kernels import polygon as pg
from kernels.precision import float64

POS_TOL = 1e-9   # m: a plan must reach the goal position this closely (replayed)
ANG_TOL = 1e-9   # rad: and the goal orientation
SAME_ORIENTATION = 1e-12  # rad: start and goal orientations this close admit a translation plan
OBJECTIVES = ("distance", "pushes")


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

    @property
    def omega(self) -> np.ndarray:
        """Body-frame angle (rad) of the push direction into each stable edge
        (the edge's outward normal turned by pi), in the order of ``stable``."""
        return self.nu[list(self.stable)] + math.pi

    def peshkin(self, edge: int, pivot: int, alpha: float) -> float:
        """Peshkin distance (m) of a reorient push of ``alpha`` rad onto hull
        ``edge`` about hull vertex ``pivot``, times the safety factor (numpy twin
        of :func:`kernels.polygon.peshkin_distance`)."""
        k, beta2 = pg.pivot_constants_np(self.body, float(self.nu[edge]), pivot)
        return float(pg.peshkin_length_np(self.safety_factor * k, beta2 - alpha, beta2))


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


@float64
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
