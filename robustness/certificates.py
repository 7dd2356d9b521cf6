"""Certificates: what a Monte-Carlo evaluation of a plan shows, and nothing more.

A certificate answers "does this plan reach its goal with probability at least
``p`` on the real, imperfect part?" for one task, from ``n`` samples of the
stated model (quasi-static pushes, the exact replay, or exact tumbles) drawn
from the stated tolerances:

* **certified**: the one-sided Clopper-Pearson lower bound of the success
  probability at the required confidence is at least ``p``.  That is the only
  probability claim made, and the certificate's ``claim`` says it in words:
  the bound, the confidence, the number of samples, the model and what was
  perturbed.
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

from robustness import stats

VERDICTS = ("certified", "not certified", "no plan")
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
        return d


def perturbed_sources(sampler, kind: str, model: str) -> tuple:
    """What varies between samples of ``sampler`` under ``model`` (names)."""
    g, f, e = sampler.geometry, sampler.friction, sampler.execution
    out = []
    if g.tau_v > 0:
        out.append("part vertices")
    if g.tau_com > 0:
        out.append("centre of mass")
    if e.start_xy > 0 or e.start_theta > 0:
        out.append("start pose")
    if kind == "push":
        if e.fence_angle > 0:
            out.append("fence angle")
        if e.distance_abs > 0 or e.distance_rel > 0:
            out.append("push distance")
        if model == "quasistatic":  # the exact replay does not depend on friction
            if f.mu_f[1] > f.mu_f[0]:
                out.append("fence friction")
            if f.c is None or f.c[1] > f.c[0]:
                out.append("support pressure")
    elif e.tumble_slip_xy > 0 or e.tumble_slip_theta > 0:
        out.append("slip after tumbles")
    return tuple(out)


def decide(summary: dict, required_probability: float, confidence: float, *, kind: str,
           model: str, perturbed: tuple, pos_eps_m: float = math.nan,
           theta_eps_rad: float = math.nan) -> Certificate:
    """The certificate of a task's Monte-Carlo summary (see the module docstring).

    Args:
      summary: the summary row (``robustness.summary.summarise``): ``n``,
        ``n_success``, ``dominant_failure_mode``, the bound fields.
      required_probability, confidence: the requirement.
      kind, model: the plan kind and the evaluation model (named in the claim).
      perturbed: :func:`perturbed_sources` of the sampler.
      pos_eps_m, theta_eps_rad: the success tolerances (to report whether the
        analytic bound lies within them).
    """
    p, conf = float(required_probability), float(confidence)
    n, k = int(summary["n"]), int(summary["n_success"])
    low = stats.one_sided_lower(k, n, conf) if n else 0.0
    need = stats.samples_needed(p, conf)
    dominant = str(summary.get("dominant_failure_mode") or "none")
    bp = float(summary.get("bound_position_m", math.nan))
    bt = float(summary.get("bound_theta_rad", math.nan))
    within = (bool(bp <= pos_eps_m and bt <= theta_eps_rad)
              if math.isfinite(bp) and math.isfinite(bt) else None)
    common = dict(n_samples=n, n_success=k, success_rate=k / n if n else math.nan,
                  ci_low_one_sided=low, samples_needed=need, required_probability=p,
                  confidence=conf, nothing_perturbed=not perturbed, perturbed=tuple(perturbed),
                  dominant_failure_mode=dominant, model=model, bound_position_m=bp,
                  bound_theta_rad=bt, bound_within_eps=within,
                  bound_violated=summary.get("bound_violated"))
    what = f"{n} samples of the {model} model"
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
                           claim=(f"P(success) >= {low:.4f} >= {p:g} at {conf:.0%} confidence "
                                  f"(one-sided Clopper-Pearson over {what}; {varied})"),
                           note="; ".join(notes), **common)
    if n and k == n:
        return Certificate(verdict="not certified", reason="too_few_samples",
                           claim=(f"{k}/{n} succeeded, but at least {need} successes without a "
                                  f"failure are needed for p >= {p:g} at {conf:.0%} confidence "
                                  f"(one-sided Clopper-Pearson lower bound {low:.4f}; {varied})"),
                           note="; ".join(notes), **common)
    upper = stats.one_sided_upper(k, n, conf) if n else 1.0
    reason = "below_requirement" if upper < p else "failures"
    tail = (f"; even the upper bound {upper:.4f} is below {p:g}: more samples cannot certify"
            if reason == "below_requirement" else "")
    return Certificate(verdict="not certified", reason=reason,
                       claim=(f"{k}/{n} succeeded ({what}; {varied}): one-sided Clopper-Pearson "
                              f"lower bound {low:.4f} < {p:g} at {conf:.0%} confidence; dominant "
                              f"failure: {dominant}{tail}"),
                       note="; ".join(notes), **common)


def no_plan(reason: str, required_probability: float, confidence: float, model: str) -> Certificate:
    """The certificate of a task the planner could not serve (nothing sampled)."""
    return Certificate(verdict="no plan", reason="no_plan", claim=f"no plan: {reason}",
                       n_samples=0, n_success=0, success_rate=math.nan, ci_low_one_sided=math.nan,
                       samples_needed=stats.samples_needed(required_probability, confidence),
                       required_probability=required_probability, confidence=confidence,
                       nothing_perturbed=False, perturbed=(), dominant_failure_mode="no_plan",
                       model=model, note=f"planner: {reason}")


def decided(n: int, k: int, required_probability: float, confidence: float) -> bool:
    """Whether more samples could still change the verdict: False while the
    requirement lies between the one-sided lower and upper bounds."""
    if n == 0:
        return False
    return (stats.one_sided_lower(k, n, confidence) >= required_probability
            or stats.one_sided_upper(k, n, confidence) < required_probability)


def auto_sample_counts(required_probability: float, confidence: float, cap: int,
                       first: Optional[int] = None) -> list[int]:
    """The sample counts ``--n-samples auto`` tries in turn: the fewest that
    could certify (all successful), then doubling up to ``cap``."""
    n = max(1, first or stats.samples_needed(required_probability, confidence))
    out = []
    while n < cap:
        out.append(n)
        n *= 2
    out.append(int(cap))
    return out


def grow(evaluate_more: Callable[[int], tuple[int, int]], counts: list[int],
         required_probability: float, confidence: float) -> tuple[int, int]:
    """Draw samples until the verdict is decided or the last count is reached.

    Args:
      evaluate_more: ``f(n_total) -> (n, k)``: extends the evaluation to
        ``n_total`` samples (reusing those drawn before) and returns the totals.
      counts: increasing targets (:func:`auto_sample_counts`).

    Returns:
      ``(n, k)`` at the end.
    """
    n = k = 0
    for target in counts:
        n, k = evaluate_more(int(target))
        if decided(n, k, required_probability, confidence):
            break
    return n, k


def first_certifying(candidates, evaluate_one: Callable) -> Optional[object]:
    """The first candidate (in order) whose evaluation certifies:
    ``evaluate_one(candidate) -> bool``; None if none does."""
    for c in candidates:
        if evaluate_one(c):
            return c
    return None


def certify(plan, sampler, key, *, required_probability: float = 0.9, confidence: float = 0.95,
            n_samples="auto", max_samples: int = 100_000, model: str = "quasistatic",
            dtype=None, pos_eps_m: Optional[float] = None, theta_eps_rad: Optional[float] = None,
            physics=None, task: str = "task", bound: bool = True):
    """Certify one plan: sample, replay, decide (see the module docstring).

    Args:
      plan: a :class:`~planning.PushPlan` or :class:`~planning.TumblePlan`.
      sampler: the :class:`~robustness.Sampler` of the tolerances.
      key: a ``jax.random`` key; block ``b`` of samples uses ``fold_in(key, b)``, so
        growing the sample count keeps the samples drawn before.
      required_probability, confidence: the requirement (both in (0, 1)).
      n_samples: an integer, or ``"auto"``: grow from the fewest samples that
        could certify, doubling, until the verdict is decided or ``max_samples``.
      model, dtype, pos_eps_m, theta_eps_rad, physics, task, bound: as in
        :func:`robustness.evaluate`.

    Returns:
      ``(certificate, samples, summary)``: the :class:`Certificate`, the
      per-sample frame of every block, and the summary row (dict).
    """
    import jax
    import jax.numpy as jnp
    import pandas as pd

    from robustness.evaluation import evaluate
    from robustness.models import model_for
    from robustness.summary import summarise

    kind = "push" if hasattr(plan, "pushes") else "tumble"
    model = model_for(model, kind)
    dtype = jnp.float64 if dtype is None else dtype
    if kind == "tumble":
        pe = float(plan.eps) if pos_eps_m is None else pos_eps_m
        te = float(plan.eps) if theta_eps_rad is None else theta_eps_rad
    else:
        pe = 1e-3 if pos_eps_m is None else pos_eps_m
        te = math.radians(1.0) if theta_eps_rad is None else theta_eps_rad
    if n_samples == "auto":
        counts = auto_sample_counts(required_probability, confidence, int(max_samples))
    elif isinstance(n_samples, int) and not isinstance(n_samples, bool) and n_samples >= 1:
        counts = [n_samples]
    else:
        raise ValueError(f"n_samples: expected an integer >= 1 or 'auto', got {n_samples!r}")
    block = counts[0]
    frames: list = []

    def more(total: int):
        drawn = sum(len(f) for f in frames)
        b = len(frames)
        while drawn < total:
            m = min(block, total - drawn)
            ev = evaluate(plan, sampler, m, jax.random.fold_in(key, b), model=model, dtype=dtype,
                          pos_eps_m=pe, theta_eps_rad=te, confidence=confidence, physics=physics,
                          task=task, bound=False)
            df = ev.samples.copy()
            df["sample_id"] += drawn
            frames.append(df)
            drawn += m
            b += 1
        df = pd.concat(frames, ignore_index=True)
        return len(df), int(df["success"].sum())

    grow(more, counts, required_probability, confidence)
    samples = pd.concat(frames, ignore_index=True)
    summary = summarise(samples, plan, sampler, kind=kind, model=model,
                        dtype=jnp.dtype(dtype).name, pos_eps_m=pe, theta_eps_rad=te,
                        confidence=confidence, task=task, bound=bound)
    cert = decide(summary, required_probability, confidence, kind=kind, model=model,
                  perturbed=perturbed_sources(sampler, kind, model), pos_eps_m=pe,
                  theta_eps_rad=te)
    return cert, samples, summary


__all__ = ["Certificate", "certify", "decide", "no_plan", "perturbed_sources", "decided",
           "auto_sample_counts", "grow", "VERDICTS", "REASONS", "BOUND_MODEL"]
