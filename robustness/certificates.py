"""Certificates: what a Monte-Carlo evaluation of a plan shows, and nothing more.

A certificate answers "does this plan reach its goal with probability at least
``p`` on the real, imperfect part?" for one task, from ``n`` samples of the
stated model (quasi-static pushes, the exact replay, or exact tumbles) drawn
from the stated tolerances:

* **certified**: the one-sided Clopper-Pearson lower bound of the success
  probability at the required confidence (at each look's share of it when the
  samples were drawn sequentially, see below) is at least ``p``.  That is the
  only probability claim made, and the certificate's ``claim`` says it in
  words: the bound, the confidence, the procedure, the number of samples, the
  model and what was perturbed.
* **not certified**, with a ``reason``:

  - ``too_few_samples``: every sample succeeded, but ``n`` is below the
    ``samples_needed`` (the fewest all-successful samples that reach ``p`` at
    that confidence); more samples may certify;
  - ``failures``: some samples failed and the lower bound is below ``p``; the
    dominant failure mode says how (``below_requirement`` when even the
    one-sided upper bound is below ``p``: more samples cannot help);
  - ``nothing_perturbed``: no tolerance, friction range or error varies, so
    every sample is the same replay and no probability can be claimed.

* **no plan**: the planner found none (its reason is in ``note``).

How many samples, and at which confidence each bound is taken, is the
certificate's :class:`Schedule` (its ``procedure``):

* ``fixed`` (``n_samples = N``): one look at ``N`` samples, the plain one-sided
  Clopper-Pearson bound at the required confidence.
* ``sequential_bonferroni`` (``n_samples = "auto"``): looks at a schedule of
  sample counts fixed before any sample is drawn (:func:`auto_schedule`: the
  fewest that could certify, doubling, up to the cap), stopping at the first
  look that decides.  Re-testing at every look at the full confidence would not
  hold it (a plan exactly at the requirement came out "certified" in 28 % of
  runs at 95 %), so ``alpha = 1 - confidence`` is split over the ``K`` looks:
  each look's bounds are taken at ``1 - alpha / K`` (``look_confidence``).  By
  the union bound, the chance that ANY look's lower bound exceeds the true
  success probability, or any upper bound falls below it, is at most
  ``alpha``: a false "certified" and a false "below_requirement" each have
  probability at most ``alpha`` over the whole procedure
  (:func:`robustness.stats.sequential_rates` computes both exactly).

The analytic first-order bound of :mod:`robustness.bounds` is reported beside
the verdict with the model it assumes (``bound_model``): it is the linearised
worst case of the exact, no-slip kinematics over the tolerance box, not a
proven bound (second-order terms, slip, incomplete reorientation and wrong
edges are outside it), so it never certifies anything on its own.  A
Monte-Carlo sample beyond it is reported as a finding (``bound_violated``).
"""
from __future__ import annotations

import dataclasses
import math
from typing import Callable, Optional

import numpy as np

from robustness import stats
from robustness.kinds import KINDS, kind_of
from robustness.models import DEFAULT_MODEL, Model
from robustness.tolerances import Requirement, SuccessCriterion

VERDICTS = ("certified", "not certified", "no plan")
PROCEDURES = ("fixed", "sequential_bonferroni")
REASONS = ("", "too_few_samples", "failures", "below_requirement", "nothing_perturbed", "no_plan")
BOUND_MODEL = ("first-order worst case of the exact no-slip kinematics over the tolerance box "
               "(linearised, not a guarantee)")


