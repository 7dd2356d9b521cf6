"""Tests of planning.rationals (continued fractions, rational approximations)
and planning.tumbling.angle_gcd (GCD of rational angles, Bezout coefficients)."""

from __future__ import annotations

import math
from fractions import Fraction as F

import pytest
import sympy
from hypothesis import given, settings
from hypothesis import strategies as st

from planning.rationals import (
    best_rational_within,
    continued_fraction,
    convergents,
    min_denominator_for_tol,
    rational_approx,
    rational_at_tolerance,
)
from planning.tumbling.angle_gcd import extended_gcd_coeffs, rational_gcd, rotation_step

SETTINGS = settings(derandomize=True, max_examples=150, deadline=None)

finite_floats = st.floats(min_value=-50, max_value=50, allow_nan=False, allow_infinity=False)
fractions_ = st.builds(F, st.integers(-10**6, 10**6), st.integers(1, 10**4))
pos_tols = st.one_of(
    st.floats(min_value=1e-12, max_value=2.0),
    st.builds(F, st.integers(1, 50), st.integers(1, 10**7)),
)


def _value(cf):
    v = F(cf[-1])
    for a in reversed(cf[:-1]):
        v = a + 1 / v
    return v


# ---------------------------------------------------------------- continued fractions
def test_known_expansions():
    assert continued_fraction(F(415, 93)) == [4, 2, 6, 7]
    assert continued_fraction(F(-3, 8)) == [-1, 1, 1, 1, 2]
    assert continued_fraction(7) == [7]
    assert continued_fraction(sympy.pi, 5) == [3, 7, 15, 1, 292]
    assert continued_fraction(sympy.sqrt(2), 6) == [1, 2, 2, 2, 2, 2]
    assert convergents(sympy.pi, 4) == [F(3), F(22, 7), F(333, 106), F(355, 113)]
    assert continued_fraction(F(415, 93), max_terms=2) == [4, 2]
    with pytest.raises(ValueError, match="max_terms"):
        continued_fraction(sympy.pi)


@SETTINGS
@given(st.one_of(finite_floats, fractions_))
def test_cf_reproduces_exact_value(x):
    cf = continued_fraction(x)
    assert _value(cf) == F(x)
    assert all(a >= 1 for a in cf[1:])
    cv = convergents(x)
    assert cv[-1] == F(x)
    qs = [c.denominator for c in cv]
    assert qs[0] == 1 and all(a < b for a, b in zip(qs[1:], qs[2:]))
    for k in range(1, len(cv)):  # p_k q_{k-1} - p_{k-1} q_k = (-1)^(k-1)
        assert cv[k].numerator * cv[k - 1].denominator - cv[k - 1].numerator * cv[k].denominator == (-1) ** (k - 1)
    for c in cv:
        assert abs(F(x) - c) <= F(1, c.denominator**2)


# ---------------------------------------------------------------- paper's rule
def test_min_denominator_exact():
    assert min_denominator_for_tol(F(1, 100)) == 10
    assert min_denominator_for_tol(F(1, 101)) == 11
    assert min_denominator_for_tol(1) == 1 and min_denominator_for_tol(5) == 1
    for t in [1e-4, 1e-6, 0.3, 2.5e-7, F(1, 7)]:
        q = min_denominator_for_tol(t)
        assert q * q * F(t) >= 1 and (q - 1) ** 2 * F(t) < 1


@SETTINGS
@given(st.one_of(finite_floats, fractions_), pos_tols)
def test_rational_approx_paper_rule(x, tol):
    r = rational_approx(x, tol)
    xe, t = F(x), F(tol)
    qmin = min_denominator_for_tol(tol)
    cv = convergents(x)
    assert r in cv
    assert abs(xe - r) <= F(1, r.denominator**2) <= t or r == xe
    assert abs(xe - r) <= t
    # first convergent with q >= qmin (or the exact value if none)
    earlier = cv[: cv.index(r)]
    assert all(c.denominator < qmin for c in earlier)
    assert r.denominator >= qmin or r == xe


def test_rational_approx_examples_and_irrational():
    assert rational_approx(math.pi, 1e-4) == F(333, 106)  # q >= 100
    assert rational_approx(sympy.pi, 1e-6) == F(103993, 33102)
    r = rational_approx(sympy.sqrt(2), F(1, 10**8))
    assert r.denominator >= 10**4 and abs(sympy.sqrt(2) - sympy.Rational(r.numerator, r.denominator)) < 1e-8


