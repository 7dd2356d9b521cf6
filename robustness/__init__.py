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

The door imports each name from its home module when it is first used
(:func:`kernels.open_door`): ``from robustness import cpu_threads`` imports no
JAX, so a command line checks ``$NUDGE_THREADS`` with it before any work.

Units: metres, radians.  Nothing here reads or writes files; the edge
(:mod:`sweeps`) does.
"""
from kernels import open_door

__all__ = open_door(__name__, [
    ("robustness.certificates", ("Certificate", "certify")),
    ("robustness.bounds", (
        "Bound", "SourceBound", "push_plan_bound", "tumble_first_order_bound",
        "tumble_plan_paper_bounds")),
    ("robustness.evaluation", ("MODELS", "BoundViolation", "Evaluation", "evaluate")),
    ("robustness.samplers", ("Draws", "PerturbationParams", "Sampler")),
    ("robustness.stats", (
        "CONFIDENCE", "REQUIRED_PROBABILITY", "clopper_pearson", "one_sided_lower",
        "one_sided_upper", "samples_needed")),
    ("robustness.summary", ("summarise",)),
    ("robustness.synthesis", (
        "GRID_MARGINS_DEG", "GRID_SAFETY_FACTORS", "GRID_STRATEGIES", "SHORTLIST", "Candidate",
        "Scores", "Selection", "Synthesis", "physics_tiebreak", "physics_veto", "push_candidates",
        "score_candidates", "select", "selection_key", "synthesize", "tiebreak_key", "veto_key")),
    ("robustness.tolerances", (
        "ExecutionTolerance", "FrictionRange", "GeometryTolerance", "Requirement",
        "SuccessCriterion")),
    # used by the layers above (the one boundary: tests/test_layers.py)
    ("robustness.tables", (
        "CANDIDATES_SCHEMA", "CERTIFICATES_SCHEMA", "DESIGN_SCHEMA", "PLANS_SCHEMA",
        "SAMPLES_SCHEMA", "SUMMARY_SCHEMA", "arrow_table", "rows_table", "samples_columns",
        "schema_for", "with_design")),
    ("robustness.tolerance_design", (
        "design_key", "design_samples_needed", "drawing_line", "joint_design")),
    ("robustness.compiled", ("release_executables",)),
    ("robustness.confirmation", (
        "NO_PHYSICS", "PhysicsCheck", "confirm_in_physics", "confirmation_key")),
    ("robustness.certificates", (
        "Schedule", "auto_schedule", "certify_block_size", "decide", "grow", "no_plan",
        "perturbed_sources", "plan_certificate")),
    ("robustness.kinds", (
        "KINDS", "NOT_EVALUATED", "PlanKind", "kind_for_part", "kind_of", "model_for", "plan_kind")),
    ("robustness.models", (
        "DEFAULT_MODEL", "PUSH_KINEMATIC", "Model", "THROUGHPUT", "block_samples", "decision_model",
        "peak_bytes", "samples_per_second")),
    ("robustness.summary", ("STAT_COLUMNS", "empty_summary")),
    ("robustness.blocks", ("Block", "BlockRun", "sample_block", "summarise_stats")),
    ("robustness.margins", ("MarginRecommendation", "MarginTrial", "recommend_margins")),
    ("robustness.sensorless", ("is_sensorless", "start_set")),
    ("robustness.tables", ("FAILURE_MODES", "to_arrow")),
    ("robustness.cpus", ("cpu_threads",)),
], aliases={
    "FAILURE_MODE_COLOURS": ("robustness.failure_modes", "COLOURS"),
    "FAILURE_MODE_TABLE": ("robustness.failure_modes", "MODES"),
    "TABLE_SCHEMAS": ("robustness.tables", "TABLES"),
    "DESIGN_AXES": ("robustness.tolerance_design", "AXES"),
    "DESIGN_HEADROOM": ("robustness.tolerance_design", "HEADROOM"),
    "DesignJudge": ("robustness.tolerance_design", "Judge"),
    "design_axes_for": ("robustness.tolerance_design", "axes_for"),
    "loosest_tolerances": ("robustness.tolerance_design", "loosest"),
    "tolerance_sensitivity": ("robustness.tolerance_design", "sensitivity"),
})
