"""Exact tests of planning.lattice (HNF, Lagrange-Gauss, closest vector)."""

from __future__ import annotations

import itertools
import math
import random
from fractions import Fraction as F

import pytest
import sympy
from hypothesis import given, settings
from hypothesis import strategies as st
from sympy.matrices.normalforms import hermite_normal_form as sympy_hnf

from planning.lattice import (
    closest_lattice_point,
    hermite_normal_form,
    lagrange_gauss_reduce,
    lattice_basis,
    lattice_point,
    mesh_area,
)

SETTINGS = settings(derandomize=True, max_examples=150, deadline=None)


def _matmul(A, B):
    return [[sum((A[i][k] * B[k][j] for k in range(len(B))), 0) for j in range(len(B[0]))] for i in range(len(A))]


def _random_matrix(rng: random.Random):
    r = rng.choice([1, 2, 2, 2, 3, 4])
    n = rng.randint(1, 8)
    kind = rng.random()
    lo = rng.choice([2, 5, 30, 1000])
    if kind < 0.55:  # generic
        return [[rng.randint(-lo, lo) for _ in range(n)] for _ in range(r)]
    if kind < 0.85:  # rank-deficient: (r x k)(k x n) with k < r
        k = rng.randint(0, max(0, min(r, n) - 1)) if r > 1 else 0
        if k == 0:
            return [[0] * n for _ in range(r)]
        L = [[rng.randint(-4, 4) for _ in range(k)] for _ in range(r)]
        R = [[rng.randint(-lo, lo) for _ in range(n)] for _ in range(k)]
        return _matmul(L, R)
    # sparse / structured: zero rows, repeated columns
    A = [[rng.choice([0, 0, rng.randint(-lo, lo)]) for _ in range(n)] for _ in range(r)]
    if n > 1:
        j = rng.randrange(n)
        for row in A:
            row[j] = row[0]
    return A


def _check_hnf_shape(H, rank):
    r, n = len(H), len(H[0])
    for j in range(rank, n):
        assert all(H[i][j] == 0 for i in range(r))
    prev = -1
    for j in range(rank):
        piv = next(i for i in range(r) if H[i][j] != 0)
        assert piv > prev and H[piv][j] > 0
        for jj in range(j):
            assert 0 <= H[piv][jj] < H[piv][j]
        for jj in range(j + 1, n):
            assert H[piv][jj] == 0
        prev = piv


def test_hnf_against_sympy_random():
    rng = random.Random(20240531)
    n_deficient = 0
    for _ in range(260):
        A = _random_matrix(rng)
        r, n = len(A), len(A[0])
        H, U = hermite_normal_form(A)
        assert len(U) == n and all(len(row) == n for row in U)
        assert _matmul(A, U) == H
        assert all(isinstance(v, int) for row in U for v in row)
        assert sympy.Matrix(U).det() in (1, -1)
        rank = sympy.Matrix(A).rank()
        n_deficient += rank < min(r, n)
        _check_hnf_shape(H, rank)
        if rank == 0:
            assert all(v == 0 for row in H for v in row)
            continue
        # sympy: pivots rightmost, bottom row first  ->  reverse rows and columns
        S = sympy_hnf(sympy.Matrix(A[::-1]))
        assert S.shape == (r, rank)
        mine = [[H[i][j] for j in range(rank)] for i in range(r)]
        theirs = [[int(S[r - 1 - i, rank - 1 - j]) for j in range(rank)] for i in range(r)]
        assert mine == theirs
    assert n_deficient >= 60