@dataclasses.dataclass(frozen=True)
class Certificate:
    """What was shown for one task (fields of the ``certificates`` table).

    Attributes:
      verdict: one of :data:`VERDICTS`; reason: one of :data:`REASONS`.
      claim: one sentence stating exactly what was shown (or why nothing was).
      n_samples, n_success: the Monte Carlo; success_rate: their ratio.
      ci_low_one_sided: one-sided Clopper-Pearson lower bound at ``confidence``.
      samples_needed: fewest all-successful samples that would certify.
      required_probability, confidence: the requirement.
      procedure: one of :data:`PROCEDURES`; look_confidence: the confidence of
      each look's bounds (``confidence`` for a fixed count, ``1 - alpha / n_looks``
      when sequential); n_looks, look_counts: the schedule; look: the look the
      verdict was taken at (1-based; 0 without samples).
      nothing_perturbed: no source of variation in the samples.
      perturbed: what varied (part geometry, start pose, fence friction...).
      dominant_failure_mode: the commonest failure, ``none`` without failures.
      bound_position_m, bound_theta_rad, bound_within_eps, bound_violated,
      bound_model: the analytic bound beside the verdict (NaN when not computed).
      note: anything else the reader must know.
    """

    verdict: str
    reason: str
    claim: str
    n_samples: int
    n_success: int
    success_rate: float
    ci_low_one_sided: float
    samples_needed: int
    required_probability: float
    confidence: float
    nothing_perturbed: bool
    perturbed: tuple
    dominant_failure_mode: str
    model: str
    procedure: str = "fixed"
    look_confidence: float = math.nan
    n_looks: int = 1
    look: int = 1
    look_counts: tuple = ()
    bound_position_m: float = math.nan
    bound_theta_rad: float = math.nan
    bound_within_eps: Optional[bool] = None
    bound_violated: Optional[bool] = None
    bound_model: str = BOUND_MODEL
    note: str = ""

    def to_row(self) -> dict:
        """The certificate's fields for the ``certificates`` table."""
        d = dataclasses.asdict(self)
        d.pop("perturbed")
        d["look_counts"] = [int(c) for c in self.look_counts]
        return d


@dataclasses.dataclass(frozen=True)
class Schedule:
    """The looks of a certification, fixed before any sample is drawn.

    Attributes:
      counts: increasing total sample counts, one per look.
      confidence: the confidence the whole procedure holds (in (0, 1)).
    """

    counts: tuple
    confidence: float

    def __post_init__(self):
        c = tuple(int(x) for x in self.counts)
        if not c or c[0] < 1 or any(b <= a for a, b in zip(c, c[1:])):
            raise ValueError(f"counts: expected increasing sample counts >= 1, got {list(c)}")
        if not (0.0 < self.confidence < 1.0):
            raise ValueError(f"confidence: expected a number in (0, 1), got {self.confidence!r}")
        object.__setattr__(self, "counts", c)

    @property
    def n_looks(self) -> int:
        """``K``, the number of looks."""
        return len(self.counts)

    @property
    def procedure(self) -> str:
        """``fixed`` (one look) or ``sequential_bonferroni``."""
        return "fixed" if self.n_looks == 1 else "sequential_bonferroni"

    @property
    def look_confidence(self) -> float:
        """Confidence of each look's one-sided bounds: ``1 - (1 - confidence) / K``."""
        return 1.0 - (1.0 - self.confidence) / self.n_looks

    def describe(self) -> str:
        """The procedure in words (named in every claim)."""
        if self.n_looks == 1:
            return (f"one-sided Clopper-Pearson at {_pct(self.confidence)} confidence, fixed "
                    f"n = {self.counts[0]}")
        c = [str(x) for x in self.counts]
        shown = ", ".join(c if len(c) <= 6 else c[:3] + ["..."] + c[-2:])
        return (f"sequential: Bonferroni over {self.n_looks} looks at n = {shown}, each a "
                f"one-sided Clopper-Pearson bound at {_pct(self.look_confidence)} confidence, "
                f"{_pct(self.confidence)} over all looks")


def _pct(c: float) -> str:
    """A confidence as a percentage with three significant digits of ``1 - c``,
    rounded down (95%, 98.75%, 99.583%): never overstated, never 100%."""
    d = max(0, 2 - math.floor(math.log10(100.0 * (1.0 - c))))
    t = f"{math.floor(100.0 * c * 10 ** d + 1e-6) / 10 ** d:.{d}f}"
    return (t.rstrip("0").rstrip(".") if "." in t else t) + "%"


