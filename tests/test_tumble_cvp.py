"""Tests of the translation and rotation decompositions of the short planner
(:mod:`planning.tumbling.cvp`, :mod:`~planning.tumbling.translation_dense`,
:mod:`~planning.tumbling.translation_lattice`, :mod:`~planning.tumbling.rotation_table`)
against exact arithmetic (sympy / Fractions) and brute-force enumeration."""
from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
import sympy

from planning.tumbling.cvp import CVPSolver, Sumset, lll_reduce
from planning.tumbling.effort import BudgetExhausted, Effort
from planning.tumbling.loops import Gen
from planning.tumbling.rotation_table import RotationTables
from planning.tumbling.translation_dense import DenseLoops
from planning.tumbling.translation_lattice import DIJKSTRA_R, LatticeLoops


# ---------------------------------------------------------------- LLL
@pytest.mark.parametrize("seed", range(4))
def test_lll_is_unimodular_size_reduced_and_lovasz(seed):
    rng = np.random.default_rng(seed)
    n = 6
    B = rng.normal(size=(n, n + 2)) * rng.uniform(0.1, 10, size=(n, 1))
    Bred, T = lll_reduce(B, delta=0.99)
    assert abs(sympy.Matrix(T.tolist()).det()) == 1  # exact: unimodular
    np.testing.assert_allclose(Bred, np.array(T, dtype=float) @ B, atol=1e-9 * np.abs(B).max())
    # Gram-Schmidt of the result, exactly in float64 by hand
    Q = np.zeros_like(Bred)
    mu = np.zeros((n, n))
    for i in range(n):
        Q[i] = Bred[i]
        for j in range(i):
            mu[i, j] = Bred[i] @ Q[j] / (Q[j] @ Q[j])
            Q[i] = Q[i] - mu[i, j] * Q[j]
    assert np.all(np.abs(mu[np.tril_indices(n, -1)]) <= 0.5 + 1e-9)
    for k in range(1, n):
        assert Q[k] @ Q[k] >= (0.99 - mu[k, k - 1] ** 2) * (Q[k - 1] @ Q[k - 1]) - 1e-9


def test_lll_respects_the_effort_budget():
    rng = np.random.default_rng(9)
    B = rng.normal(size=(12, 14)) * np.logspace(0, 6, 12)[:, None]
    with pytest.raises(BudgetExhausted):
        lll_reduce(B, effort=Effort(limit=10, time_limit=None))
    stats = {}
    lll_reduce(B, stats=stats)
    assert stats["cost"] >= 12 * 12


# ---------------------------------------------------------------- CVP and sumsets
def test_cvp_recovers_exact_integer_combinations():
    rng = np.random.default_rng(1)
    vecs = [complex(*rng.normal(size=2)) for _ in range(5)]
    costs = [int(c) for c in rng.integers(4, 12, 5)]
    solver = CVPSolver(vecs, costs, weight=1e9)
    assert solver.cost > 0
    for _ in range(5):
        c = rng.integers(-3, 4, 5)
        t = complex(sum(ci * v for ci, v in zip(c, vecs)))
        coef = solver.solve(t)
        assert all(isinstance(x, int) for x in coef)
        assert abs(sum(ci * v for ci, v in zip(coef, vecs)) - t) < 1e-9


def test_sumset_query_is_the_brute_force_optimum():
    rng = np.random.default_rng(2)
    n = 5
    vecs = [complex(*rng.normal(size=2)) for _ in range(n)]
    costs = [float(c) for c in rng.integers(3, 9, n)]
    S = Sumset(vecs, costs, [{i: 1} for i in range(n)], r=2, scale=1.0)
    combos = list(itertools.product(range(-2, 3), repeat=n))
    allv = np.array([sum(c * v for c, v in zip(cs, vecs)) for cs in combos])
    allc = np.array([sum(abs(c) * k for c, k in zip(cs, costs)) for cs in combos])
    for _ in range(6):
        r = complex(*rng.normal(size=2)) * 2
        tol = 0.3
        coef, vec, cost, err = S.query(r, tol, k=len(S.halves[0][2]))  # k = all: exact
        assert abs(sum(m * vecs[b] for b, m in coef.items()) - vec) < 1e-12
        within = np.abs(allv - r) <= tol
        if within.any():
            assert err <= tol and cost == pytest.approx(allc[within].min())
        else:
            assert err == pytest.approx(np.abs(allv - r).min())
    small = S.smallest_nonzero(5)
    norms = [abs(v) for v, _, _ in small]
    assert norms == sorted(norms) and norms[0] > 0
    assert norms[0] == pytest.approx(np.abs(allv[np.abs(allv) > 1e-12]).min(), rel=1e-9)
    for v, _, coef in small:
        assert abs(sum(m * vecs[b] for b, m in coef.items()) - v) < 1e-12


