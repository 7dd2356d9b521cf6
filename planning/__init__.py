"""nudge planners (the public API of ``planning``).

* Fence pushes on convex polygons (Akella & Mason 1992): :func:`plan_pose` (one
  problem, numpy reference, LP in closed form or by cvxpy) and
  :func:`plan_pose_batch` (many start/goal pairs of one part, JAX), and
  :func:`plan_alternatives` (the candidates ranked below the plan, verified:
  robust synthesis chooses among them); plans are
  :class:`PushPlan` values of :class:`Push` steps.
* Sensorless posing (Goldberg 1993, issue 40): :func:`push_function` and
  :func:`orient` (the shortest orienting funnel, up to the push function's
  symmetry) and :func:`plan_sensorless` (orient, register, pose: one list of
  fence-line pushes from any heading and any position in a region, checked by
  :func:`replay_sensorless` from a grid of starts); plans are
  :class:`SensorlessPlan` values of :class:`FencePush` steps.
* Tumbles of convex polyhedra (Marigo & Bicchi): :func:`analyze_polyhedron`
  (rotations, generators, lattice, reachable class) and :func:`plan_tumble`;
  plans are :class:`TumblePlan` values of :class:`Tumble` steps.

Every plan type implements the plan interface (:mod:`planning.kinds`: ``kind``,
``n_steps``, ``nominal_part()``, ``draw_shape()``); :data:`PLAN_TYPES` lists them
by kind.

The door imports each name from its home module when it is first used
(:func:`kernels.open_door`): ``from planning import PushOptions`` imports no JAX.

Every function computes in float64 whatever the caller's JAX setting, and
every returned plan has been replayed by the exact kinematics of
:mod:`kernels`.  Units: metres, radians, CCW positive.
"""
from kernels import open_door

__all__ = open_door(__name__, [
    ("planning.pushing.alternatives", ("plan_alternatives",)),
    ("planning.pushing.batch", ("PushPlanBatch", "plan_pose_batch")),
    ("planning.pushing.options", ("OBJECTIVES", "STRATEGIES", "PushOptions")),
    ("planning.pushing.part", ("PlanningError", "PushPart", "WorkspaceError", "prepare_part")),
    ("planning.pushing.plan", ("Push", "PushPlan")),
    ("planning.pushing.planner", ("plan_pose",)),
    ("planning.pushing.funnel", (
        "Funnel", "PushFunction", "exhaustive_length", "orient", "push_function")),
    ("planning.pushing.sensorless", (
        "FencePush", "SensorlessPlan", "plan_sensorless", "replay_sensorless", "start_grid")),
    ("planning.tumbling.analysis", ("TumbleAnalysis",)),
    ("planning.tumbling.plan", ("Tumble", "TumblePlan")),
    ("planning.tumbling.planner", ("analyze_polyhedron", "plan_tumble", "tumble_alternatives")),
    ("planning.kinds", ("PLAN_TYPES", "Plan")),
    # used by the layers above (the one boundary: tests/test_layers.py)
    ("planning.pushing.stability", ("PushStability", "push_stability")),
    ("planning.tumbling.development", ("development_poses", "face_footprint", "pose3")),
    ("planning.tumbling.paper", ("paper_bounds",)),
    ("planning.tumbling.reachability", (
        "lattice_count_bound", "radius_for_count", "reduced_basis")),
    ("planning.tumbling.trajectory", (
        "plan_trajectory", "quiet_polyhedron", "sample_reached_positions")),
])
