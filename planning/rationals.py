"""Exact rational arithmetic for the Marigo-Bicchi tumbling planner.

Conventions
-----------
* **Angles are in units of pi.**  A defect angle ``beta = (p/q) * pi`` rad is
  represented by the rational ``p/q``; "mod 2 pi" therefore reads "mod 2" here.
* Every result is exact: ``fractions.Fraction`` (or ``int``).  Inputs may be
  ``int``, ``Fraction``, ``float`` (taken at its *exact* binary value,
  ``Fraction(x)``), numpy scalars, or sympy numbers.  A sympy irrational
  (``sympy.pi``, ``sympy.sqrt(2)``, ``sympy.acos(1/3)/sympy.pi`` ...) is accepted
  by the continued-fraction functions; its terms are produced by sympy's exact
  ``floor`` (which refines ``evalf`` as needed).

Public API
----------
``continued_fraction(x, max_terms=None) -> list[int]``
``convergents(x, max_terms=None) -> list[Fraction]``
``rational_approx(x, tol) -> Fraction``               (the paper's rule, Sec. II-A)
``best_rational_within(x, tol) -> Fraction``          (smallest denominator within tol)
``rational_at_tolerance(x, tol, max_den) -> Fraction | None``  (a rational the tolerance determines)
``min_denominator_for_tol(tol) -> int``               (``ceil(tol**-0.5)``, exactly)
``rational_gcd(fracs) -> Fraction``                   (Sec. III, eq. (2))
``rotation_step(fracs) -> Fraction``                  (generator of the subgroup mod 2)
``extended_gcd_coeffs(fracs, modulus_twopi=True, symmetric=False) -> GcdCoefficients``
"""

from __future__ import annotations

import math
import numbers
from fractions import Fraction
from typing import Iterable, Iterator

__all__ = [
    "best_rational_within",
    "continued_fraction",
    "convergents",
    "min_denominator_for_tol",
    "rational_approx",
    "rational_at_tolerance",
    "to_fraction",
]


# --------------------------------------------------------------------------
# input normalisation
# --------------------------------------------------------------------------
def _is_sympy(x) -> bool:
    return type(x).__module__.startswith("sympy")


def to_fraction(x, *, name: str = "x", allow_float: bool = True) -> Fraction:
    """Convert an exact-representable real number to a ``Fraction``, exactly.

    Accepts ``int``/``bool``, ``Fraction``, numpy integer and float scalars,
    Python ``float`` (its exact binary value, ``Fraction(x)``), sympy ``Integer``,
    ``Rational`` and ``Float`` (exact binary value).  Raises ``ValueError`` for
    NaN/inf, ``TypeError`` for anything else (e.g. a sympy irrational, which has
    no exact rational value).  With ``allow_float=False`` a non-integral float
    raises ``TypeError`` (used where a float would silently produce a huge
    dyadic denominator).
    """
    if isinstance(x, Fraction):
        return x
    if isinstance(x, bool):
        return Fraction(int(x))
    if isinstance(x, numbers.Integral):
        return Fraction(int(x))
    if _is_sympy(x):
        import sympy

        if isinstance(x, sympy.Rational):  # includes Integer
            return Fraction(int(x.p), int(x.q))
        if isinstance(x, sympy.Float):
            if not x.is_finite:
                raise ValueError(f"{name} must be finite, got {x!r}")
            r = sympy.Rational(x)  # exact binary value
            if not allow_float and r.q != 1:
                _reject_float(x, name)
            return Fraction(int(r.p), int(r.q))
        raise TypeError(f"{name}={x!r} is not an exact rational number")
    if isinstance(x, numbers.Real):
        xf = float(x)
        if math.isnan(xf) or math.isinf(xf):
            raise ValueError(f"{name} must be finite, got {x!r}")
        if not allow_float and not xf.is_integer():
            _reject_float(x, name)
        return Fraction(xf)
    raise TypeError(f"{name}={x!r} ({type(x).__name__}) is not a real number")


