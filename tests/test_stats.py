"""robustness.stats decides every certificate: checked against scipy's exact
binomial intervals (an independent implementation) over a grid of n, k and
confidence, one- and two-sided."""
import math

import numpy as np
import pytest
from scipy.stats import binom, binomtest

from robustness import stats

GRID = [(n, k) for n in (1, 2, 5, 10, 29, 59, 100, 400, 1000) for k in sorted({0, 1, n // 3, n // 2, n - 1, n})
        if 0 <= k <= n]
CONFIDENCES = (0.8, 0.9, 0.95, 0.99)


@pytest.mark.parametrize("conf", CONFIDENCES)
@pytest.mark.parametrize("n,k", GRID)
def test_two_sided_matches_scipy(n, k, conf):
    ref = binomtest(k, n).proportion_ci(confidence_level=conf, method="exact")
    lo, hi = stats.clopper_pearson(k, n, conf)
    assert lo == pytest.approx(ref.low, abs=1e-12, rel=1e-9)
    assert hi == pytest.approx(ref.high, abs=1e-12, rel=1e-9)


@pytest.mark.parametrize("conf", CONFIDENCES)
@pytest.mark.parametrize("n,k", GRID)
def test_one_sided_matches_scipy(n, k, conf):
    low = binomtest(k, n, alternative="greater").proportion_ci(confidence_level=conf, method="exact").low
    high = binomtest(k, n, alternative="less").proportion_ci(confidence_level=conf, method="exact").high
    assert stats.one_sided_lower(k, n, conf) == pytest.approx(low, abs=1e-12, rel=1e-9)
    assert stats.one_sided_upper(k, n, conf) == pytest.approx(high, abs=1e-12, rel=1e-9)
    # a one-sided bound is tighter than the same side of the two-sided interval
    lo2, hi2 = stats.clopper_pearson(k, n, conf)
    assert stats.one_sided_lower(k, n, conf) >= lo2 - 1e-15
    assert stats.one_sided_upper(k, n, conf) <= hi2 + 1e-15


@pytest.mark.parametrize("p", (0.5, 0.8, 0.9, 0.95, 0.99, 0.999))
@pytest.mark.parametrize("conf", CONFIDENCES)
def test_samples_needed_is_the_fewest_that_certify(p, conf):
    n = stats.samples_needed(p, conf)
    assert stats.one_sided_lower(n, n, conf) >= p
    assert n == 1 or stats.one_sided_lower(n - 1, n - 1, conf) < p


def test_known_values():
    assert stats.samples_needed(0.95, 0.95) == 59      # the classic 59 successes
    assert stats.samples_needed(0.9, 0.95) == 29
    assert stats.samples_needed(0.99, 0.95) == 299
    assert stats.one_sided_lower(59, 59, 0.95) == pytest.approx(0.05 ** (1 / 59))


def test_bad_arguments():
    with pytest.raises(ValueError, match="k"):
        stats.clopper_pearson(5, 4)
    with pytest.raises(ValueError, match="confidence"):
        stats.one_sided_lower(1, 2, 1.0)
    with pytest.raises(ValueError, match="n"):
        stats.one_sided_upper(0, -1)
    with pytest.raises(ValueError, match="p_required"):
        stats.samples_needed(1.0, 0.95)
    assert stats.clopper_pearson(0, 0) == (0.0, 1.0)


def test_quantiles_never_hide_a_diverged_sample():
    q = stats.quantiles([1.0, 2.0, float("nan")])
    assert math.isinf(q["max"])
    q = stats.quantiles(np.arange(101.0))
    assert q["q50"] == 50.0 and q["q90"] == 90.0 and q["q99"] == 99.0 and q["max"] == 100.0
    assert all(math.isnan(v) for v in stats.quantiles([]).values())


@pytest.mark.parametrize("conf", (0.9, 0.95, 0.995))
@pytest.mark.parametrize("p", (0.5, 0.9, 0.99))
def test_thresholds_are_the_decisions_of_the_bounds(p, conf):
    for n in (0, 1, 2, 7, 29, 120):
        c, f = stats.certify_threshold(n, p, conf), stats.below_threshold(n, p, conf)
        for k in range(n + 1):
            assert (stats.one_sided_lower(k, n, conf) >= p) == (k >= c), (n, k)
            assert (stats.one_sided_upper(k, n, conf) < p) == (k <= f), (n, k)
        assert -1 <= f < c <= n + 1


def test_sequential_rates_match_enumeration():
    # every one of the 2^10 success sequences of a three-look schedule, weighted exactly
    import itertools

    counts, p_req, conf, p_true = (3, 6, 10), 0.6, 0.8, 0.55
    cert = below = 0.0
    c = [stats.certify_threshold(n, p_req, conf) for n in counts]
    f = [stats.below_threshold(n, p_req, conf) for n in counts]
    for seq in itertools.product((0, 1), repeat=counts[-1]):
        w = p_true ** sum(seq) * (1 - p_true) ** (len(seq) - sum(seq))
        for n, ci, fi in zip(counts, c, f):
            k = sum(seq[:n])
            if k >= ci:
                cert += w
                break
            if k <= fi:
                below += w
                break
    got = stats.sequential_rates(counts, p_req, conf, p_true)
    assert got == pytest.approx((cert, below), abs=1e-12)
    assert 0 < cert < 1 and 0 < below < 1
    # one look is the plain binomial tail
    one, _ = stats.sequential_rates((40,), 0.8, 0.95, 0.8)
    assert one == pytest.approx(binom.sf(stats.certify_threshold(40, 0.8, 0.95) - 1, 40, 0.8))
    with pytest.raises(ValueError, match="increasing"):
        stats.sequential_rates((5, 5), 0.8, 0.95, 0.8)
