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

Every function computes in float64 whatever the caller's JAX setting, and
every returned plan has been replayed by the exact kinematics of
:mod:`kernels`.  Units: metres, radians, CCW positive.
"""
from planning.pushing.alternatives import plan_alternatives
from planning.pushing.batch import PushPlanBatch, plan_pose_batch
from planning.pushing.options import STRATEGIES, PushOptions
from planning.pushing.part import PlanningError, PushPart, WorkspaceError, prepare_part
from planning.pushing.plan import Push, PushPlan
from planning.pushing.planner import plan_pose
from planning.pushing.funnel import Funnel, PushFunction, exhaustive_length, orient, push_function
from planning.pushing.sensorless import (FencePush, SensorlessPlan, plan_sensorless,
                                        replay_sensorless, start_grid)
from planning.tumbling.analysis import TumbleAnalysis
from planning.tumbling.plan import Tumble, TumblePlan
from planning.tumbling.planner import analyze_polyhedron, plan_tumble, tumble_alternatives
from planning.kinds import PLAN_TYPES, Plan

# used by the layers above (the one boundary: tests/test_layers.py)
from planning.pushing.stability import PushStability, push_stability
from planning.tumbling.development import development_poses, face_footprint, pose3
from planning.tumbling.paper import paper_bounds
from planning.tumbling.reachability import lattice_count_bound, radius_for_count, reduced_basis
from planning.tumbling.trajectory import plan_trajectory, quiet_polyhedron, sample_reached_positions

__all__ = [
    "plan_pose", "plan_alternatives", "tumble_alternatives", "plan_pose_batch", "PushOptions", "prepare_part", "PushPart", "PushPlanBatch", "Push",
    "PushPlan", "STRATEGIES", "PlanningError", "WorkspaceError", "plan_tumble", "analyze_polyhedron", "TumbleAnalysis",
    "Tumble", "TumblePlan", "PLAN_TYPES", "Plan",
    "Funnel", "PushFunction", "exhaustive_length", "orient", "push_function", "FencePush",
    "SensorlessPlan", "plan_sensorless", "replay_sensorless", "start_grid",
    "push_stability", "PushStability", "development_poses", "face_footprint", "lattice_count_bound",
    "paper_bounds", "plan_trajectory", "pose3", "quiet_polyhedron", "radius_for_count",
    "reduced_basis", "sample_reached_positions",
]
