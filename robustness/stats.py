"""Statistics of Monte-Carlo evaluations (host-side numpy / scipy).

* :func:`clopper_pearson`: the exact (conservative) binomial confidence
  interval of a success probability from ``k`` successes in ``n`` trials,
  from the beta distribution: ``lower = Beta(alpha/2; k, n-k+1)``,
  ``upper = Beta(1-alpha/2; k+1, n-k)``, with ``alpha = 1 - confidence``
  (two-sided), and ``lower = 0`` when ``k = 0``, ``upper = 1`` when ``k = n``.
  For certification the ONE-sided lower bound at the stated confidence
  (``Beta(alpha; k, n-k+1)``) is what counts: :func:`one_sided_lower`.
* :func:`quantiles`: the 50/90/99 % quantiles and the maximum of an error.
* :func:`one_sided_upper`: the one-sided upper bound (a requirement above it
  cannot be met, whatever more samples show).
* :func:`samples_needed`: how many all-successful samples certify a required
  probability at a confidence (``p^n <= alpha``).
* :func:`certify_threshold`, :func:`below_threshold`: the fewest successes
  whose lower bound reaches a requirement, the most whose upper bound stays
  below it (the decision rule of one look, as counts).
* :func:`sequential_rates`: the exact probabilities that a rule which looks at
  a fixed schedule of sample counts, stopping at the first decided look, ends
  certified or ends below the requirement, for a true success probability
  (dynamic programming over the looks).  Re-testing at every look at the full
  confidence does not hold that confidence (a plan exactly at the requirement
  is "certified" far more often than ``1 - confidence``); splitting ``alpha``
  over the looks (Bonferroni) does, and this function checks it exactly.
"""
from __future__ import annotations

import math

import numpy as np
from scipy import stats as _st

#: The confidence of a probability claim when none is stated: every default of a
#: ``confidence`` (the bounds here, :func:`robustness.evaluate`, :func:`robustness.certify`,
#: robust synthesis, a config's ``required.confidence``) is this one value.
CONFIDENCE = 0.95
#: The required success probability when none is stated (:func:`robustness.certify`,
#: a config's ``required.probability``).
REQUIRED_PROBABILITY = 0.9

QUANTILES = (0.5, 0.9, 0.99)
QUANTILE_NAMES = ("q50", "q90", "q99")


def _check(k: int, n: int, confidence: float) -> None:
    if not (isinstance(n, (int, np.integer)) and n >= 0):
        raise ValueError(f"n: expected an integer >= 0, got {n!r}")
    if not (0 <= k <= n):
        raise ValueError(f"k: expected 0 <= k <= n = {n}, got {k!r}")
    if not (0.0 < confidence < 1.0):
        raise ValueError(f"confidence: expected a number in (0, 1), got {confidence!r}")


def _check_p(p_required: float) -> None:
    if not (0.0 < p_required < 1.0):
        raise ValueError(f"p_required: expected a number in (0, 1), got {p_required!r}")


def clopper_pearson(k: int, n: int, confidence: float = CONFIDENCE) -> tuple[float, float]:
    """Two-sided Clopper-Pearson interval ``(lower, upper)`` for a binomial
    proportion (``k`` successes of ``n``); ``(0, 1)`` when ``n = 0``."""
    _check(k, n, confidence)
    if n == 0:
        return 0.0, 1.0
    a = 1.0 - confidence
    lo = 0.0 if k == 0 else float(_st.beta.ppf(a / 2, k, n - k + 1))
    hi = 1.0 if k == n else float(_st.beta.ppf(1 - a / 2, k + 1, n - k))
    return lo, hi


def one_sided_lower(k: int, n: int, confidence: float = CONFIDENCE) -> float:
    """One-sided Clopper-Pearson lower bound: with probability ``confidence``
    the true success probability is at least this (0 when ``k = 0``)."""
    _check(k, n, confidence)
    if n == 0 or k == 0:
        return 0.0
    return float(_st.beta.ppf(1.0 - confidence, k, n - k + 1))


def one_sided_upper(k: int, n: int, confidence: float = CONFIDENCE) -> float:
    """One-sided Clopper-Pearson upper bound: with probability ``confidence``
    the true success probability is at most this (1 when ``k = n``)."""
    _check(k, n, confidence)
    if n == 0 or k == n:
        return 1.0
    return float(_st.beta.ppf(confidence, k + 1, n - k))