def test_hnf_known_and_kernel():
    H, U = hermite_normal_form([[2, 4, 6], [1, 2, 3]])
    assert H == [[2, 0, 0], [1, 0, 0]]
    # last N - rank columns of U span the integer kernel
    A = [[2, 4, 6], [1, 2, 3]]
    AU = _matmul(A, U)
    assert all(AU[i][j] == 0 for i in range(2) for j in (1, 2))
    H, _ = hermite_normal_form([[0, 0], [0, 0]])
    assert H == [[0, 0], [0, 0]]
    H, U = hermite_normal_form(sympy.Matrix([[3, 5], [1, 2]]))
    assert H == [[1, 0], [0, 1]]
    import numpy as np

    H, U = hermite_normal_form(np.array([[4, 6, 0], [0, 3, 9]], dtype=np.int64))
    assert H == [[2, 0, 0], [0, 3, 0]] and all(type(v) is int for row in H for v in row)
    H, U = hermite_normal_form(np.array([[0.5, 0.25]]))  # floats read exactly -> Fractions
    assert H == [[F(1, 4), 0]]


def test_hnf_rational():
    rng = random.Random(7)
    for _ in range(60):
        n = rng.randint(1, 6)
        A = [[F(rng.randint(-30, 30), rng.randint(1, 12)) for _ in range(n)] for _ in range(2)]
        H, U = hermite_normal_form(A)
        assert _matmul(A, U) == H
        assert sympy.Matrix(U).det() in (1, -1)
        assert all(isinstance(v, F) for row in H for v in row)
        rank = sympy.Matrix([[sympy.Rational(v.numerator, v.denominator) for v in row] for row in A]).rank()
        _check_hnf_shape(H, rank)


def test_lattice_basis_and_mesh_area():
    rng = random.Random(11)
    for _ in range(80):
        n = rng.randint(2, 7)
        V = [(rng.randint(-20, 20), rng.randint(-20, 20)) for _ in range(n)]
        X, U, rank = lattice_basis(V)
        assert rank == sympy.Matrix(V).rank()
        for j in range(n):
            s = (sum(V[i][0] * U[i][j] for i in range(n)), sum(V[i][1] * U[i][j] for i in range(n)))
            assert s == (X[j] if j < rank else (0, 0))
        if rank == 2:
            minors = [V[a][0] * V[b][1] - V[a][1] * V[b][0] for a, b in itertools.combinations(range(n), 2)]
            assert mesh_area(X) == math.gcd(*minors)  # lattice determinant
    X, U, rank = lattice_basis([(F(1, 2), 0), (0, F(1, 3)), (F(1, 4), F(1, 6))])
    assert rank == 2 and mesh_area(X) == F(1, 12)


# ---------------------------------------------------------------- Lagrange-Gauss
frac = st.builds(F, st.integers(-400, 400), st.integers(1, 9))
vec = st.tuples(frac, frac)


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1]


@SETTINGS
@given(vec, vec)
def test_lagrange_gauss(b1, b2):
    det = b1[0] * b2[1] - b1[1] * b2[0]
    if det == 0:
        with pytest.raises(ValueError):
            lagrange_gauss_reduce(b1, b2)
        return
    r1, r2, T = lagrange_gauss_reduce(b1, b2)
    assert T[0][0] * T[1][1] - T[0][1] * T[1][0] in (1, -1)
    assert r1 == (T[0][0] * b1[0] + T[1][0] * b2[0], T[0][0] * b1[1] + T[1][0] * b2[1])
    assert r2 == (T[0][1] * b1[0] + T[1][1] * b2[0], T[0][1] * b1[1] + T[1][1] * b2[1])
    assert _dot(r1, r1) <= _dot(r2, r2)
    assert 2 * abs(_dot(r1, r2)) <= _dot(r1, r1)
    assert mesh_area([r1, r2]) == abs(det)


# ---------------------------------------------------------------- closest vector
def _sqdist(X, k, t):
    p = lattice_point(X, k)
    return (p[0] - t[0]) ** 2 + (p[1] - t[1]) ** 2


