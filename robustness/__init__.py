"""nudge robustness analysis (the public API of ``robustness``).

* Tolerance models (:class:`GeometryTolerance`, :class:`FrictionRange`,
  :class:`ExecutionTolerance`) and the :class:`Sampler` that draws them with
  explicit ``jax.random`` keys, as :class:`Draws`.
* :func:`evaluate`: Monte-Carlo replay of a push or tumble plan on perturbed
  parts, friction and robot errors, returning an :class:`Evaluation`
  (per-sample frame and summary).
* Analytic bounds: :func:`push_plan_bound` and :func:`tumble_first_order_bound`
  (first order, exact model derivatives; a :class:`Bound`), :func:`tumble_plan_paper_bounds`
  (Marigo-Bicchi eqs. 4-6).
* :func:`certify`: sample, replay and decide what can be claimed about a plan
  (a :class:`Certificate`: the one-sided Clopper-Pearson bound at the required
  confidence, or why nothing can be claimed); :func:`summarise` summarises any
  set of samples.
* The block runner's pure half (:mod:`robustness.blocks`): :func:`sample_block`
  (one block of samples and its statistics), :class:`BlockRun` (a task's blocks
  grown look by look; ``certify`` runs one, the command line's studies and
  certifications add files and resume), :func:`summarise_stats`.
* Robust synthesis: :func:`synthesize` (candidate plans of a push task scored
  on the same draws, :func:`select` by an explicit objective; certify the
  chosen one on fresh draws, :func:`selection_key`).
* Tolerance design: :mod:`tolerance_design` (the loosest value of each tolerance
  that still certifies a plan, what drives its failures, a joint design
  verified on fresh draws).
* Plan kinds: :data:`KINDS`, the dispatch table (each plan kind's draw, replay,
  physics rollout, bound and defaults; :func:`kind_of` a plan's row by
  ``plan.kind``, :func:`kind_for_part`).
* Success: :class:`SuccessCriterion` (the tolerances, their defaults by plan kind
  and the one classification of every model's samples).
* Values handed down: :class:`Model` (a model's name, the kernels' dtype,
  MuJoCo's settings: what ``evaluate``, ``certify``, ``synthesize`` and the
  design's judge take as ``model=``), :class:`Requirement` (probability,
  confidence, criterion: what a certificate must show), :class:`Selection`
  (robust synthesis' draws and objective).
* Statistics: :func:`clopper_pearson`, :func:`one_sided_lower`, :func:`one_sided_upper`;
  the default confidence :data:`CONFIDENCE` and required probability
  :data:`REQUIRED_PROBABILITY`.

Units: metres, radians.  Nothing here reads or writes files; the edge
(:mod:`sweeps`) does.
"""
from robustness.certificates import Certificate, certify
from robustness.bounds import (Bound, SourceBound, push_plan_bound, tumble_first_order_bound,
                               tumble_plan_paper_bounds)
from robustness.evaluation import MODELS, BoundViolation, Evaluation, evaluate
from robustness.samplers import Draws, PerturbationParams, Sampler
from robustness.stats import (CONFIDENCE, REQUIRED_PROBABILITY, clopper_pearson, one_sided_lower,
                              one_sided_upper, samples_needed)
from robustness.summary import summarise
from robustness.synthesis import (GRID_MARGINS_DEG, GRID_SAFETY_FACTORS, GRID_STRATEGIES,
                                  SHORTLIST, Candidate, Scores, Selection, Synthesis, physics_tiebreak, physics_veto, push_candidates,
                                  score_candidates, select, selection_key, synthesize, tiebreak_key,
                                  veto_key)
from robustness.tolerances import (ExecutionTolerance, FrictionRange, GeometryTolerance,
                                   Requirement, SuccessCriterion)

# used by the layers above (the one boundary: tests/test_layers.py)
from robustness.failure_modes import COLOURS as FAILURE_MODE_COLOURS, MODES as FAILURE_MODE_TABLE
from robustness.tables import (CANDIDATES_SCHEMA, CERTIFICATES_SCHEMA, DESIGN_SCHEMA, PLANS_SCHEMA,
                               SAMPLES_SCHEMA, SUMMARY_SCHEMA, TABLES as TABLE_SCHEMAS, arrow_table,
                               rows_table, samples_columns, schema_for, with_design)
