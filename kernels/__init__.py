"""nudge kernels (the public API of ``kernels``): pure JAX functions, written
for one part and lifted with ``jax.vmap`` at the call site.

* Polygons: :func:`make_polygon` (host-side validation), :func:`polygon_geometry`
  (the push geometry as a pytree), :func:`replay_push` / :func:`replay_pushes`
  (the exact push kinematics of Akella & Mason), :func:`simulate_push` /
  :func:`simulate_pushes` (quasi-static pusher-slider with an ellipsoidal limit
  surface and fence friction).
* Polyhedra: :func:`make_polyhedron`, :func:`tumble_geometry`, :func:`tumble`,
  :func:`replay` (exact tumble kinematics of Marigo & Bicchi).
* Supports: :mod:`kernels.support` (the support families a pushed part rests
  on, drawn by the sampler and realised by the MuJoCo scene):
  :func:`corner_weights`, :func:`equilibrium_weights`, :func:`family_c_range`,
  :func:`tripod_fit`.
* Shared formulas: :mod:`kernels.planar` (angle wraps, rotations).

Kernels take the dtype of their inputs (float32 or float64); planners and
bounds run them under :func:`kernels.precision.float64`.  Units: metres,
radians, CCW positive.
"""
from kernels.facets import TOLERANCE_MERGE_FACTOR
from kernels.planar import rot2, wrap_angle
from kernels.polygon import PartError, PartWarning, Polygon, PolygonGeometry, make_polygon, polygon_geometry
from kernels.polyhedron import Polyhedron, make_polyhedron
from kernels.tumble_geometry import TumbleGeometry, tumble_geometry
from kernels.push import PushOutcome, replay_push, replay_pushes
from kernels.quasistatic import SimOutcome, limit_surface_ratio, simulate_push, simulate_pushes
from kernels.tumble import TumbleConfig, make_config, replay, tumble
from kernels.support import (SUPPORT_FAMILIES, corner_weights, equilibrium_weights,
                             family_c_range, tripod_fit)

__all__ = [
    "TOLERANCE_MERGE_FACTOR", "wrap_angle", "rot2", "PartError", "PartWarning", "Polygon", "PolygonGeometry", "make_polygon",
    "polygon_geometry", "Polyhedron", "TumbleGeometry", "make_polyhedron", "tumble_geometry",
    "PushOutcome", "replay_push", "replay_pushes", "SimOutcome", "limit_surface_ratio",
    "simulate_push", "simulate_pushes", "TumbleConfig", "make_config", "replay", "tumble",
    "SUPPORT_FAMILIES", "corner_weights", "equilibrium_weights", "family_c_range", "tripod_fit",
]
