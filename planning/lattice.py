"""Exact integer/rational lattice algorithms for the tumbling planner (Sec. III).

All arithmetic is exact: Python ``int`` and ``fractions.Fraction``.  Matrices
are plain lists of rows (``list[list[...]]``); a 2-D vector is a pair
``(x, y)``.  A lattice basis ``X`` is a sequence of basis vectors
``[X1, X2]`` (the *columns* of the paper's matrix ``[X1 X2]``).  Inputs may be
ints, Fractions, floats (read at their exact binary value), numpy arrays or
sympy matrices/numbers.

Public API
----------
``hermite_normal_form(A) -> (H, U)``            ``H == A U``, column-style HNF
``lattice_basis(vectors) -> (X, U, rank)``      the paper's ``[X1 X2 0] = V U``
``lagrange_gauss_reduce(b1, b2) -> (r1, r2, T)``
``closest_lattice_point(X, target) -> (k1, k2)``  exact CVP in 2-D
``lattice_point(X, k) -> (x, y)``               ``k1 X1 + k2 X2``
``mesh_area(X) -> Fraction``                    the paper's ``Delta = |det[X1 X2]|``
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Sequence

from planning.rationals import to_fraction

__all__ = [
    "closest_lattice_point",
    "hermite_normal_form",
    "lagrange_gauss_reduce",
    "lattice_basis",
    "lattice_point",
    "mesh_area",
]

Vec2 = tuple[Fraction, Fraction]


# --------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------
def _rows(A) -> list[list]:
    if hasattr(A, "tolist"):
        A = A.tolist()
    rows = [list(r) for r in A]
    if rows and any(len(r) != len(rows[0]) for r in rows):
        raise ValueError("A must be a rectangular matrix (list of equal-length rows)")
    return rows


def _nearest_quotient(a: int, b: int) -> int:
    """Integer ``k`` minimising ``|a - k b|`` (``b != 0``)."""
    k, r = divmod(a, b)  # r has the sign of b, |r| < |b|
    if 2 * abs(r) > abs(b):
        k += 1
    return k


def _round_half_down(x: Fraction) -> int:
    """Nearest integer to ``x`` (ties to the smaller)."""
    return -math.floor(-x + Fraction(1, 2))


# --------------------------------------------------------------------------
# Hermite normal form
# --------------------------------------------------------------------------
def _hnf_int(rows: list[list[int]]) -> tuple[list[list[int]], list[list[int]]]:
    r = len(rows)
    n = len(rows[0]) if r else 0
    cols = [[rows[i][j] for i in range(r)] for j in range(n)]  # column-major
    ucols = [[1 if i == j else 0 for i in range(n)] for j in range(n)]

    def addcol(dst: int, src: int, k: int) -> None:  # col[dst] += k col[src]
        if k == 0:
            return
        cd, cs = cols[dst], cols[src]
        for i in range(r):
            if cs[i]:
                cd[i] += k * cs[i]
        ud, us = ucols[dst], ucols[src]
        for i in range(n):
            if us[i]:
                ud[i] += k * us[i]

    def swap(j1: int, j2: int) -> None:
        if j1 != j2:
            cols[j1], cols[j2] = cols[j2], cols[j1]
            ucols[j1], ucols[j2] = ucols[j2], ucols[j1]

    pc = 0  # next pivot column
    for i in range(r):
        if pc == n:
            break
        # Euclid across columns pc..n-1 of row i (smallest |entry| as divisor).
        while True:
            nz = [j for j in range(pc, n) if cols[j][i] != 0]
            if not nz:
                break
            jmin = min(nz, key=lambda j: abs(cols[j][i]))
            swap(pc, jmin)
            piv = cols[pc][i]
            done = True
            for j in range(pc + 1, n):
                a = cols[j][i]
                if a:
                    addcol(j, pc, -_nearest_quotient(a, piv))
                    if cols[j][i]:
                        done = False
            if done:
                break
        if cols[pc][i] == 0:
            continue  # row i has no pivot (it is dependent on the rows above)
        if cols[pc][i] < 0:
            cols[pc] = [-v for v in cols[pc]]
            ucols[pc] = [-v for v in ucols[pc]]
        piv = cols[pc][i]
        for j in range(pc):  # reduce the entries left of the pivot into [0, piv)
            addcol(j, pc, -(cols[j][i] // piv))
        pc += 1
    H = [[cols[j][i] for j in range(n)] for i in range(r)]
    U = [[ucols[j][i] for j in range(n)] for i in range(n)]
    return H, U


def hermite_normal_form(A):
    """Column-style Hermite normal form with its unimodular transform.

    ``A`` is an ``r x N`` matrix (list of rows; ints, Fractions, floats at their
    exact value, numpy or sympy).  Returns ``(H, U)`` with

    * ``U`` an ``N x N`` integer matrix, ``det U = +-1``;
    * ``H == A U`` **exactly**;
    * ``H`` in column Hermite normal form ("lower triangular"): its first
      ``rank`` columns are non-zero and the remaining ``N - rank`` are zero; the
      pivot (first non-zero entry) of column ``j`` lies in row ``i_j`` with
      ``i_0 < i_1 < ...``; pivots are positive; in every pivot row ``i_j`` the
      entries left of the pivot are reduced into ``[0, H[i_j][j])`` (entries
      right of it are 0).  This form is unique for the lattice spanned by the
      columns of ``A``; its first ``rank`` columns are a basis of that lattice
      (for ``r = 2``: the paper's ``[X1 X2 0] = V U``), and the last ``N - rank``
      columns of ``U`` are a basis of the integer kernel ``{k : A k = 0}``.

    Rational input: with ``L`` the lcm of all denominators, the HNF of the
    integer matrix ``L A`` is computed and ``H = HNF(L A) / L`` is returned
    (``U`` is the same); ``H == A U`` still holds exactly.  Entries of ``H`` are
    ``int`` when every entry of ``A`` is integer-typed (Python/numpy/sympy
    integers), ``Fraction`` otherwise.

    Relation to ``sympy.matrices.normalforms.hermite_normal_form`` (Cohen 2.4.5:
    also column operations, but pivots placed in the *rightmost* columns and the
    bottom row handled first, zero columns dropped): with ``J`` the reversal
    permutation, ``H[:, :rank] == J_r * sympyHNF(J_r A) * J_rank``.
    """
    rows = _rows(A)
    r = len(rows)
    if r == 0:
        raise ValueError("A must have at least one row")
    fr = [[to_fraction(v, name="A entry") for v in row] for row in rows]
    L = math.lcm(*(v.denominator for row in fr for v in row)) if fr[0] else 1
    H, U = _hnf_int([[int(v * L) for v in row] for row in fr])
    if not _all_integer_typed(rows):
        H = [[Fraction(v, L) for v in row] for row in H]
    return H, U


def _all_integer_typed(rows) -> bool:
    import numbers

    return all(isinstance(v, numbers.Integral) or _is_sympy_integer(v) for row in rows for v in row)


def _is_sympy_integer(v) -> bool:
    return type(v).__module__.startswith("sympy") and getattr(v, "is_Integer", False)


def lattice_basis(vectors: Sequence[Sequence]) -> tuple[list[tuple], list[list[int]], int]:
    """Basis of the lattice generated by the given vectors (the paper's
    ``[X1 X2 0] = V U``, Sec. III).

    ``vectors`` is a sequence of ``N`` vectors of equal dimension ``d``
    (typically 2-D translation generators ``v_i`` as Fraction pairs); they are
    the columns of ``V``.  Returns ``(X, U, rank)``:

    * ``X``: list of ``rank`` basis vectors (tuples of Fractions), the non-zero
      columns of ``H = V U`` (HNF, see :func:`hermite_normal_form`);
    * ``U``: ``N x N`` unimodular integer matrix (list of rows) with
      ``X_j = sum_i v_i U[i][j]`` exactly (``j < rank``) and
      ``sum_i v_i U[i][j] = 0`` for ``j >= rank``;
    * ``rank``: the rank of ``V`` (2 for a genuine planar lattice).
    """
    vs = [[to_fraction(c, name="vector component") for c in v] for v in vectors]
    if not vs:
        raise ValueError("need at least one vector")
    d = len(vs[0])
    if d == 0 or any(len(v) != d for v in vs):
        raise ValueError("vectors must be non-empty and of equal dimension")
    V = [[vs[j][i] for j in range(len(vs))] for i in range(d)]
    H, U = hermite_normal_form(V)
    rank = sum(1 for j in range(len(vs)) if any(H[i][j] != 0 for i in range(d)))
    X = [tuple(Fraction(H[i][j]) for i in range(d)) for j in range(rank)]
    return X, U, rank


# --------------------------------------------------------------------------
# 2-D reduction and closest vector
# --------------------------------------------------------------------------
def _vec(v, name: str) -> Vec2:
    if hasattr(v, "tolist"):
        v = v.tolist()
    v = list(v)
    if len(v) != 2:
        raise ValueError(f"{name} must be a 2-D vector, got length {len(v)}")
    return (to_fraction(v[0], name=name), to_fraction(v[1], name=name))


def _dot(a: Vec2, b: Vec2) -> Fraction:
    return a[0] * b[0] + a[1] * b[1]


def _det(a: Vec2, b: Vec2) -> Fraction:
    return a[0] * b[1] - a[1] * b[0]


def lagrange_gauss_reduce(b1, b2) -> tuple[Vec2, Vec2, list[list[int]]]:
    """Lagrange-Gauss reduction of the 2-D lattice basis ``(b1, b2)``, exact.

    Returns ``(r1, r2, T)`` with ``T`` a 2x2 integer matrix (list of rows),
    ``det T = +-1``, and ``[r1 r2] = [b1 b2] T`` (columns), i.e.
    ``r1 = T[0][0] b1 + T[1][0] b2``, ``r2 = T[0][1] b1 + T[1][1] b2``.
    The result is reduced: ``|r1| <= |r2|`` and ``2 |<r1, r2>| <= |r1|^2``;
    hence ``r1`` is a shortest non-zero lattice vector, the angle between
    ``r1`` and ``r2`` lies in [60, 120] degrees, and ``r2`` is shortest among
    the vectors independent of ``r1``.  Raises ``ValueError`` if ``b1, b2``
    are linearly dependent.
    """
    u, v = _vec(b1, "b1"), _vec(b2, "b2")
    if _det(u, v) == 0:
        raise ValueError("b1 and b2 are linearly dependent")
    # columns of T track u and v in terms of (b1, b2)
    tu, tv = [1, 0], [0, 1]
    if _dot(u, u) > _dot(v, v):
        u, v, tu, tv = v, u, tv, tu
    while True:
        k = _round_half_down(_dot(u, v) / _dot(u, u))
        if k:
            v = (v[0] - k * u[0], v[1] - k * u[1])
            tv = [tv[0] - k * tu[0], tv[1] - k * tu[1]]
        if _dot(v, v) < _dot(u, u):
            u, v, tu, tv = v, u, tv, tu
        else:
            break
    # After the loop |<u,v>| <= |u|^2 / 2 and |u| <= |v|.
    T = [[tu[0], tv[0]], [tu[1], tv[1]]]
    return u, v, T


def lattice_point(X, k) -> Vec2:
    """``k1 X1 + k2 X2`` exactly (Fractions); ``X = [X1, X2]``, ``k = (k1, k2)``."""
    x1, x2 = _basis(X)
    k1, k2 = int(k[0]), int(k[1])
    return (k1 * x1[0] + k2 * x2[0], k1 * x1[1] + k2 * x2[1])


def _basis(X) -> tuple[Vec2, Vec2]:
    if hasattr(X, "tolist"):
        X = X.tolist()
    X = list(X)
    if len(X) != 2:
        raise ValueError(f"X must hold two basis vectors [X1, X2], got {len(X)}")
    return _vec(X[0], "X1"), _vec(X[1], "X2")


def closest_lattice_point(X, target) -> tuple[int, int]:
    """Exact closest vector: integers ``(k1, k2)`` minimising
    ``|k1 X1 + k2 X2 - target|`` over ``Z^2``.

    ``X = [X1, X2]`` must be linearly independent (Fractions/ints/floats, read
    exactly); ``target`` is a 2-D point (floats read at their exact value).
    Ties (several closest points) are broken deterministically: the smallest
    ``(a2, a1)`` in reduced-basis coordinates.

    Method and proof of the search neighbourhood.  Reduce ``X`` by
    :func:`lagrange_gauss_reduce` to ``(r1, r2)`` and write
    ``target = c1 r1 + c2 r2`` (exact).  Let ``v = a1 r1 + a2 r2`` be a closest
    point and ``e = target - v = x r1 + y r2`` (``x = c1 - a1``, ``y = c2 - a2``).
    (i) ``|e| <= |target - babai|`` where ``babai = round(c1) r1 + round(c2) r2``,
    so ``|e| <= (|r1| + |r2|) / 2 <= |r2|``.  (ii) The distance of ``e`` from
    the line ``R r1`` is ``|y| |r2| sin(angle(r1, r2))`` and reduction gives
    ``|cos| <= 1/2``, so ``|e| >= |y| |r2| sqrt(3)/2``.  Together
    ``|y| <= 2/sqrt(3) < 1.16``: ``a2`` is one of the at most three integers in
    ``(c2 - 1.16, c2 + 1.16)``; we scan ``floor(c2) - 1 .. ceil(c2) + 1``.  For
    each fixed ``a2`` the best ``a1`` minimises a 1-D convex quadratic whose
    real minimiser is ``c1 + (c2 - a2) <r1,r2>/|r1|^2``; its floor and ceiling
    are both tried.  Every candidate is compared by exact squared distance, so
    the result is exactly optimal.  Returns the coefficients in the *given*
    basis: ``(k1, k2) = T (a1, a2)``.
    """
    x1, x2 = _basis(X)
    t = _vec(target, "target")
    r1, r2, T = lagrange_gauss_reduce(x1, x2)
    det = _det(r1, r2)
    c1 = _det(t, r2) / det  # Cramer: t = c1 r1 + c2 r2
    c2 = _det(r1, t) / det
    n11, n12 = _dot(r1, r1), _dot(r1, r2)
    best = None
    for a2 in range(math.floor(c2) - 1, math.ceil(c2) + 2):
        m = c1 + (c2 - a2) * n12 / n11
        for a1 in {math.floor(m), math.ceil(m)}:
            ex = t[0] - a1 * r1[0] - a2 * r2[0]
            ey = t[1] - a1 * r1[1] - a2 * r2[1]
            key = (ex * ex + ey * ey, a2, a1)
            if best is None or key < best:
                best = key
    _, a2, a1 = best
    return (T[0][0] * a1 + T[0][1] * a2, T[1][0] * a1 + T[1][1] * a2)


def mesh_area(X) -> Fraction:
    """The paper's ``Delta``: ``|det[X1 X2]|`` (area of a fundamental cell),
    exact; ``X = [X1, X2]``.  Zero for a degenerate pair."""
    x1, x2 = _basis(X)
    return abs(_det(x1, x2))