def samples_needed(p_required: float, confidence: float) -> int:
    """Fewest samples that, all successful, put the one-sided lower bound at
    ``p_required`` or above: the smallest n with ``p_required ** n <= 1 - confidence``."""
    _check_p(p_required)
    if not (0.0 < confidence < 1.0):
        raise ValueError(f"confidence: expected a number in (0, 1), got {confidence!r}")
    n = max(1, int(math.ceil(math.log(1.0 - confidence) / math.log(p_required))))
    # the ratio of logs can round across an integer: settle n on the exact condition
    while n > 1 and p_required ** (n - 1) <= 1.0 - confidence:
        n -= 1
    while p_required ** n > 1.0 - confidence:
        n += 1
    return n


def certify_threshold(n: int, p_required: float, confidence: float) -> int:
    """Fewest successes ``k`` of ``n`` whose one-sided lower bound
    (:func:`one_sided_lower` at ``confidence``) is at least ``p_required``;
    ``n + 1`` when even ``k = n`` is not enough.  The bound increases with ``k``,
    so this bisects on the very function a certificate uses."""
    _check_p(p_required)
    if one_sided_lower(n, n, confidence) < p_required:
        return n + 1
    lo, hi = 0, n            # lower(lo) < p_required <= lower(hi)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if one_sided_lower(mid, n, confidence) >= p_required else (mid, hi)
    return hi


def below_threshold(n: int, p_required: float, confidence: float) -> int:
    """Most successes ``k`` of ``n`` whose one-sided upper bound
    (:func:`one_sided_upper` at ``confidence``) is below ``p_required``; -1 when
    none is (the bound increases with ``k``: bisection, as :func:`certify_threshold`)."""
    _check_p(p_required)
    if one_sided_upper(0, n, confidence) >= p_required:
        return -1
    lo, hi = 0, n            # upper(lo) < p_required <= upper(hi) = 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if one_sided_upper(mid, n, confidence) < p_required else (lo, mid)
    return lo


def sequential_rates(counts, p_required: float, look_confidence: float,
                     p_true: float) -> tuple[float, float]:
    """Exact outcome probabilities of a sequential test at fixed looks.

    The rule: draw samples up to ``counts[0]``, ``counts[1]``, ... (increasing
    totals); at each look with ``k`` successes of ``n``, stop "certified" when
    ``k >= certify_threshold(n, p_required, look_confidence)``, stop "below"
    when ``k <= below_threshold(n, p_required, look_confidence)``, else go on;
    after the last look, stop undecided.  Samples are independent successes of
    probability ``p_true``.

    Returns:
      ``(P(certified), P(below))`` over all looks, computed exactly: the
      distribution of ``k`` among runs still going is carried from look to look
      (convolved with the binomial of the new samples) and the decided mass
      removed.  Both are monotone in ``p_true`` (more successes certify sooner),
      so at ``p_true = p_required`` they are the largest false-certification and
      false-"below" probabilities the rule can have.
    """
    from scipy.signal import fftconvolve

    if not (0.0 <= p_true <= 1.0):
        raise ValueError(f"p_true: expected a number in [0, 1], got {p_true!r}")
    mass = np.ones(1)
    prev, p_cert, p_below = 0, 0.0, 0.0
    for n in (int(c) for c in counts):
        if n <= prev:
            raise ValueError(f"counts: expected increasing sample counts, got {list(counts)}")
        inc = _st.binom.pmf(np.arange(n - prev + 1), n - prev, p_true)
        mass = (np.convolve(mass, inc) if mass.size * inc.size <= 1 << 22
                else np.clip(fftconvolve(mass, inc), 0.0, None))
        c = certify_threshold(n, p_required, look_confidence)
        f = below_threshold(n, p_required, look_confidence)
        p_cert += float(mass[c:].sum())
        p_below += float(mass[:f + 1].sum())
        mass[c:] = 0.0
        mass[:f + 1] = 0.0
        prev = n
    return p_cert, p_below


def quantiles(values) -> dict:
    """``{"q50", "q90", "q99", "max"}`` of finite ``values`` (NaN when empty).

    Non-finite values (a diverged sample) make ``max`` infinite, never hide it.
    """
    v = np.asarray(values, dtype=np.float64).ravel()
    out = {}
    if v.size == 0:
        return {**{q: math.nan for q in QUANTILE_NAMES}, "max": math.nan}
    nonfinite = ~np.isfinite(v)
    w = np.where(nonfinite, np.inf, v)
    for name, q in zip(QUANTILE_NAMES, QUANTILES):
        # linear interpolation when every value is finite; otherwise the next
        # order statistic (interpolating towards inf would give NaN)
        out[name] = float(np.quantile(w, q, method="higher" if nonfinite.any() else "linear"))
    out["max"] = float(np.max(w))
    return out
