"""nudge robustness analysis (the public API of ``robustness``).

* Tolerance models (:class:`GeometryTolerance`, :class:`FrictionRange`,
  :class:`ExecutionTolerance`) and the :class:`Sampler` that draws them with
  explicit ``jax.random`` keys.
* :func:`evaluate`: Monte-Carlo replay of a push or tumble plan on perturbed
  parts, friction and robot errors, returning an :class:`Evaluation`
  (per-sample frame and summary).
* Analytic bounds: :func:`push_plan_bound` and :func:`tumble_first_order_bound`
  (first order, exact model derivatives), :func:`tumble_plan_paper_bounds`
  (Marigo-Bicchi eqs. 4-6).
* :func:`certify`: sample, replay and decide what can be claimed about a plan
  (a :class:`Certificate`: the one-sided Clopper-Pearson bound at the required
  confidence, or why nothing can be claimed); :func:`summarise` summarises any
  set of samples.
* Statistics: :func:`clopper_pearson`, :func:`one_sided_lower`, :func:`one_sided_upper`.

Units: metres, radians.  Nothing here reads or writes files; the edge
(:mod:`sweeps`) does.
"""
from robustness.certificates import Certificate, certify
from robustness.bounds import push_plan_bound, tumble_first_order_bound, tumble_plan_paper_bounds
from robustness.evaluation import MODELS, BoundViolation, Evaluation, evaluate
from robustness.samplers import PerturbationParams, Sampler
from robustness.stats import clopper_pearson, one_sided_lower, one_sided_upper
from robustness.summary import summarise
from robustness.tolerances import ExecutionTolerance, FrictionRange, GeometryTolerance

__all__ = [
    "GeometryTolerance", "FrictionRange", "ExecutionTolerance", "Sampler", "PerturbationParams",
    "evaluate", "Evaluation", "BoundViolation", "MODELS", "push_plan_bound",
    "tumble_first_order_bound", "tumble_plan_paper_bounds", "clopper_pearson", "one_sided_lower",
    "one_sided_upper", "certify", "Certificate", "summarise",
]