def perturbed_sources(sampler, kind: str, model: str, sensorless: bool = False) -> tuple:
    """What varies between samples of ``sampler`` under ``model`` (names);
    ``sensorless``: a sensorless plan's, whose start is drawn over its start set
    in place of the start error (:mod:`robustness.sensorless`)."""
    g, e = sampler.geometry, sampler.execution
    out = []
    if g.tau_v > 0:
        out.append("part vertices")
    if g.tau_com > 0:
        out.append("centre of mass")
    if sensorless:
        out.append("start heading and position (uniform)")
    elif e.start_xy > 0 or e.start_theta > 0:
        out.append("start pose")
    out += KINDS[kind].sources(sampler, model)   # the kind's own execution errors
    return tuple(out)


def decide(summary: dict, requirement: Requirement, *, kind: str, model: str, perturbed: tuple,
           schedule: Optional[Schedule] = None, starts: str = "") -> Certificate:
    """The certificate of a task's Monte-Carlo summary (see the module docstring).

    Args:
      summary: the summary row (``robustness.summary.summarise``): ``n``,
        ``n_success``, ``dominant_failure_mode``, the bound fields.
      requirement: the :class:`~robustness.Requirement` (probability and
        confidence; its ``criterion``, the samples' success criterion, reports
        whether the analytic bound lies within its tolerances: None, not reported).
      kind, model: the plan kind and the evaluation model (named in the claim).
      perturbed: :func:`perturbed_sources` of the sampler.
      schedule: the looks the samples were drawn by (:func:`auto_schedule`;
        ``n`` must be one of its counts); None: one fixed look at ``n``.  Every
        bound is taken at its ``look_confidence``.
      starts: a sensorless plan's start set in words
        (:func:`robustness.sensorless.start_set`: ``any heading in [a, b] deg and
        any position in [xmin, xmax] x [ymin, ymax] m``), which every claim
        with samples begins with (``from any heading in ...: P(success) >= ...``);
        "": a known start.
    """
    if not isinstance(requirement, Requirement):
        raise ValueError(f"requirement: expected a robustness.Requirement, got {requirement!r}")
    cert = _decide(summary, requirement.probability, requirement.confidence, kind=kind,
                   model=model, perturbed=perturbed, criterion=requirement.criterion,
                   schedule=schedule)
    if starts and cert.n_samples:
        cert = dataclasses.replace(cert, claim=f"from {starts}: {cert.claim}")
    return cert