def _reject_float(x, name):
    raise TypeError(
        f"{name}={x!r} is a float; pass exact rationals (Fraction/int/sympy "
        "Rational), e.g. from rational_approx()"
    )


def _as_exact(x, name: str = "x"):
    """Fraction for rationals/floats; a real sympy ``Expr`` for irrationals."""
    if _is_sympy(x):
        import sympy

        if isinstance(x, (sympy.Rational, sympy.Float)):
            return to_fraction(x, name=name)
        x = sympy.sympify(x)
        if x.is_real is False or x.is_finite is False:
            raise ValueError(f"{name}={x!r} must be a finite real number")
        if x.is_Rational:
            return to_fraction(x, name=name)
        if x.is_number:
            return x
        raise TypeError(f"{name}={x!r} is not a number")
    return to_fraction(x, name=name)


def _validate_tol(tol, name: str = "tol") -> Fraction:
    if isinstance(tol, numbers.Real) and not isinstance(tol, numbers.Rational):
        tf = float(tol)
        if math.isnan(tf):
            raise ValueError(f"{name} must be a non-negative number, got NaN")
        if tf < 0:
            raise ValueError(f"{name} must be >= 0, got {tol!r}")
        if math.isinf(tf):
            raise ValueError(f"{name} must be finite, got {tol!r}")
    try:
        t = to_fraction(tol, name=name)
    except TypeError as exc:  # pragma: no cover - defensive
        raise ValueError(f"{name} must be a non-negative real number, got {tol!r}") from exc
    if t < 0:
        raise ValueError(f"{name} must be >= 0, got {tol!r}")
    return t


# --------------------------------------------------------------------------
# continued fractions
# --------------------------------------------------------------------------
def _cf_terms(x) -> Iterator[int]:
    """Lazy continued-fraction terms of an exact value (Fraction or sympy Expr)."""
    if isinstance(x, Fraction):
        p, q = x.numerator, x.denominator
        while q:
            a = p // q  # floor, also for negative p
            yield a
            p, q = q, p - a * q
        return
    from sympy.ntheory.continued_fraction import continued_fraction_iterator

    for a in continued_fraction_iterator(x):
        yield int(a)


def continued_fraction(x, max_terms: int | None = None) -> list[int]:
    """Simple continued-fraction terms ``[n0; n1, n2, ...]`` of ``x``.

    ``n0 = floor(x)`` (may be negative or zero), ``n_i >= 1`` for ``i >= 1``
    (the last term of a finite expansion is ``>= 2`` unless the expansion is
    ``[n0]`` alone).  The expansion is of the *exact* value: a float is expanded
    as ``Fraction(x)`` (so it terminates and reproduces ``x`` bit for bit);
    rationals terminate; a sympy irrational never terminates, so ``max_terms``
    is then required.  At most ``max_terms`` terms are returned.
    """
    xe = _as_exact(x)
    if max_terms is not None:
        if int(max_terms) != max_terms or max_terms < 0:
            raise ValueError(f"max_terms must be a non-negative integer, got {max_terms!r}")
        max_terms = int(max_terms)
    elif not isinstance(xe, Fraction):
        raise ValueError("max_terms is required for an irrational x")
    out: list[int] = []
    for a in _cf_terms(xe):
        if max_terms is not None and len(out) >= max_terms:
            break
        out.append(a)
    return out


def _iter_convergents(terms: Iterable[int]) -> Iterator[tuple[int, int, int]]:
    """Yield ``(a_k, p_k, q_k)`` for the convergents of a term stream."""
    p_prev, q_prev = 1, 0
    p, q = None, None
    for a in terms:
        if p is None:
            p, q = a, 1
        else:
            p, p_prev = a * p + p_prev, p
            q, q_prev = a * q + q_prev, q
        yield a, p, q