def _gens(vecs, lengths):
    return [Gen(word=(1, 0) * (n // 2), t=complex(v), length=n, cancel=0) for v, n in zip(vecs, lengths)]


def test_dense_decomposition_reaches_tolerance_and_is_cheap():
    rng = np.random.default_rng(4)
    vecs = [0.1, 0.1j * math.sqrt(2), 0.07 + 0.05j * math.sqrt(3), 0.013 - 0.02j * math.pi]
    D = DenseLoops(_gens(vecs, [6, 8, 10, 12]), scale=0.1)
    e = Effort.unlimited()
    for _ in range(4):
        t = complex(*rng.uniform(-0.5, 0.5, 2))
        coef, cost, err = D.decompose(t, 1e-3, effort=e)
        got = sum(c * vecs[b] for b, c in coef.items())
        assert abs(got - t) == pytest.approx(err, abs=1e-15) and err <= 1e-3
        assert cost == sum(abs(c) * [6, 8, 10, 12][b] for b, c in coef.items())
    assert e.used > 0 and "dense translations (LLL)" in e.by_stage
    # a coarse fallback within a length cap: the most accurate affordable combination
    t = 0.33 + 0.21j
    coef = D.coarse(t, 40)
    assert sum(abs(c) * [6, 8, 10, 12][b] for b, c in coef.items()) <= 40
    assert abs(t - sum(c * vecs[b] for b, c in coef.items())) <= abs(t)


# ---------------------------------------------------------------- exact lattice
def test_lattice_loops_decompose_exactly_and_optimally():
    b1, b2 = 0.2 + 0j, 0.05 + 0.15j
    coords = [(2, 0), (0, 3), (1, 1), (3, -2)]
    lengths = [5, 7, 4, 9]
    gens = _gens([a * b1 + b * b2 for a, b in coords], lengths)
    L = LatticeLoops(((b1.real, b1.imag), (b2.real, b2.imag)), gens, (np.zeros(0), np.zeros(0)),
                     lambda s, a: None, lambda w: None)
    assert L.spanned and L.issues == 0 and sorted(L.ncoords) == sorted(
        L.coords(a * b1 + b * b2) for a, b in coords)
    # brute force: cheapest representation of small lattice vectors (bounded counts)
    cheapest = {}
    for cs in itertools.product(range(-4, 5), repeat=4):
        k = tuple(sum(c * L.ncoords[i][j] for i, c in enumerate(cs)) for j in range(2))
        cost = sum(abs(c) * L.gens[i].length for i, c in enumerate(cs))
        cheapest[k] = min(cheapest.get(k, math.inf), cost)
    for k in [(0, 1), (1, 0), (3, 4), (-2, 5), (7, -6)]:
        coef, cost = L.decompose(k)
        got = tuple(sum(c * L.ncoords[i][j] for i, c in coef.items()) for j in range(2))
        assert got == k
        assert cost == sum(abs(c) * L.gens[i].length for i, c in coef.items())
        if max(abs(k[0]), abs(k[1])) <= DIJKSTRA_R and k in cheapest:
            assert cost <= cheapest[k]
    # far away: a pair of loops for the bulk, still exact
    coef, cost = L.decompose((500, -300))
    assert tuple(sum(c * L.ncoords[i][j] for i, c in coef.items()) for j in range(2)) == (500, -300)
    assert L.coords(0.1 + 0.1j) is None  # off the lattice


# ---------------------------------------------------------------- rotation table
def test_rotation_table_is_the_cheapest_product():
    a1, a2 = 0.7, math.sqrt(2) / 3
    loops = [((1, 2, 0), a1, 3), ((3, 4, 5, 0), a2, 4)]  # loop words at face 0
    R = RotationTables(loops, 0)
    e = Effort.unlimited()
    tab = R.table(2 * math.pi / 256, effort=e)
    assert tab.nb == 256 and e.by_stage["rotation table"] == tab.cost
    # brute force over counts: the cheapest product landing in each bin
    best = {}
    for i, j in itertools.product(range(-40, 41), repeat=2):
        cost = 3 * abs(i) + 4 * abs(j)
        b = int(tab.bin_of(np.array([i * a1 + j * a2]))[0])
        best[b] = min(best.get(b, math.inf), cost)
    reached = np.flatnonzero(tab.dist < np.iinfo(np.int64).max)
    assert len(reached) >= 250 and all(int(b) in best for b in reached)
    ratios = []
    for b in reached:
        assert tab.dist[b] >= best[int(b)]  # a real product: never cheaper than the optimum
        ratios.append(tab.dist[b] / max(best[int(b)], 1))
        # the exact angle is the sum of the loops along the predecessor chain
        total, cb, cost = 0.0, int(b), 0
        while tab.pbin[cb] >= 0:
            code = int(tab.pcode[cb])
            total += math.copysign(loops[abs(code) - 1][1], code)
            cost += loops[abs(code) - 1][2]
            cb = int(tab.pbin[cb])
        assert abs(math.remainder(total - tab.ang[b], 2 * math.pi)) < 1e-9 and cost == tab.dist[b]
        assert int(tab.bin_of(np.array([tab.ang[b]]))[0]) == b
    # Dial over bins keeps one exact angle per bin, so it is near, not at, the optimum
    assert np.mean(ratios) <= 1.15
    for target in (0.3, -2.0, 3.0):
        w, ang = R.word(target, 0.02, effort=e)
        assert w and w[-1] == 0 and abs(math.remainder(ang - target, 2 * math.pi)) <= 0.02
    assert R.word(1e-4, 0.01) == ((), 0.0)
