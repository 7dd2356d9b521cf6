"""nudge kernels (the public API of ``kernels``): pure JAX functions, written
for one part and lifted with ``jax.vmap`` at the call site.

* Polygons: :func:`make_polygon` (host-side validation), :func:`polygon_geometry`
  (the push geometry as a pytree), :func:`replay_push` / :func:`replay_pushes`
  (the exact push kinematics of Akella & Mason), :func:`simulate_push` /
  :func:`simulate_pushes` (quasi-static pusher-slider with an ellipsoidal limit
  surface and fence friction), :func:`simulate_push_on_points` /
  :func:`simulate_pushes_on_points` (the same on the exact limit surface of a
  point support, :func:`push_motion` the instantaneous motion).
* Polyhedra: :func:`make_polyhedron`, :func:`tumble_geometry`, :func:`tumble`,
  :func:`replay` (exact tumble kinematics of Marigo & Bicchi).
* Supports: :mod:`kernels.support` (the support families a pushed part rests
  on, drawn by the sampler and realised by the MuJoCo scene):
  :func:`corner_weights`, :func:`equilibrium_weights`, :func:`family_c_range`,
  :func:`tripod_fit`, :func:`family_support` (a sample's points and loads).
* Shared formulas: :mod:`kernels.planar` (angle wraps, rotations),
  :func:`solve2` (closed-form 2 x 2 solves; :mod:`kernels.linsolve`: no LAPACK
  custom calls in a compiled replay).

Kernels take the dtype of their inputs (float32 or float64); planners and
bounds run them under :func:`kernels.precision.float64`.  Units: metres,
radians, CCW positive.
"""
from kernels.facets import TOLERANCE_MERGE_FACTOR
from kernels.planar import rot2, wrap_angle
from kernels.linsolve import solve2
from kernels.polygon import PartError, PartWarning, Polygon, PolygonGeometry, make_polygon, polygon_geometry
from kernels.polyhedron import Polyhedron, make_polyhedron
from kernels.tumble_geometry import TumbleGeometry, tumble_geometry
from kernels.push import PushOutcome, replay_push, replay_pushes
from kernels.quasistatic import SimOutcome, limit_surface_ratio, simulate_push, simulate_pushes
from kernels.limit_surface import Motion, push_motion
from kernels.quasistatic_points import simulate_push as simulate_push_on_points
from kernels.quasistatic_points import simulate_pushes as simulate_pushes_on_points
from kernels.tumble import TumbleConfig, edge_motion, make_config, replay, tumble
from kernels.support import (SUPPORT_FAMILIES, corner_weights, equilibrium_weights,
                             family_c_range, family_point_count, family_support, tripod_fit)

# used by the layers above (the one boundary: tests/test_layers.py)
from kernels.polygon import (BIPLUS_STABLE, CCW, CW, MARGINAL_FOOT, NICE_STABLE, OBJECT_CLASS_NAMES,
                             UNI_STABLE, as_points, max_reorient_table, object_class,
                             peshkin_length, peshkin_length_np, pivot_constants_np, step_angle)
from kernels.reorient import model_gain, sticking_angle_limit
from kernels.support import CODES, TRIPOD_MIN_FRACTION, family_points
from kernels.errors import warn_implausible_size
from kernels.facets import extent, merge_distance
from kernels.hulls import (polygon_hull_changed, polyhedron_hull_tables,
                           polyhedron_hull_verdict_batch)
from kernels.planar import TWO_PI, angle_distance, mod_2pi, rot2_np, wrap_angle_near, wrap_angle_np
from kernels.polyhedron import DEFAULT_MERGE_TOL, NEARLY_FLAT_RAD, combinatorics_changed
from kernels.precision import float64
from kernels.support import (ANY_COMPONENTS, FAMILIES, FAMILY, FOOT_INSET, PLAN_SUPPORTS,
                             PLANNED_FAMILIES, REALISABLE_SUPPORTS, VARYING_SUPPORTS)
from kernels.tumble import replay_trajectory

__all__ = [
    "TOLERANCE_MERGE_FACTOR", "wrap_angle", "rot2", "solve2", "PartError", "PartWarning", "Polygon", "PolygonGeometry", "make_polygon",
    "polygon_geometry", "Polyhedron", "TumbleGeometry", "make_polyhedron", "tumble_geometry",
    "PushOutcome", "replay_push", "replay_pushes", "SimOutcome", "limit_surface_ratio",
    "simulate_push", "simulate_pushes", "Motion", "push_motion", "simulate_push_on_points",
    "simulate_pushes_on_points", "family_support", "family_point_count", "TumbleConfig", "edge_motion", "make_config", "replay", "tumble",
    "SUPPORT_FAMILIES", "corner_weights", "equilibrium_weights", "family_c_range", "tripod_fit",
    "BIPLUS_STABLE", "CCW", "CW", "MARGINAL_FOOT", "NICE_STABLE", "OBJECT_CLASS_NAMES", "UNI_STABLE",
    "as_points", "max_reorient_table", "object_class", "peshkin_length", "peshkin_length_np",
    "pivot_constants_np", "step_angle", "model_gain", "sticking_angle_limit", "CODES",
    "TRIPOD_MIN_FRACTION", "family_points", "DEFAULT_MERGE_TOL", "NEARLY_FLAT_RAD", "ANY_COMPONENTS",
    "FAMILIES", "FAMILY", "FOOT_INSET",
    "PLAN_SUPPORTS", "PLANNED_FAMILIES", "REALISABLE_SUPPORTS", "VARYING_SUPPORTS", "TWO_PI",
    "angle_distance", "combinatorics_changed", "extent", "float64", "merge_distance", "mod_2pi",
    "polygon_hull_changed", "polyhedron_hull_tables", "polyhedron_hull_verdict_batch",
    "replay_trajectory", "rot2_np", "warn_implausible_size", "wrap_angle_near", "wrap_angle_np",
]
