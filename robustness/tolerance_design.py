"""Tolerance design: for a plan, the loosest tolerance on each axis that still
certifies, what drives the failures, and a joint design to put on a drawing.

Axes (push plans; tumble plans have the first three and the tumble slip):

=================  ==========================================  ============
axis               what is loosened                            looser is
=================  ==========================================  ============
``tau_v``          ``tolerances.tau_v`` (each vertex, m)       larger
``tau_com``        ``tolerances.tau_com`` (m)                  larger
``start``          ``execution.start_xy`` (m), ``start_theta``  larger
                   (rad), in proportion
``fence_angle``    ``execution.fence_angle`` (rad)             larger
``push_distance``  ``execution.distance_abs`` (m),             larger
                   ``distance_rel``, in proportion
``fence_friction`` the low end of ``friction.mu_f``            lower
``tumble_slip``    ``execution.tumble_slip_xy`` (m),           larger
                   ``tumble_slip_theta`` (rad)
=================  ==========================================  ============

**One axis at a time** (:func:`loosest`): the other axes at their configured
values, the axis is scaled (an axis configured at zero from a reference scale
of the part's size) and bracketed, then bisected geometrically to ``rel_tol``
on the verdict "the one-sided Clopper-Pearson lower bound of success at
``confidence`` reaches ``p``", every evaluation on the SAME draws (the
sampler's uniforms do not depend on the tolerance values: common random
numbers), so the success count moves only with the tolerance and the
bisection sees a monotone step (tested against a brute-force grid).

**What drives the failures** (:func:`sensitivity`): per axis, on the same
draws, the failure rate with that axis perfect (:data:`PERFECT`, 1e-12; fence friction known, at the middle of its
range) and the
others as configured (``failure_rate_without``), and with only that axis
perturbed (``failure_rate_alone``); and with every axis perfect (what fails
then fails for what no axis covers: the support).  ``failures_removed`` = failure rate - failure rate
without: the share of all samples that stop failing if that axis is made
perfect; axes are ranked by it.  A knock-out analysis, not a variance
decomposition: it answers the engineer's question ("which tolerance do I
tighten?") directly and interactions show as removed shares that sum to more
or less than the total.

**The joint design** (:func:`joint_design`): the one-axis limits hold one at a
time; together they fail.  All axes are moved together the same fraction ``t``
of the way from the configured tolerances (when they certify; else from
perfect) to their one-axis limits, the largest ``t`` that certifies with
headroom (at a tenth of the stated error rate) found by bisection, and that
design is then verified once, at the stated confidence, on FRESH draws (the design was
chosen on the design draws, so its bound there is optimistic); the drawing
line states the fresh verdict.

Units: metres, radians, friction coefficients; a relative distance error is a
fraction.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Callable, Optional, Sequence

import jax
import numpy as np

from robustness import stats
from robustness.blocks import sample_block
from robustness.kinds import kind_of
from robustness.models import DEFAULT_MODEL, Model
from robustness.samplers import Sampler
from robustness.tolerances import Requirement

#: push-plan axes, tumble-plan axes
PUSH_AXES = ("tau_v", "tau_com", "start", "fence_angle", "push_distance", "fence_friction")
TUMBLE_AXES = ("tau_v", "start", "tumble_slip")
#: the design axes by plan kind (every kind of the dispatch table: tests/test_plan_kinds.py)
AXES = {"push": PUSH_AXES, "tumble": TUMBLE_AXES,
        "sensorless": ()}   # none: a design needs a known start (configs refuse it)
#: ``axis: ((section, field, reference scale as a fraction of the part's size or an absolute
#: value, is_length), ...)``
_FIELDS = {
    "tau_v": (("geometry", "tau_v", 1e-3, True),),
    "tau_com": (("geometry", "tau_com", 5e-3, True),),
    "start": (("execution", "start_xy", 5e-3, True), ("execution", "start_theta", 0.01, False)),
    "fence_angle": (("execution", "fence_angle", 0.002, False),),
    "push_distance": (("execution", "distance_abs", 1e-3, True),
                      ("execution", "distance_rel", 0.005, False)),
    "tumble_slip": (("execution", "tumble_slip_xy", 1e-4, True),
                    ("execution", "tumble_slip_theta", 1e-3, False)),
}
_SECTION = {"geometry": "tolerances", "execution": "execution", "friction": "friction"}
SCALE_MAX, SCALE_MIN = 1e4, 1e-4


@dataclasses.dataclass(frozen=True)
class AxisDesign:
    """The loosest value of one axis that certifies (the others as configured).

    Attributes:
      axis: the axis name; fields: the config fields it moves (dotted).
      configured: the configured values (SI units, one per field).
      loosest: the loosest values that certify (for ``fence_friction`` the
        lowest low end of ``mu_f``); the configured ones scaled by ``scale``.
      scale: ``loosest / configured`` (from the reference scale for an axis
        configured at zero; NaN for friction).
      certified_at_configured: the configured value certifies.
      ci_low: the lower bound at ``loosest`` (on the design draws).
      limit: ``""``, or why the search stopped: ``"no_limit"`` (certifies up
        to the largest value tried), ``"none_certifies"`` (not even the
        smallest value tried: the other axes fail alone).
      evaluations: how many evaluations the search took.
    """

    axis: str
    fields: tuple
    configured: tuple
    loosest: tuple
    scale: float
    certified_at_configured: bool
    ci_low: float
    limit: str
    evaluations: int


@dataclasses.dataclass(frozen=True)
class Sensitivity:
    """Failure rates on the same draws: all axes as configured, this axis
    perfect, only this axis perturbed; ``failures_removed`` = ``failure_rate -
    failure_rate_without``."""

    axis: str
    failure_rate: float
    failure_rate_without: float
    failure_rate_alone: float

    @property
    def failures_removed(self) -> float:
        return self.failure_rate - self.failure_rate_without


@dataclasses.dataclass(frozen=True)
class JointDesign:
    """All axes ``t`` of the way to their one-axis limits, verified on fresh draws.

    Attributes:
      t: the fraction of the way (1: every one-axis limit at once); basis:
        where the way starts, ``"configured"`` (the configured tolerances,
        which certify) or ``"perfect"`` (they do not).
      values: ``{axis: values}`` of the design (SI).
      ci_low_design: the bound on the design draws (optimistic).
      n_fresh, k_fresh, ci_low_fresh: the verification on fresh draws.
      certified: ``ci_low_fresh >= p``.
      none_certifies: no design on the way certifies, not even every axis at
        a ten-thousandth of its limit: the failures come from what no
        tolerance covers (the support, the fence friction's range, the plan);
        then ``t`` is 0, ``values`` NaN, nothing is verified (``n_fresh`` 0,
        ``ci_low_fresh`` NaN) and nothing certified.
      failure_rate_perfect: the failure rate on the design draws with every
        axis perfect (:func:`all_perfect`).
    """

    t: float
    values: dict
    ci_low_design: float
    n_fresh: int
    k_fresh: int
    ci_low_fresh: float
    certified: bool
    basis: str = "configured"
    none_certifies: bool = False
    failure_rate_perfect: float = math.nan


def axes_for(plan) -> tuple:
    """The design axes of a plan's kind."""
    return AXES[kind_of(plan).kind]


def _size(plan) -> float:
    v = np.asarray(plan.vertices, np.float64)
    return float(np.max(np.linalg.norm(v[:, None] - v[None], axis=-1)))


def configured(sampler: Sampler, axis: str) -> tuple:
    """The configured values of an axis (SI)."""
    if axis == "fence_friction":
        return (float(sampler.friction.mu_f[0]),)
    return tuple(float(getattr(getattr(sampler, sec), f)) for sec, f, _, _ in _FIELDS[axis])


def fields(axis: str) -> tuple:
    """The config fields an axis moves (dotted, as in a certify config)."""
    if axis == "fence_friction":
        return ("friction.mu_f[0]",)
    return tuple(f"{_SECTION[sec]}.{f}" for sec, f, _, _ in _FIELDS[axis])


def unit_values(sampler: Sampler, axis: str, size: float) -> tuple:
    """The values scale 1 stands for: the configured ones, or (all configured
    zero) the reference scale (a fraction of the part's ``size`` for lengths)."""
    c = configured(sampler, axis)
    if any(x > 0 for x in c):
        return c
    return tuple(ref * size if is_len else ref for _, _, ref, is_len in _FIELDS[axis])


def with_values(sampler: Sampler, axis: str, values: Sequence[float]) -> Sampler:
    """``sampler`` with ``axis`` set to ``values`` (SI)."""
    if axis == "fence_friction":
        lo = float(values[0])
        hi = max(lo, float(sampler.friction.mu_f[1]))
        return dataclasses.replace(sampler, friction=dataclasses.replace(sampler.friction,
                                                                         mu_f=(lo, hi)))
    out = sampler
    for (sec, f, _, _), v in zip(_FIELDS[axis], values):
        part = getattr(out, sec)
        upd = {f: float(v)}
        if sec == "geometry" and f == "tau_v" and part.sigma_v is not None and part.tau_v > 0:
            upd["sigma_v"] = part.sigma_v * float(v) / part.tau_v   # keep sigma / tau
        out = dataclasses.replace(out, **{sec: dataclasses.replace(part, **upd)})
    return out


#: "perfect" is this (m, rad, fraction, friction) rather than zero: a tolerance that is
#: zero changes the sampler's compiled structure, a tiny one keeps every evaluation of a
#: design on one compiled sampler (and the same uniforms)
PERFECT = 1e-12


def perfect(sampler: Sampler, axis: str) -> Sampler:
    """``sampler`` with ``axis`` made perfect (:data:`PERFECT`; fence friction:
    known, the middle of its range: more friction is not always better for a
    plan).  An axis configured at zero stays zero."""
    if axis == "fence_friction":
        lo, hi = (float(x) for x in sampler.friction.mu_f)
        if hi == lo:
            return sampler
        mid = 0.5 * (lo + hi)
        return dataclasses.replace(sampler, friction=dataclasses.replace(
            sampler.friction, mu_f=(mid, mid + PERFECT)))
    return with_values(sampler, axis, tuple(min(c, PERFECT) for c in configured(sampler, axis)))


class Judge:
    """Counts successes of a plan on the same draws for any sampler (common
    random numbers: one ``key``, one ``n``) and says whether they certify the
    :class:`~robustness.Requirement` (each sample judged by its criterion;
    None: the plan kind's), under ``model`` (a :class:`~robustness.Model` or a
    name)."""

    def __init__(self, plan, n: int, key, requirement: Requirement, model=DEFAULT_MODEL):
        if not isinstance(requirement, Requirement):
            raise ValueError(f"requirement: expected a robustness.Requirement, got {requirement!r}")
        self.plan, self.n, self.key = plan, int(n), key
        self.requirement = requirement
        self.kw = dict(criterion=requirement.criterion, model=Model.of(model))
        self.calls = 0

    @property
    def p(self) -> float:
        """The required success probability (the requirement's)."""
        return self.requirement.probability

    @property
    def confidence(self) -> float:
        """The confidence of the claim (the requirement's)."""
        return self.requirement.confidence

    def successes(self, sampler: Sampler, key=None) -> int:
        """Successes on the ``n`` draws of ``key`` (default the judge's) of
        ``sampler``: one block of the runner (:func:`robustness.sample_block`)."""
        self.calls += 1
        return sample_block(self.plan, sampler, self.n, self.key if key is None else key,
                            **self.kw).n_success

    def low(self, k: int) -> float:
        return stats.one_sided_lower(k, self.n, self.confidence)

    def certifies(self, sampler: Sampler) -> tuple[bool, float]:
        low = self.low(self.successes(sampler))
        return low >= self.p, low


def _boundary(ok: Callable[[float], tuple], good: float, bad: float, good_val, tol: float,
              geometric: bool = True, max_iter: int = 60):
    """Bisect between ``good`` (``ok`` true) and ``bad`` (false), either side of it:
    the last good point and its value once they are within ``tol`` (relative
    when ``geometric``, else absolute)."""
    best = (good, good_val)
    for _ in range(max_iter):
        gap = (max(good, bad) / min(good, bad) - 1.0) if geometric else abs(good - bad)
        if gap <= tol:
            break
        mid = math.sqrt(good * bad) if geometric else 0.5 * (good + bad)
        g, val = ok(mid)
        if g:
            good, best = mid, (mid, val)
        else:
            bad = mid
    return best


def _walk(ok: Callable[[float], tuple], s: float, verdict: bool, val, factor: float,
          stop: float):
    """From ``s`` (``ok(s)`` gave ``verdict``, ``val``) multiply by ``factor`` until
    the verdict changes or ``stop`` is passed: ``(last s with the verdict, its
    value, (first s with the other verdict, its value) or None)``."""
    while True:
        t = s * factor
        if (t > stop) if factor > 1 else (t < stop):
            return s, val, None
        g, v = ok(t)
        if g != verdict:
            return s, val, (t, v)
        s, val = t, v


def loosest(judge: Judge, sampler: Sampler, axis: str, *, rel_tol: float = 0.05) -> AxisDesign:
    """The loosest value of ``axis`` that certifies, the others as in ``sampler``."""
    calls0 = judge.calls
    conf = configured(sampler, axis)
    if axis == "fence_friction":
        lo0, hi = conf[0], float(sampler.friction.mu_f[1])
        ok = lambda x: judge.certifies(with_values(sampler, axis, (x,)))  # noqa: E731
        good0, low0 = ok(lo0)
        limit = ""
        if good0:   # lower the low end while it certifies
            good_z, low_z = ok(0.0)
            if good_z:
                x, low = 0.0, low_z
                limit = "no_limit"
            else:   # ok(x) false at 0, true at lo0: the smallest true, by bisection on -x
                x, low = _boundary(ok, lo0, 0.0, low0, 0.005, geometric=False)
        else:
            good_h, low_h = ok(hi)
            if not good_h:
                x, low, limit = hi, low_h, "none_certifies"
            else:
                x, low = _boundary(ok, hi, lo0, low_h, 0.005, geometric=False)
        return AxisDesign(axis, fields(axis), conf, (x,), math.nan, good0, low, limit,
                          judge.calls - calls0)
    unit = unit_values(sampler, axis, _size(judge.plan))
    scaled = lambda s: with_values(sampler, axis, tuple(s * u for u in unit))  # noqa: E731
    ok = lambda s: judge.certifies(scaled(s))  # noqa: E731
    nonzero = any(x > 0 for x in conf)
    good, low = ok(1.0)
    at_configured = good if nonzero else judge.certifies(sampler)[0]
    limit = ""
    if good:   # loosen by 4x while it certifies, then bisect
        lo, lo_val, bad = _walk(ok, 1.0, True, low, 4.0, SCALE_MAX)
        if bad is None:
            limit, scale, low = "no_limit", lo, lo_val
        else:
            scale, low = _boundary(ok, lo, bad[0], lo_val, rel_tol)
    else:      # tighten by 4x until it certifies, then bisect
        hi, _, good_at = _walk(ok, 1.0, False, low, 0.25, SCALE_MIN)
        if good_at is None:
            limit, scale = "none_certifies", 0.0
        else:
            scale, low = _boundary(ok, good_at[0], hi, good_at[1], rel_tol)
    return AxisDesign(axis, fields(axis), conf, tuple(scale * u for u in unit),
                      scale if nonzero else math.nan, bool(at_configured), low, limit,
                      judge.calls - calls0)


def all_perfect(sampler: Sampler, axes: Sequence[str]) -> Sampler:
    """``sampler`` with every axis of ``axes`` perfect (what is left varies
    outside the axes: the support, the support friction)."""
    for a in axes:
        sampler = perfect(sampler, a)
    return sampler


def sensitivity(judge: Judge, sampler: Sampler, axes: Sequence[str]) -> list[Sensitivity]:
    """Failure rates with each axis perfect and with it alone (same draws)."""
    n = judge.n
    f_all = 1.0 - judge.successes(sampler) / n
    none = all_perfect(sampler, axes)
    out = []
    for a in axes:
        without = 1.0 - judge.successes(perfect(sampler, a)) / n
        alone_s = with_values(none, a, configured(sampler, a))
        alone = 1.0 - judge.successes(alone_s) / n
        out.append(Sensitivity(a, f_all, without, alone))
    return out


def _joint_sampler(sampler: Sampler, designs: Sequence[AxisDesign], t: float,
                   basis: str) -> Sampler:
    """Every axis at ``t`` of the way: from its configured value to its one-axis
    limit (``basis="configured"``), or from perfect (``"perfect"``: zero;
    friction the range's high end) to it."""
    out = sampler
    for d in designs:
        start = d.configured if basis == "configured" else (
            (float(sampler.friction.mu_f[1]),) if d.axis == "fence_friction"
            else (0.0,) * len(d.loosest))
        out = with_values(out, d.axis, tuple(a + t * (b - a) for a, b in zip(start, d.loosest)))
    return out


#: the joint design is searched at this share of the stated error rate (``1 - confidence``):
#: headroom, so that the one verification on fresh draws passes when the design holds
HEADROOM = 0.1


def design_samples_needed(p: float, confidence: float) -> int:
    """The fewest design draws that can show ``P(success) >= p`` at the joint
    design's stricter confidence (:data:`HEADROOM`), even with no failure:
    fewer can never certify a design, whatever the tolerances."""
    return stats.samples_needed(p, 1.0 - HEADROOM * (1.0 - confidence))


def joint_design(judge: Judge, sampler: Sampler, designs: Sequence[AxisDesign], fresh_key,
                 n_fresh: Optional[int] = None, *, rel_tol: float = 0.02) -> JointDesign:
    """The joint design: every axis ``t`` of the way to its one-axis limit, the
    largest ``t`` whose bound on the design draws reaches ``p`` at the stricter
    confidence ``1 - HEADROOM (1 - confidence)`` (a design at the edge of the
    design draws would fail its fresh verification half of the time), then
    verified, once, at ``confidence`` on ``n_fresh`` draws of ``fresh_key``
    (default ``judge.n``): the verification is the claim.

    The way starts at the configured tolerances when they certify (no axis is
    then tighter than configured: ``basis = "configured"``), else at perfect
    (``"perfect"``: all axes the same fraction of their limits).  When no
    fraction certifies (down to 1e-4 of the way from perfect), the design is
    ``none_certifies``: nothing is verified or claimed."""
    strict = 1.0 - HEADROOM * (1.0 - judge.confidence)
    perfect_rate = 1.0 - judge.successes(all_perfect(sampler, [d.axis for d in designs])) / judge.n

    def ok(t, basis):
        low = stats.one_sided_lower(
            judge.successes(_joint_sampler(sampler, designs, t, basis)), judge.n, strict)
        return low >= judge.p, low

    basis = "configured" if ok(0.0, "configured")[0] else "perfect"
    good1, low1 = ok(1.0, basis)
    at = lambda x: ok(x, basis)  # noqa: E731
    if good1:
        t, low = 1.0, low1
    elif basis == "configured":   # t = 0 certifies: bisect [0, 1]
        t, low = _boundary(at, 0.0, 1.0, ok(0.0, basis)[1], rel_tol, geometric=False)
    else:                         # halve t until it certifies, then bisect
        _, _, good_at = _walk(at, 1.0, False, low1, 0.5, 1e-4)
        if good_at is None:   # not even every axis nearly perfect: no tolerance certifies it
            values = {d.axis: (math.nan,) * len(d.loosest) for d in designs}
            return JointDesign(0.0, values, low1, 0, 0, math.nan, False, basis,
                               none_certifies=True, failure_rate_perfect=perfect_rate)
        else:
            t, low = _boundary(at, good_at[0], min(1.0, 2.0 * good_at[0]), good_at[1], rel_tol)
    s = _joint_sampler(sampler, designs, t, basis)
    n = int(n_fresh or judge.n)
    fresh = Judge(judge.plan, n, fresh_key, judge.requirement, judge.kw["model"])
    k = fresh.successes(s)
    lowf = stats.one_sided_lower(k, n, judge.confidence)
    values = {d.axis: (configured(s, d.axis)) for d in designs}
    return JointDesign(t, values, low, n, k, lowf, lowf >= judge.p, basis,
                       failure_rate_perfect=perfect_rate)


def design_key(key):
    """The design draws' key of a task certified with ``key`` (an independent
    stream, like :func:`robustness.synthesis.selection_key`); the joint design's
    fresh draws use ``fold_in`` of it once more."""
    return jax.random.fold_in(key, 0xD5E16)


#: each axis's values in a drawing's words (mm, degrees, percent)
_WORDS = {
    "fence_friction": lambda v: f"fence friction >= {v[0]:.3g}",
    "tau_v": lambda v: f"vertices within +-{v[0] * 1e3:.3g} mm",
    "tau_com": lambda v: f"centre of mass within {v[0] * 1e3:.3g} mm",
    "start": lambda v: f"start within +-{v[0] * 1e3:.3g} mm / +-{math.degrees(v[1]):.3g} deg",
    "fence_angle": lambda v: f"fence angle within +-{math.degrees(v[0]):.3g} deg",
    "push_distance": lambda v: f"push distance within +-{v[0] * 1e3:.3g} mm +-{v[1] * 100:.3g} %",
    "tumble_slip": lambda v: (f"slip per tumble within +-{v[0] * 1e3:.3g} mm / "
                              f"+-{math.degrees(v[1]):.3g} deg"),
}


def drawing_line(designs: Sequence[AxisDesign], joint: JointDesign, p: float,
                 confidence: float, model: str) -> str:
    """The joint design in words an engineer can copy onto a drawing, with what
    was shown (model, confidence, fresh samples); when no tolerance certifies
    the plan (:attr:`JointDesign.none_certifies`), that, and the failure rate
    that is left with every tolerance perfect - never a design of zeros."""
    if joint.none_certifies:
        rate, allowed = joint.failure_rate_perfect, 1.0 - p
        if rate < allowed:   # few failures, too few draws to show it
            return (f"no design certifies on these design draws: with every tolerance perfect, "
                    f"{rate:.1%} of them fail ({model} model), within the {allowed:.0%} that "
                    f"P(success) >= {p:g} allows but too close to show it at the design's "
                    f"confidence")
        return (f"no tolerance certifies this plan: with every tolerance perfect, "
                f"{rate:.0%} of the design draws still fail ({model} model), more than the "
                f"{allowed:.0%} that P(success) >= {p:g} allows; they fail from what no "
                f"tolerance covers: the support, the fence friction's range, the plan itself")
    parts = [_WORDS[d.axis](joint.values[d.axis]) for d in designs]
    head = ", ".join(parts)
    pct = f"{confidence * 100:.4g}%"
    if joint.certified:
        return (f"{head}: certified P(success) >= {joint.ci_low_fresh:.4f} >= {p:g} at {pct} "
                f"confidence ({joint.k_fresh}/{joint.n_fresh} fresh samples of the {model} model)")
    return (f"{head}: NOT certified on fresh draws ({joint.k_fresh}/{joint.n_fresh} fresh samples of "
            f"the {model} model, lower bound {joint.ci_low_fresh:.4f} < {p:g} at {pct}); tighten "
            "the axes that remove most failures")


__all__ = ["AxisDesign", "Sensitivity", "JointDesign", "Judge", "PUSH_AXES", "TUMBLE_AXES",
           "axes_for", "configured", "fields", "loosest", "sensitivity", "joint_design",
           "design_key", "drawing_line", "design_samples_needed", "with_values", "perfect", "all_perfect", "unit_values"]