from robustness.tolerance_design import (AXES as DESIGN_AXES, HEADROOM as DESIGN_HEADROOM,
                                         Judge as DesignJudge, axes_for as design_axes_for,
                                         design_key, design_samples_needed, drawing_line,
                                         joint_design, loosest as loosest_tolerances,
                                         sensitivity as tolerance_sensitivity)
from robustness.compiled import release_executables
from robustness.confirmation import NO_PHYSICS, PhysicsCheck, confirm_in_physics, confirmation_key
from robustness.certificates import (Schedule, auto_schedule, certify_block_size, decide, grow,
                                     no_plan, perturbed_sources, plan_certificate)
from robustness.kinds import (KINDS, NOT_EVALUATED, PlanKind, kind_for_part, kind_of, model_for,
                              plan_kind)
from robustness.models import (DEFAULT_MODEL, PUSH_KINEMATIC, Model, THROUGHPUT, block_samples,
                               decision_model, peak_bytes, samples_per_second)
from robustness.summary import STAT_COLUMNS, empty_summary
from robustness.blocks import Block, BlockRun, sample_block, summarise_stats
from robustness.margins import MarginRecommendation, MarginTrial, recommend_margins
from robustness.sensorless import is_sensorless, start_set
from robustness.tables import FAILURE_MODES, to_arrow

__all__ = [
    "synthesize", "tiebreak_key", "veto_key", "physics_tiebreak", "physics_veto", "push_candidates", "score_candidates", "select", "selection_key", "Candidate",
    "Scores", "Selection", "Synthesis", "GRID_MARGINS_DEG", "GRID_SAFETY_FACTORS", "GRID_STRATEGIES",
    "GeometryTolerance", "FrictionRange", "ExecutionTolerance", "SuccessCriterion", "Requirement", "Model", "Sampler",
    "CONFIDENCE", "REQUIRED_PROBABILITY", "plan_kind", "KINDS", "NOT_EVALUATED", "PlanKind",
    "kind_for_part", "kind_of", "DEFAULT_MODEL", "decision_model", "SHORTLIST",
    "NO_PHYSICS", "PhysicsCheck", "confirm_in_physics", "confirmation_key",
    "Draws", "PerturbationParams",
    "evaluate", "Evaluation", "BoundViolation", "MODELS", "Bound", "SourceBound", "push_plan_bound",
    "tumble_first_order_bound", "tumble_plan_paper_bounds", "clopper_pearson", "one_sided_lower",
    "one_sided_upper", "samples_needed", "certify", "Certificate", "summarise",
    "FAILURE_MODES", "FAILURE_MODE_COLOURS", "FAILURE_MODE_TABLE", "CANDIDATES_SCHEMA",
    "CERTIFICATES_SCHEMA", "DESIGN_SCHEMA", "PLANS_SCHEMA", "SAMPLES_SCHEMA", "SUMMARY_SCHEMA",
    "TABLE_SCHEMAS", "arrow_table", "rows_table", "samples_columns", "schema_for", "with_design",
    "DESIGN_AXES", "DESIGN_HEADROOM", "DesignJudge", "design_axes_for", "design_key",
    "design_samples_needed", "drawing_line", "joint_design", "loosest_tolerances",
    "tolerance_sensitivity", "STAT_COLUMNS", "Schedule", "auto_schedule", "decide", "empty_summary",
    "grow", "certify_block_size", "plan_certificate", "MarginRecommendation", "MarginTrial", "recommend_margins", "PUSH_KINEMATIC", "THROUGHPUT", "block_samples", "model_for", "peak_bytes", "release_executables", "samples_per_second", "no_plan", "perturbed_sources", "to_arrow", "is_sensorless", "start_set",
    "Block", "BlockRun", "sample_block", "summarise_stats",
]