def _decide(summary: dict, required_probability: float, confidence: float, *, kind: str,
            model: str, perturbed: tuple, criterion: Optional[SuccessCriterion] = None,
            schedule: Optional[Schedule] = None) -> Certificate:
    """:func:`decide` for a known start."""
    p, conf = float(required_probability), float(confidence)
    n, k = int(summary["n"]), int(summary["n_success"])
    if schedule is None:
        schedule = Schedule((max(n, 1),), conf)
    elif schedule.confidence != conf:
        raise ValueError(f"schedule: its confidence {schedule.confidence} is not the required "
                         f"{conf}")
    if n and n not in schedule.counts:
        raise ValueError(f"summary: n = {n} samples is not a look of the schedule "
                         f"{list(schedule.counts)}")
    lc = schedule.look_confidence
    low = stats.one_sided_lower(k, n, lc) if n else 0.0
    need = stats.samples_needed(p, lc)
    dominant = str(summary.get("dominant_failure_mode") or "none")
    bp = float(summary.get("bound_position_m", math.nan))
    bt = float(summary.get("bound_theta_rad", math.nan))
    within = (bool(criterion.within(bp, bt))
              if criterion is not None and math.isfinite(bp) and math.isfinite(bt) else None)
    common = dict(n_samples=n, n_success=k, success_rate=k / n if n else math.nan,
                  ci_low_one_sided=low, samples_needed=need, required_probability=p,
                  confidence=conf, nothing_perturbed=not perturbed, perturbed=tuple(perturbed),
                  dominant_failure_mode=dominant, model=model, bound_position_m=bp,
                  bound_theta_rad=bt, bound_within_eps=within,
                  bound_violated=summary.get("bound_violated"), **_procedure(schedule, n))
    sequential = schedule.n_looks > 1
    what = f"{n} samples of the {model} model"
    how = (f"{schedule.describe()}; verdict at look {schedule.counts.index(n) + 1} of "
           f"{schedule.n_looks}: {what}" if sequential and n
           else f"one-sided Clopper-Pearson over {what}")
    at = (f"at the look's {_pct(lc)} confidence ({_pct(conf)} over all looks)" if sequential
          else f"at {_pct(conf)} confidence")
    varied = f"perturbed: {', '.join(perturbed)}" if perturbed else "nothing perturbed"
    notes = []
    if summary.get("bound_violated"):
        notes.append("a sample exceeded the first-order bound (a finding: the bound is not a "
                     "guarantee)")
    if not perturbed:
        return Certificate(verdict="not certified", reason="nothing_perturbed",
                           claim=(f"nothing was perturbed (no part or execution tolerance, no "
                                  f"friction range): the {n} samples are one replay of the nominal "
                                  f"plan, {'which succeeds' if k == n and n else 'which fails'}; "
                                  "no probability can be claimed"),
                           note="; ".join(notes), **common)
    if n and low >= p:
        return Certificate(verdict="certified", reason="",
                           claim=(f"P(success) >= {low:.4f} >= {p:g} at {_pct(conf)} confidence "
                                  f"({how}; {varied})"),
                           note="; ".join(notes), **common)
    if n and k == n:
        return Certificate(verdict="not certified", reason="too_few_samples",
                           claim=(f"{k}/{n} succeeded, but at least {need} successes without a "
                                  f"failure are needed for p >= {p:g} {at} (one-sided "
                                  f"Clopper-Pearson lower bound {low:.4f}; {varied})"),
                           note="; ".join(notes), **common)
    upper = stats.one_sided_upper(k, n, lc) if n else 1.0
    reason = "below_requirement" if upper < p else "failures"
    tail = (f"; even the upper bound {upper:.4f} is below {p:g}: more samples cannot certify"
            if reason == "below_requirement" else "")
    return Certificate(verdict="not certified", reason=reason,
                       claim=(f"{k}/{n} succeeded ({how}; {varied}): one-sided Clopper-Pearson "
                              f"lower bound {low:.4f} < {p:g} {at}; dominant failure: "
                              f"{dominant}{tail}"),
                       note="; ".join(notes), **common)


def _procedure(schedule: Schedule, n: int) -> dict:
    """The certificate's procedure fields for a verdict taken at ``n`` samples."""
    return dict(procedure=schedule.procedure, look_confidence=schedule.look_confidence,
                n_looks=schedule.n_looks, look=schedule.counts.index(n) + 1 if n else 0,
                look_counts=schedule.counts)


def no_plan(reason: str, requirement: Requirement, model: str,
            schedule: Optional[Schedule] = None) -> Certificate:
    """The certificate of a task the planner could not serve (nothing sampled)
    under ``requirement`` (a :class:`~robustness.Requirement`); ``schedule``:
    the looks it would have had (its procedure is recorded)."""
    required_probability, confidence = requirement.probability, requirement.confidence
    schedule = schedule or Schedule((stats.samples_needed(required_probability, confidence),),
                                    confidence)
    return Certificate(verdict="no plan", reason="no_plan", claim=f"no plan: {reason}",
                       n_samples=0, n_success=0, success_rate=math.nan, ci_low_one_sided=math.nan,
                       samples_needed=stats.samples_needed(required_probability,
                                                           schedule.look_confidence),
                       required_probability=required_probability, confidence=confidence,
                       nothing_perturbed=False, perturbed=(), dominant_failure_mode="no_plan",
                       model=model, note=f"planner: {reason}", **_procedure(schedule, 0))