def test_rational_approx_tol_zero_exact():
    assert rational_approx(F(2, 3), 0) == F(2, 3)
    assert rational_approx(5, 0) == F(5)
    assert rational_approx(sympy.Rational(-7, 9), 0) == F(-7, 9)
    assert rational_approx(0.1, 0) == F(0.1)
    assert rational_approx(0.1, 0.0) == F(0.1)
    with pytest.raises(ValueError):
        rational_approx(sympy.pi, 0)


@pytest.mark.parametrize("fn", [rational_approx, best_rational_within])
@pytest.mark.parametrize("bad", [-1e-3, float("nan"), F(-1, 2), -1])
def test_bad_tol(fn, bad):
    with pytest.raises(ValueError, match="tol"):
        fn(0.3, bad)


def test_bad_x():
    with pytest.raises(ValueError):
        rational_approx(float("nan"), 1e-3)
    with pytest.raises(ValueError):
        rational_approx(float("inf"), 1e-3)
    with pytest.raises(TypeError):
        rational_approx("0.3", 1e-3)


# ---------------------------------------------------------------- smallest denominator
def _brute_best(x: F, t: F) -> F:
    q = 1
    while True:
        lo, hi = math.ceil((x - t) * q), math.floor((x + t) * q)
        if lo <= hi:
            cands = [F(p, q) for p in range(lo, hi + 1)]
            return min(cands, key=lambda c: (abs(x - c), c))
        q += 1


@SETTINGS
@given(
    st.one_of(st.floats(min_value=-20, max_value=20), fractions_),
    st.one_of(st.floats(min_value=1e-6, max_value=1.5), st.builds(F, st.integers(1, 30), st.integers(1, 10**6))),
)
def test_best_rational_within_brute(x, tol):
    r = best_rational_within(x, tol)
    assert r == _brute_best(F(x), F(tol))


def test_best_rational_within_examples():
    assert best_rational_within(math.pi, 1e-3) == F(201, 64)
    assert best_rational_within(sympy.pi, F(1, 10**6)) == F(355, 113)
    assert best_rational_within(sympy.pi, F(2, 1000)) == F(22, 7)
    assert best_rational_within(0.5, 0) == F(1, 2)
    assert best_rational_within(F(1, 2), F(1, 2)) == 0  # 0 and 1 tie: the smaller
    # a huge partial quotient (x ~ 1e-9: [0; 10**9, ...]) exercises the bisection
    x, t = F(1e-9), F(1e-12)
    assert best_rational_within(1e-9, 1e-12) == F(1, math.ceil(1 / (x + t)))
    # irrational input against brute force on a 40-digit rational stand-in
    s2 = sympy.Rational(sympy.N(sympy.sqrt(2), 40))
    assert best_rational_within(sympy.sqrt(2), F(1, 10**5)) == _brute_best(F(int(s2.p), int(s2.q)), F(1, 10**5))


def test_best_never_worse_than_paper_rule():
    for x in [math.pi, math.e, 0.123456789, -2.718281828]:
        for t in [1e-2, 1e-4, 1e-7]:
            assert best_rational_within(x, t).denominator <= rational_approx(x, t).denominator


# ---------------------------------------------------------------- GCD
rat_lists = st.lists(
    st.one_of(st.just(F(0)), st.builds(F, st.integers(-60, 60), st.integers(1, 40))), min_size=0, max_size=7
)


