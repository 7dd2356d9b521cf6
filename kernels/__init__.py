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

The door imports each name from its home module when it is first used
(:func:`open_door`): ``import kernels`` imports no JAX, and the support
families' names (:mod:`kernels.families`) never do.

Kernels take the dtype of their inputs (float32 or float64); planners and
bounds run them under :func:`kernels.precision.float64`.  Units: metres,
radians, CCW positive.
"""
from kernels.door import open_door

__all__ = open_door(__name__, [
    ("kernels.facets", ("TOLERANCE_MERGE_FACTOR",)),
    ("kernels.planar", ("rot2", "wrap_angle")),
    ("kernels.linsolve", ("solve2",)),
    ("kernels.polygon", (
        "PartError", "PartWarning", "Polygon", "PolygonGeometry", "make_polygon", "polygon_geometry")),
    ("kernels.polyhedron", ("Polyhedron", "make_polyhedron")),
    ("kernels.tumble_geometry", ("TumbleGeometry", "tumble_geometry")),
    ("kernels.push", ("PushOutcome", "replay_push", "replay_pushes")),
    ("kernels.quasistatic", (
        "SimOutcome", "limit_surface_ratio", "simulate_push", "simulate_pushes")),
    ("kernels.limit_surface", ("Motion", "push_motion")),
    ("kernels.tumble", ("TumbleConfig", "edge_motion", "make_config", "replay", "tumble")),
    ("kernels.families", ("SUPPORT_FAMILIES",)),
    ("kernels.support", (
        "corner_weights", "equilibrium_weights", "family_c_range", "family_point_count",
        "family_support", "tripod_fit")),
    # used by the layers above (the one boundary: tests/test_layers.py)
    ("kernels.polygon", (
        "BIPLUS_STABLE", "CCW", "CW", "MARGINAL_FOOT", "NICE_STABLE", "OBJECT_CLASS_NAMES",
        "UNI_STABLE", "as_points", "max_reorient_table", "object_class", "peshkin_length",
        "peshkin_length_np", "pivot_constants_np", "step_angle")),
    ("kernels.reorient", ("model_gain", "sticking_angle_limit")),
    ("kernels.families", (
        "CODES", "ANY_COMPONENTS", "FAMILIES", "FAMILY", "PLAN_SUPPORTS", "PLANNED_FAMILIES",
        "REALISABLE_SUPPORTS", "VARYING_SUPPORTS")),
    ("kernels.support", ("TRIPOD_MIN_FRACTION", "family_points", "FOOT_INSET")),
    ("kernels.errors", ("warn_implausible_size",)),
    ("kernels.facets", ("extent", "merge_distance")),
    ("kernels.hulls", (
        "polygon_hull_changed", "polyhedron_hull_tables", "polyhedron_hull_verdict_batch")),
    ("kernels.planar", (
        "TWO_PI", "angle_distance", "mod_2pi", "rot2_np", "wrap_angle_near", "wrap_angle_np")),
    ("kernels.polyhedron", ("DEFAULT_MERGE_TOL", "NEARLY_FLAT_RAD", "combinatorics_changed")),
    ("kernels.precision", ("float64",)),
    ("kernels.tumble", ("replay_trajectory",)),
    ("kernels.door", ("open_door",)),
], aliases={
    "simulate_push_on_points": ("kernels.quasistatic_points", "simulate_push"),
    "simulate_pushes_on_points": ("kernels.quasistatic_points", "simulate_pushes"),
})