def decided(n: int, k: int, required_probability: float, look_confidence: float) -> bool:
    """Whether a look at ``k`` successes of ``n`` decides the verdict: the
    one-sided lower bound at ``look_confidence`` reaches the requirement, or the
    upper bound lies below it (a :class:`Schedule`'s ``look_confidence``, not the
    overall confidence, when there are several looks)."""
    if n == 0:
        return False
    return (stats.one_sided_lower(k, n, look_confidence) >= required_probability
            or stats.one_sided_upper(k, n, look_confidence) < required_probability)


def auto_sample_counts(required_probability: float, look_confidence: float, cap: int) -> list[int]:
    """Doubling sample counts: the fewest that could certify at
    ``look_confidence`` (all successful), doubling while below ``cap``, then ``cap``."""
    n = stats.samples_needed(required_probability, look_confidence)
    out = []
    while n < cap:
        out.append(n)
        n *= 2
    out.append(int(cap))
    return out


def auto_schedule(required_probability: float, confidence: float, cap: int) -> Schedule:
    """The looks of ``--n-samples auto``, fixed before any sample is drawn.

    The counts double from the fewest all-successful samples that certify at
    the per-look confidence ``1 - alpha / K`` up to ``cap``; the smallest ``K``
    whose doubling schedule has at most ``K`` looks is taken (a larger ``K``
    starts higher, so has no more looks), and each look's bounds are then at
    ``1 - alpha / (number of looks)``: Bonferroni over the looks, so the whole
    procedure holds ``confidence`` (see the module docstring).
    """
    if not (isinstance(cap, (int, np.integer)) and cap >= 1):
        raise ValueError(f"max_samples: expected an integer >= 1, got {cap!r}")
    alpha = 1.0 - float(confidence)
    K = 1
    while True:
        counts = auto_sample_counts(required_probability, 1.0 - alpha / K, int(cap))
        if len(counts) <= K:
            return Schedule(tuple(counts), float(confidence))
        K += 1


def grow(evaluate_more: Callable[[int], tuple[int, int]], schedule: Schedule,
         requirement: Requirement) -> tuple[int, int]:
    """Draw samples look by look until one decides (at the schedule's
    ``look_confidence``) or the last look is reached.

    Args:
      evaluate_more: ``f(n_total) -> (n, k)``: extends the evaluation to
        ``n_total`` samples (reusing those drawn before) and returns the totals.
      schedule: the looks (:func:`auto_schedule`, or one fixed count).
      requirement: the :class:`~robustness.Requirement` a look decides against
        (its probability; the looks' confidence is the schedule's).

    Returns:
      ``(n, k)`` at the end.
    """
    n = k = 0
    for target in schedule.counts:
        n, k = evaluate_more(int(target))
        if n < target or decided(n, k, requirement.probability, schedule.look_confidence):
            break       # n < target: interrupted
    return n, k


def certify_block_size(plan, model: str, support, schedule: "Schedule") -> int:
    """Samples per block of a certification of ``plan`` under ``model`` (a
    name) on ``support``: :func:`robustness.block_samples` of the plan's kind,
    at most the schedule's first look (:func:`certify` and ``nudge certify``
    alike, so that one key draws the same samples in both)."""
    from robustness.models import block_samples

    return min(schedule.counts[0], block_samples(kind_of(plan).kind, model, support))


