"""What a certificate may say: one test per verdict and per reason of
robustness.certificates.decide, and the sample-growing rule of --n-samples auto."""
import math

import pytest

from robustness import ExecutionTolerance, FrictionRange, GeometryTolerance, Sampler
from robustness.certificates import (BOUND_MODEL, auto_sample_counts, decide, decided, grow,
                                     no_plan, perturbed_sources)

SOURCES = ("part vertices", "fence friction")


def _summary(n, k, mode="none", bound=(math.nan, math.nan), violated=None):
    return {"n": n, "n_success": k, "dominant_failure_mode": mode, "bound_position_m": bound[0],
            "bound_theta_rad": bound[1], "bound_violated": violated}


def _decide(n, k, p=0.95, conf=0.95, perturbed=SOURCES, **kw):
    return decide(_summary(n, k, **kw), p, conf, kind="push", model="quasistatic",
                  perturbed=perturbed, pos_eps_m=0.002, theta_eps_rad=0.03)


def test_certified_states_the_one_sided_bound_model_and_samples():
    c = _decide(300, 300)
    assert c.verdict == "certified" and c.reason == ""
    assert c.ci_low_one_sided >= 0.95 and c.samples_needed == 59
    assert "P(success) >=" in c.claim and "95% confidence" in c.claim
    assert "one-sided Clopper-Pearson over 300 samples of the quasistatic model" in c.claim
    assert "perturbed: part vertices, fence friction" in c.claim


def test_certified_with_a_few_failures():
    c = _decide(1000, 990, p=0.95, mode="slip")
    assert c.verdict == "certified" and c.dominant_failure_mode == "slip"


def test_too_few_samples_says_how_many_are_needed():
    c = _decide(50, 50)
    assert c.verdict == "not certified" and c.reason == "too_few_samples"
    assert "50/50 succeeded, but at least 59 successes without a failure are needed for " \
           "p >= 0.95 at 95% confidence" in c.claim


def test_failures_name_the_dominant_mode():
    c = _decide(100, 93, mode="slip")
    assert c.verdict == "not certified" and c.reason == "failures"
    assert "dominant failure: slip" in c.claim and "93/100" in c.claim


def test_below_requirement_when_more_samples_cannot_help():
    c = _decide(100, 50, mode="incomplete_reorientation")
    assert c.reason == "below_requirement" and "more samples cannot certify" in c.claim


def test_nothing_perturbed_claims_nothing():
    c = _decide(400, 400, perturbed=())
    assert c.verdict == "not certified" and c.reason == "nothing_perturbed"
    assert c.nothing_perturbed and "no probability can be claimed" in c.claim


def test_no_plan():
    c = no_plan("no feasible pose plan", 0.9, 0.95, "exact")
    assert c.verdict == "no plan" and c.reason == "no_plan" and c.n_samples == 0
    row = c.to_row()
    assert row["dominant_failure_mode"] == "no_plan" and "perturbed" not in row


def test_an_analytic_bound_never_certifies_and_is_reported_with_its_model():
    # a bound well within eps, but too few samples: still not certified
    c = _decide(10, 10, bound=(1e-5, 1e-4))
    assert c.verdict == "not certified" and c.bound_within_eps is True
    assert c.bound_model == BOUND_MODEL and "not a guarantee" in c.bound_model
    c = _decide(300, 300, bound=(1.0, 1.0), violated=True)
    assert c.verdict == "certified" and c.bound_within_eps is False
    assert "exceeded the first-order bound" in c.note


def test_perturbed_sources_follow_the_model():
    s = Sampler(GeometryTolerance(tau_v=1e-5), FrictionRange(mu_f=(0.3, 0.8)),
                ExecutionTolerance(fence_angle=1e-3))
    assert perturbed_sources(s, "push", "quasistatic") == (
        "part vertices", "fence angle", "fence friction", "support pressure")
    # the exact replay does not depend on friction
    assert perturbed_sources(s, "push", "exact") == ("part vertices", "fence angle")
    nothing = Sampler(friction=FrictionRange(mu_f=(0.5, 0.5), c=(0.01, 0.01)))
    assert perturbed_sources(nothing, "push", "quasistatic") == ()
    assert perturbed_sources(Sampler(execution=ExecutionTolerance(tumble_slip_xy=1e-5)),
                             "tumble", "exact") == ("slip after tumbles",)


def test_auto_counts_start_at_the_fewest_that_could_certify_and_double():
    assert auto_sample_counts(0.95, 0.95, 1000) == [59, 118, 236, 472, 944, 1000]
    assert auto_sample_counts(0.9, 0.95, 29) == [29]


@pytest.mark.parametrize("true_rate,expect", [(1.0, "certified"), (0.5, "not certified")])
def test_grow_stops_when_decided(true_rate, expect):
    calls = []

    def more(total):
        calls.append(total)
        return total, int(round(true_rate * total))

    n, k = grow(more, auto_sample_counts(0.9, 0.95, 10_000), 0.9, 0.95)
    assert decided(n, k, 0.9, 0.95)
    assert calls == [29]          # both decided at the first count
    assert (_decide(n, k, p=0.9).verdict == "certified") == (expect == "certified")


def test_grow_goes_on_while_undecided_and_stops_at_the_cap():
    calls = []

    def more(total):
        calls.append(total)
        return total, total - max(1, total // 12)   # about 92%: close to p = 0.9

    n, _ = grow(more, auto_sample_counts(0.9, 0.95, 500), 0.9, 0.95)
    assert calls[0] == 29 and len(calls) > 1 and n <= 500
