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
``min_denominator_for_tol(tol) -> int``               (``ceil(tol**-0.5)``, exactly)
``rational_gcd(fracs) -> Fraction``                   (Sec. III, eq. (2))
``rotation_step(fracs) -> Fraction``                  (generator of the subgroup mod 2)
``extended_gcd_coeffs(fracs, modulus_twopi=True, symmetric=False) -> GcdCoefficients``
"""

from __future__ import annotations

import math
import numbers
from fractions import Fraction
from typing import Iterable, Iterator, NamedTuple, Sequence

__all__ = [
    "GcdCoefficients",
    "best_rational_within",
    "continued_fraction",
    "convergents",
    "extended_gcd_coeffs",
    "min_denominator_for_tol",
    "rational_approx",
    "rational_gcd",
    "rotation_step",
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


# --------------------------------------------------------------------------
# GCD of rationals (Sec. III, eq. (2))
# --------------------------------------------------------------------------
def _fractions_for_gcd(fracs) -> list[Fraction]:
    return [to_fraction(f, name=f"fracs[{i}]", allow_float=False) for i, f in enumerate(fracs)]


def rational_gcd(fracs: Iterable) -> Fraction:
    """GCD of rationals: ``gcd(p_1/q_1, ..., p_k/q_k) = gcd(p_i * (q/q_i)) / q``
    with ``q = lcm(q_i)`` (reduced fractions), as in the paper's Sec. III.

    Zero entries are skipped; the gcd of no non-zero entries is ``Fraction(0)``.
    The result is ``>= 0`` and is the largest rational ``g`` such that every
    ``f_i / g`` is an integer (these integers are coprime).  Floats are
    rejected (``TypeError``): approximate them first with :func:`rational_approx`.

    Angles (units of pi): ``g = p/q`` is the paper's ``beta_bar / pi``.  Modulo
    2 (i.e. 2 pi) the angles generate the subgroup generated by ``gcd(g, 2)``
    (``1/q`` if ``p`` is odd, ``2/q`` if ``p`` is even); see
    :func:`rotation_step`.
    """
    fs = [f for f in _fractions_for_gcd(fracs) if f != 0]
    if not fs:
        return Fraction(0)
    q = math.lcm(*(f.denominator for f in fs))
    p = math.gcd(*(f.numerator * (q // f.denominator) for f in fs))
    return Fraction(p, q)


def rotation_step(fracs: Iterable) -> Fraction:
    """Smallest positive rotation (units of pi) generated mod 2 by ``fracs``:
    ``gcd(rational_gcd(fracs), 2)``; equals ``2`` if all entries are zero.
    (The paper's "beta if p odd, 2 beta if p even", ``beta = 1/q``.)"""
    return rational_gcd(list(fracs) + [Fraction(2)])


class GcdCoefficients(NamedTuple):
    """Result of :func:`extended_gcd_coeffs` (unpacks as ``g, n, h``).

    gcd : Fraction
        ``rational_gcd(fracs)`` (``>= 0``).
    n : tuple[int, ...]
        Bezout coefficients, one per input (0 for zero inputs).
    h : tuple[int, ...]
        ``h_j = f_j / gcd`` exactly (0 where ``f_j == 0``, all 0 if gcd is 0).
    modulus_twopi : bool
        Whether ``n`` was reduced modulo ``2 q_i`` (identity then holds mod 2).
    """

    gcd: Fraction
    n: tuple[int, ...]
    h: tuple[int, ...]
    modulus_twopi: bool


def _egcd(a: int, b: int) -> tuple[int, int, int]:
    """``(g, x, y)`` with ``g = gcd(a, b) >= 0`` and ``a x + b y = g``."""
    x0, y0, x1, y1 = 1, 0, 0, 1
    while b:
        k, r = divmod(a, b)
        a, b = b, r
        x0, x1 = x1, x0 - k * x1
        y0, y1 = y1, y0 - k * y1
    if a < 0:
        a, x0, y0 = -a, -x0, -y0
    return a, x0, y0


def extended_gcd_coeffs(
    fracs: Sequence, modulus_twopi: bool = True, *, symmetric: bool = False
) -> GcdCoefficients:
    """Integers ``n_i`` with ``sum n_i f_i = gcd`` by the paper's iterated
    extended Euclid (Sec. III), and ``h_j`` with ``h_j * gcd = f_j``.

    Write ``f_i = p_i/q_i`` (reduced), ``q = lcm(q_i)``, ``a_i = p_i * q/q_i``.
    The EEA is applied as a left fold ``g_1 = |a_1|``,
    ``g_i = gcd(g_{i-1}, a_i) = u_i g_{i-1} + v_i a_i``: the new coefficient is
    ``v_i`` and every earlier coefficient is multiplied by ``u_i`` (the paper's
    products ``n_i = prod n_i^{(.)}``).  Zero entries are skipped (``n_i = 0``).

    Identity returned (all arithmetic exact, in ``Fraction``):

    * ``modulus_twopi=False``: ``sum(n_i * f_i) == gcd`` exactly.
    * ``modulus_twopi=True`` (angles in units of pi taken mod 2, i.e. mod 2 pi):
      each ``n_i`` is reduced modulo ``2 q_i`` -- to ``[0, 2 q_i)``, or with
      ``symmetric=True`` to ``(-q_i, q_i]`` -- which changes ``n_i f_i`` by a
      multiple of ``2 p_i``; hence ``(sum(n_i * f_i) - gcd) / 2`` is an integer,
      i.e. ``sum n_i f_i == gcd (mod 2)``.

    ``h_j = f_j / gcd`` (integers, coprime as a family) in both cases.
    Floats are rejected (``TypeError``); ``fracs`` may be empty.
    """
    fs = _fractions_for_gcd(fracs)
    k = len(fs)
    n = [0] * k
    nz = [i for i, f in enumerate(fs) if f != 0]
    if not nz:
        return GcdCoefficients(Fraction(0), tuple(n), tuple(n), bool(modulus_twopi))
    q = math.lcm(*(fs[i].denominator for i in nz))
    a = {i: fs[i].numerator * (q // fs[i].denominator) for i in nz}
    first = nz[0]
    g = abs(a[first])
    n[first] = 1 if a[first] > 0 else -1
    for i in nz[1:]:
        g_new, u, v = _egcd(g, a[i])
        if u != 1:
            for j in nz:
                if j == i:
                    break
                n[j] *= u
        n[i] = v
        g = g_new
    gcd = Fraction(g, q)
    assert sum((n[i] * fs[i] for i in nz), Fraction(0)) == gcd
    if modulus_twopi:
        for i in nz:
            m = 2 * fs[i].denominator
            r = n[i] % m
            if symmetric and r > m // 2:
                r -= m
            n[i] = r
    h = [0] * k
    for i in nz:
        hi = fs[i] / gcd
        assert hi.denominator == 1
        h[i] = hi.numerator
    return GcdCoefficients(gcd, tuple(n), tuple(h), bool(modulus_twopi))