@SETTINGS
@given(rat_lists)
def test_rational_gcd_properties(fs):
    g = rational_gcd(fs)
    nz = [f for f in fs if f != 0]
    if not nz:
        assert g == 0
        return
    assert g > 0
    hs = [f / g for f in nz]
    assert all(h.denominator == 1 for h in hs)
    assert math.gcd(*(h.numerator for h in hs)) == 1  # g is the greatest such rational
    q = math.lcm(*(f.denominator for f in nz))
    assert g == F(math.gcd(*(f.numerator * (q // f.denominator) for f in nz)), q)


@SETTINGS
@given(rat_lists)
def test_extended_gcd_exact(fs):
    g, n, h, mod = extended_gcd_coeffs(fs, modulus_twopi=False)
    assert not mod and g == rational_gcd(fs)
    assert len(n) == len(h) == len(fs)
    assert sum((ni * fi for ni, fi in zip(n, fs)), F(0)) == g
    assert all(hj * g == fj for hj, fj in zip(h, fs))
    assert all(ni == 0 and hi == 0 for ni, hi, fi in zip(n, h, fs) if fi == 0)


@SETTINGS
@given(rat_lists, st.booleans())
def test_extended_gcd_mod_two(fs, symmetric):
    g, n, h, mod = extended_gcd_coeffs(fs, symmetric=symmetric)
    assert mod
    s = sum((ni * fi for ni, fi in zip(n, fs)), F(0))
    diff = (s - g) / 2
    assert diff.denominator == 1  # sum n_i f_i == gcd (mod 2)
    for ni, fi in zip(n, fs):
        if fi == 0:
            assert ni == 0
        elif symmetric:
            assert -fi.denominator < ni <= fi.denominator
        else:
            assert 0 <= ni < 2 * fi.denominator
    assert all(hj * g == fj for hj, fj in zip(h, fs))


def test_gcd_examples():
    assert rational_gcd([F(1, 2), F(1, 3)]) == F(1, 6)
    assert rational_gcd([F(4, 3), F(2, 3), 0]) == F(2, 3)
    assert rational_gcd([sympy.Rational(3, 4), 2]) == F(1, 4)
    assert rational_gcd([]) == 0 and rational_gcd([0, 0]) == 0
    # cube: defect angles pi/2 at every vertex
    assert rational_gcd([F(1, 2)] * 7) == F(1, 2)
    # Bezout coefficients are not unique: check the identities, not one answer
    fs = [F(4, 3), F(6, 5), F(1, 7)]
    g, n, h, _ = extended_gcd_coeffs(fs, modulus_twopi=False)
    assert g == F(1, 105) and h == (140, 126, 15)  # 4/3 = 140/105, 6/5 = 126/105, 1/7 = 15/105
    assert sum(ni * fi for ni, fi in zip(n, fs)) == g
    g, n, h, _ = extended_gcd_coeffs(fs)
    assert ((sum(ni * fi for ni, fi in zip(n, fs)) - g) / 2).denominator == 1  # == g (mod 2)
    assert all(0 <= ni < 2 * fi.denominator for ni, fi in zip(n, fs))
    assert rotation_step([F(4, 3)]) == F(2, 3)  # p even: 2 beta
    assert rotation_step([F(1, 3)]) == F(1, 3)  # p odd: beta
    assert rotation_step([0]) == 2
    with pytest.raises(TypeError):
        rational_gcd([0.1, F(1, 2)])
    with pytest.raises(TypeError):
        extended_gcd_coeffs([0.25])


def test_rational_at_tolerance():
    """The rational a tolerance determines: the smallest denominator s in the
    interval, accepted when s <= max_den and 2 tol s^2 <= 1 (then it is the only
    fraction of denominator <= s there)."""
    assert rational_at_tolerance(0.5 + 3e-10, 3e-8, 1000) == F(1, 2)
    assert rational_at_tolerance(F(1, 3), 0, 10) == F(1, 3)
    assert rational_at_tolerance(0.1, 0, 10) is None  # 0.1 as a float is not 1/10 exactly
    assert rational_at_tolerance(17 / 23 + 1e-7, 1e-6, 1000) == F(17, 23)
    assert rational_at_tolerance(17 / 23 + 1e-7, 1e-6, 20) is None  # beyond max_den
    # sqrt(2): 577/408 is the smallest denominator within 1e-5, but 2 tol s^2 > 1
    assert rational_at_tolerance(math.sqrt(2), 1e-5, 1000) is None
    assert rational_at_tolerance(math.pi / 10, 0.6, 1000) is None  # 0 and 1 both fit
    with pytest.raises(ValueError, match="max_den"):
        rational_at_tolerance(0.5, 1e-3, 0)
    with pytest.raises(ValueError, match="tol"):
        rational_at_tolerance(0.5, -1e-3, 10)


@SETTINGS
@given(st.fractions(min_value=-5, max_value=5, max_denominator=40),
       st.floats(min_value=0.0, max_value=1e-4), st.floats(min_value=-1.0, max_value=1.0))
def test_rational_at_tolerance_is_unique(r, tol, u):
    """Whatever point of the interval the value is, a determined answer is the
    only fraction of its denominator or less within tol."""
    x = float(r) + u * tol
    got = rational_at_tolerance(x, tol, 1000)
    if got is None:
        return
    assert abs(F(x) - got) <= F(tol)
    s = got.denominator
    for q in range(1, s + 1):
        for p in (math.floor(x * q), math.ceil(x * q)):
            if F(p, q) != got:
                assert abs(F(x) - F(p, q)) > F(tol)