def _enumerate_min(X, t):
    """Independent exact CVP: Fincke-Pohst enumeration of every lattice point
    within the distance of a known lattice point (the Babai point of the given
    basis), in the *given* (possibly very skewed) basis."""
    x1, x2 = X
    det = x1[0] * x2[1] - x1[1] * x2[0]
    c1 = (t[0] * x2[1] - t[1] * x2[0]) / det
    c2 = (x1[0] * t[1] - x1[1] * t[0]) / det
    R2 = _sqdist(X, (round(c1), round(c2)), t)
    g11, g12, g22 = _dot(x1, x1), _dot(x1, x2), _dot(x2, x2)
    # |k - c|_G^2 <= R2  =>  (k2 - c2)^2 <= R2 * g11 / det^2
    w2 = math.isqrt(int(R2 * g11 / det**2) + 1) + 1
    best = None
    for k2 in range(math.floor(c2) - w2, math.ceil(c2) + w2 + 1):
        y = c2 - k2
        m = c1 + y * g12 / g11  # minimiser over real k1
        rem = R2 - y * y * det * det / g11
        if rem < 0:
            continue
        w1 = math.isqrt(int(rem / g11) + 1) + 1
        for k1 in range(math.floor(m) - w1, math.ceil(m) + w1 + 1):
            d = _sqdist(X, (k1, k2), t)
            if best is None or d < best:
                best = d
    return best


@SETTINGS
@given(vec, vec, st.tuples(st.floats(-500, 500), st.floats(-500, 500)))
def test_closest_vs_enumeration(b1, b2, t):
    if b1[0] * b2[1] - b1[1] * b2[0] == 0:
        return
    X = [b1, b2]
    k = closest_lattice_point(X, t)
    assert all(isinstance(v, int) for v in k)
    tf = (F(t[0]), F(t[1]))
    assert _sqdist(X, k, tf) == _enumerate_min(X, tf)


def test_closest_brute_window_random():
    """Plain brute force over a provably sufficient coefficient window.

    If ``v`` is closest then ``|t - v| <= d`` (``d`` = distance of the Babai
    point) and ``|k - c|_inf <= ||X^-1||_F d``; the window is that radius, and
    the grid is scanned exactly in scaled integer arithmetic (numpy int64)."""
    import numpy as np

    rng = random.Random(3)
    done = 0
    while done < 150:
        X = [(F(rng.randint(-9, 9), rng.randint(1, 3)), F(rng.randint(-9, 9), rng.randint(1, 3))) for _ in range(2)]
        det = X[0][0] * X[1][1] - X[0][1] * X[1][0]
        if det == 0:
            continue
        t = (F(rng.randint(-2000, 2000), 97), F(rng.randint(-2000, 2000), 89))
        c1 = (t[0] * X[1][1] - t[1] * X[1][0]) / det
        c2 = (X[0][0] * t[1] - X[0][1] * t[0]) / det
        d2 = _sqdist(X, (round(c1), round(c2)), t)
        inv_f2 = sum(v * v for v in (X[0][0], X[0][1], X[1][0], X[1][1])) / det**2
        W = math.isqrt(math.ceil(d2 * inv_f2)) + 2
        if W > 60:
            continue
        D = math.lcm(*(v.denominator for v in (*X[0], *X[1], *t)))
        xi = [[int(v * D) for v in col] for col in X]
        ti = [int(v * D) for v in t]
        a = np.arange(round(c1) - W, round(c1) + W + 1, dtype=np.int64)[:, None]
        b = np.arange(round(c2) - W, round(c2) + W + 1, dtype=np.int64)[None, :]
        ex = a * xi[0][0] + b * xi[1][0] - ti[0]
        ey = a * xi[0][1] + b * xi[1][1] - ti[1]
        brute = int((ex * ex + ey * ey).min())
        k = closest_lattice_point(X, t)
        assert _sqdist(X, k, t) * D * D == brute
        done += 1


def test_closest_examples():
    X = [(1, 0), (0, 1)]
    assert closest_lattice_point(X, (2.4, -3.6)) == (2, -4)
    # very skewed basis of Z x (1/7)Z
    X = [(1, 0), (1000, F(1, 7))]
    k = closest_lattice_point(X, (F(33, 10), F(3, 10)))
    assert lattice_point(X, k) == (3, F(2, 7))
    with pytest.raises(ValueError):
        closest_lattice_point([(1, 2), (2, 4)], (0, 0))
    assert mesh_area([(2, 0), (1, 3)]) == 6