def convergents(x, max_terms: int | None = None) -> list[Fraction]:
    """Convergents ``p_k/q_k`` of the continued fraction of ``x`` (see
    :func:`continued_fraction` for how ``x`` is read and when ``max_terms`` is
    required).

    Guarantees: ``q_0 = 1 < q_1 <= q_2 < ...`` (strictly increasing from k=1),
    ``p_k q_{k-1} - p_{k-1} q_k = (-1)**(k-1)``, and
    ``|x - p_k/q_k| <= 1/(q_k q_{k+1}) <= 1/q_k**2`` (0 for the last convergent
    of a rational).
    """
    return [Fraction(p, q) for _, p, q in _iter_convergents(continued_fraction(x, max_terms))]


def min_denominator_for_tol(tol) -> int:
    """``ceil(tol**-0.5)`` computed exactly on the exact value of ``tol > 0``:
    the smallest integer ``q >= 1`` with ``q*q*tol >= 1`` (so ``1/q**2 <= tol``)."""
    t = _validate_tol(tol)
    if t == 0:
        raise ValueError("tol must be > 0 for a finite denominator")
    r = Fraction(1) / t
    c = -((-r.numerator) // r.denominator)  # ceil(1/tol), q*q >= 1/tol  <=> q*q >= c
    if c <= 1:
        return 1
    return math.isqrt(c - 1) + 1


def rational_approx(x, tol) -> Fraction:
    """The paper's rational representation of ``x`` with tolerance ``tol``.

    Rule (Marigo-Bicchi Sec. II-A): expand ``x`` in a continued fraction and
    truncate at the **first convergent** ``p/q`` with ``q >= ceil(tol**-0.5)``
    (``min_denominator_for_tol``, computed exactly); if the (exact) expansion
    ends before that, ``x`` itself is returned.  Guarantee:
    ``|x - p/q| <= 1/q**2 <= tol`` (and ``= 0`` when ``x`` is returned).

    ``tol == 0`` means exact: a Fraction/int/sympy Rational is returned
    unchanged (as ``Fraction``), a float as ``Fraction(x)``; a sympy irrational
    raises ``ValueError``.  Angles are in units of pi (``beta = (p/q) pi``).
    Raises ``ValueError`` if ``tol`` is negative, NaN or infinite.
    """
    t = _validate_tol(tol)
    xe = _as_exact(x)
    if t == 0:
        if not isinstance(xe, Fraction):
            raise ValueError(f"x={x!r} is irrational: no exact rational value (tol=0)")
        return xe
    qmin = min_denominator_for_tol(t)
    last = None
    for _, p, q in _iter_convergents(_cf_terms(xe)):
        last = Fraction(p, q)
        if q >= qmin:
            return last
    assert last is not None and isinstance(xe, Fraction)
    return last  # exact value, reached before q >= qmin


def _within(x, c: Fraction, tol: Fraction) -> bool:
    """Exact ``|x - c| <= tol`` for Fraction or sympy-irrational ``x``."""
    if isinstance(x, Fraction):
        return abs(x - c) <= tol
    import sympy

    d = x - sympy.Rational(c.numerator, c.denominator)
    t = sympy.Rational(tol.numerator, tol.denominator)
    # x irrational, c and tol rational: |d| == t is impossible, comparisons are decidable.
    return bool(d <= t) and bool(-d <= t)


def _dist_le(x, a: Fraction, b: Fraction) -> bool:
    """Exact ``|x - a| <= |x - b|``."""
    if isinstance(x, Fraction):
        return abs(x - a) <= abs(x - b)
    # |x-a| <= |x-b|  <=>  (b-a)(2x - a - b) <= 0 ... sign form
    import sympy

    s = sympy.Rational((a + b).numerator, (a + b).denominator)
    lhs = 2 * x - s
    if a == b:
        return True
    return bool(lhs <= 0) if b > a else bool(lhs >= 0)


def best_rational_within(x, tol) -> Fraction:
    """The rational with the **smallest denominator** in ``[x - tol, x + tol]``.

    Exact (``x`` read as in :func:`continued_fraction`; sympy irrationals are
    accepted for ``tol > 0``).  Method: such a fraction is a best approximation
    of the first kind, hence a convergent or intermediate fraction
    (semiconvergent) of ``x``; candidates are scanned in increasing denominator
    and inside each block of semiconvergents (monotone in distance) the first
    admissible one is found by bisection.  When several fractions share the
    minimal denominator (possible only for denominator 1, i.e. several
    integers in the interval) the one nearest ``x`` is returned, ties to the
    smaller.  ``tol == 0`` returns the exact value as in :func:`rational_approx`.
    Guarantee: ``|x - r| <= tol`` and every ``p'/q'`` with ``q' < r.denominator``
    has ``|x - p'/q'| > tol``.
    """
    t = _validate_tol(tol)
    xe = _as_exact(x)
    if t == 0:
        if not isinstance(xe, Fraction):
            raise ValueError(f"x={x!r} is irrational: no exact rational value (tol=0)")
        return xe

    terms = _cf_terms(xe)
    a0 = next(terms)
    # Denominator 1: the integers floor(x) and floor(x)+1 are the candidates.
    lo_i, hi_i = Fraction(a0), Fraction(a0 + 1)
    ok_lo, ok_hi = _within(xe, lo_i, t), _within(xe, hi_i, t)
    if ok_lo or ok_hi:
        if isinstance(xe, Fraction) and xe == lo_i:
            return lo_i
        if ok_lo and ok_hi:
            return lo_i if _dist_le(xe, lo_i, hi_i) else hi_i
        return lo_i if ok_lo else hi_i

    # p_{k-1}/q_{k-1} and p_k/q_k, starting with k = 0
    p_prev, q_prev = 1, 0
    p, q = a0, 1
    for a_next in terms:
        # block: (p_prev + j p)/(q_prev + j q), j = 1..a_next; j = a_next is p_{k+1}/q_{k+1}.
        # |x - c_j| is decreasing in j; find the smallest admissible j by bisection.
        def cand(j: int) -> Fraction:
            return Fraction(p_prev + j * p, q_prev + j * q)

        if _within(xe, cand(a_next), t):
            lo, hi = 1, a_next  # hi admissible
            while lo < hi:
                mid = (lo + hi) // 2
                if _within(xe, cand(mid), t):
                    hi = mid
                else:
                    lo = mid + 1
            return cand(hi)
        p_prev, q_prev, p, q = p, q, a_next * p + p_prev, a_next * q + q_prev
    # Rational x: its last convergent is x itself, admissible; unreachable.
    raise AssertionError("continued fraction ended without an admissible candidate")


def rational_at_tolerance(x, tol, max_den: int):
    """The rational that ``x`` is, to within ``tol``, if the tolerance
    determines one; else None.

    ``r = best_rational_within(x, tol)`` (the smallest denominator ``s`` in
    ``[x - tol, x + tol]``) is returned when ``s <= max_den`` and
    ``2 tol s^2 <= 1``.  The second condition makes ``r`` the *only* fraction
    of denominator ``<= s`` in the interval (two distinct such fractions differ
    by at least ``1/s^2 >= 2 tol``), so the answer does not depend on where
    in its tolerance interval ``x`` happens to lie: a tolerance comparable to
    the spacing of the candidate fractions determines nothing.  ``tol == 0``
    tests exact rationality (a float is its exact binary value).
    """
    t = _validate_tol(tol)
    if isinstance(max_den, bool) or int(max_den) != max_den or max_den < 1:
        raise ValueError(f"max_den must be a positive integer, got {max_den!r}")
    r = best_rational_within(x, t)
    s = r.denominator
    if s <= max_den and 2 * t * s * s <= 1:
        return r
    return None