def plan_certificate(summary: dict, requirement: Requirement, plan, sampler, model: str,
                     schedule: "Schedule") -> Certificate:
    """:func:`decide` for ``plan``'s summary under ``model`` (a name): what
    varied among ``sampler``'s draws and, for a sensorless plan, its start set
    first in the claim (:func:`certify` and ``nudge certify`` alike)."""
    from robustness.sensorless import is_sensorless, start_set

    kind, sensorless = kind_of(plan).kind, is_sensorless(plan)
    return decide(summary, requirement, kind=kind, model=model,
                  perturbed=perturbed_sources(sampler, kind, model, sensorless),
                  schedule=schedule, starts=start_set(plan) if sensorless else "")


#: the most samples an ``"auto"`` certification draws (:func:`auto_schedule`'s cap)
MAX_SAMPLES = 100_000


def certify(plan, sampler, key, requirement: Optional[Requirement] = None, *,
            samples="auto", model=DEFAULT_MODEL, task: str = "task", bound: bool = True):
    """Certify one plan: sample, replay, decide (see the module docstring).

    Args:
      plan: a :class:`~planning.PushPlan` or :class:`~planning.TumblePlan`.
      sampler: the :class:`~robustness.Sampler` of the tolerances.
      key: a ``jax.random`` key; block ``b`` of samples uses ``fold_in(key, b)``, so
        growing the sample count keeps the samples drawn before; blocks of
        :func:`robustness.block_samples` (at most the first look's count), as
        ``nudge certify`` draws them, so the same key certifies on the same
        samples in both.
      requirement: the :class:`~robustness.Requirement` (probability, confidence,
        success criterion; default ``Requirement()``: 0.9 at 95 %, the plan kind's
        criterion).
      samples: an integer (one look, the plain one-sided bound), ``"auto"``: the
        sequential procedure of :func:`auto_schedule` (looks from the fewest
        samples that could certify, doubling, up to :data:`MAX_SAMPLES`; Bonferroni
        over the looks), stopping at the first look that decides; or a
        :class:`Schedule` of the requirement's confidence (another cap:
        ``auto_schedule(p, confidence, cap)``).
      model, task, bound: as in :func:`robustness.evaluate` (``model`` a name or
        a :class:`~robustness.Model`).

    Returns:
      ``(certificate, samples, summary)``: the :class:`Certificate`, the
      per-sample frame of every block, and the summary row (dict).
    """
    from robustness.blocks import BlockRun

    req = (Requirement() if requirement is None else requirement)
    if not isinstance(req, Requirement):
        raise ValueError(f"requirement: expected a robustness.Requirement, got {req!r}")
    req = req.for_plan(plan)
    p, confidence, criterion = req.probability, req.confidence, req.criterion
    kind = kind_of(plan).kind
    spec = Model.of(model).for_kind(kind)
    if isinstance(samples, Schedule):
        if samples.confidence != confidence:
            raise ValueError(f"samples: the schedule's confidence {samples.confidence} is not "
                             f"the requirement's {confidence}")
        schedule = samples
    elif samples == "auto":
        schedule = auto_schedule(p, confidence, MAX_SAMPLES)
    elif isinstance(samples, int) and not isinstance(samples, bool) and samples >= 1:
        schedule = Schedule((samples,), confidence)
    else:
        raise ValueError(f"samples: expected an integer >= 1, 'auto' or a Schedule, "
                         f"got {samples!r}")
    size = certify_block_size(plan, spec.name, sampler.friction.support, schedule)
    run = BlockRun(plan, sampler, key, size, criterion, spec, task, keep=True)
    grow(run.extend, schedule, req)
    summary = run.summary(kind=kind, model=spec.name, dtype=spec.dtype.name,
                          confidence=confidence, bound=bound)
    cert = plan_certificate(summary, req, plan, sampler, spec.name, schedule)
    frame = run.samples()
    return cert, frame, summary


__all__ = ["Certificate", "MAX_SAMPLES", "Schedule", "certify", "certify_block_size", "decide",
           "plan_certificate", "no_plan", "perturbed_sources",
           "decided", "auto_sample_counts", "auto_schedule", "grow", "VERDICTS", "REASONS",
           "PROCEDURES", "BOUND_MODEL"]
