"""Tests of walk enumeration, loops and cores of the short planner
(:mod:`planning.tumbling.walks`, :mod:`~planning.tumbling.loops`,
:mod:`~planning.tumbling.cores`, :mod:`~planning.tumbling.words` lengths),
against brute-force enumeration on small cases."""
from __future__ import annotations

import math

import numpy as np
import pytest

from kernels.planar import wrap_angle_np
from planning.tumbling.cores import RANK_DECIMALS, CoreIndex
from planning.tumbling.effort import BudgetExhausted, Effort
from planning.tumbling.loops import LoopFinder, LoopTolerances
from planning.tumbling.planner import analyze_polyhedron
from planning.tumbling.walks import akey, enumerate_walks, grid_key
from planning.tumbling.words import concat, inverse, junction_cancel, loop_power_length, power, purge
from tests.polyhedra import example, non_backtracking_words

TWO_PI = 2 * math.pi


def analysis(name):
    return analyze_polyhedron(*example(name))


def config_key(table, root, w, scale):
    m = table.word_motion(root, w)
    f = w[-1] if w else root
    return (f, int(akey(np.array([m.angle]))[0]), round(m.z.real / (1e-9 * scale)),
            round(m.z.imag / (1e-9 * scale)))


# ---------------------------------------------------------------- walks
@pytest.mark.parametrize("name", ["cube", "tetrahedron", "irregular_polyhedron"])
def test_enumerated_walks_are_the_distinct_configurations_at_their_shortest(name):
    A = analysis(name)
    table, scale = A.table, A.size
    depth = 4
    W = enumerate_walks(table, 0, 10**6, 1e-9 * scale, max_depth=depth)
    assert W.cost >= len(W)
    brute = {}
    for w in [(), *non_backtracking_words(table, 0, depth)]:
        k = config_key(table, 0, w, scale)
        brute[k] = min(brute.get(k, depth + 1), len(w))
    got = {}
    for i in range(len(W)):
        w = W.word(i)
        assert len(w) == W.depth[i] and (w[-1] if w else 0) == W.face[i]
        m = table.word_motion(0, w)
        assert abs(m.z - W.z[i]) < 1e-12 * scale
        assert abs(wrap_angle_np(m.angle - W.ang[i])) < 1e-12
        got[config_key(table, 0, w, scale)] = len(w)
    assert got == brute  # every configuration once, by one of its shortest walks


def test_walk_budget_and_effort():
    A = analysis("octahedron")
    W = enumerate_walks(A.table, 0, 100, 1e-9 * A.size)
    assert len(W) <= 100 and np.all(np.diff(W.depth) >= 0)  # breadth first
    e = Effort(limit=50, time_limit=None)
    with pytest.raises(BudgetExhausted) as exc:
        enumerate_walks(A.table, 0, 10_000, 1e-9 * A.size, effort=e)
    assert exc.value.stage == "walk enumeration" and e.used == 0  # consulted, not charged


def test_heading_keys():
    a = np.array([0.1, 0.1 + TWO_PI, -TWO_PI + 0.1, 0.1 + 3e-9])
    k = akey(a)
    assert k[0] == k[1] == k[2] != k[3]
    # a rotation grid of step pi/2 with per-face offsets: noise below half a step is keyed away
    key = grid_key(math.pi / 2, np.array([0.0, 0.3]))
    noisy = np.array([math.pi / 2 + 2e-8, math.pi / 2 - 3e-8, 0.3 + math.pi - 1e-8, 0.3 + math.pi])
    faces = np.array([0, 0, 1, 1])
    out = key(noisy, faces)
    assert out[0] == out[1] == akey(np.array([math.pi / 2]))[0] and out[2] == out[3]


# ---------------------------------------------------------------- word lengths
@pytest.mark.parametrize("name", ["cube", "octahedron"])
def test_loop_power_length_matches_purge(name):
    A = analysis(name)
    rng = np.random.default_rng(3)
    for _ in range(12):
        w, f = [], 0
        for _ in range(int(rng.integers(1, 9))):
            f = int(rng.choice(A.table.neighbors[f]))
            w.append(f)
        loop = purge(tuple(w) + inverse(A.transit_paths[f], 0), 0)  # back along L_f
        if not loop:
            continue
        assert loop[-1] == 0
        c = junction_cancel(loop, 0)
        for n in range(-3, 4):
            assert len(purge(power(loop, n, 0), 0)) == loop_power_length(len(loop), c, n)


# ---------------------------------------------------------------- loops
@pytest.mark.parametrize("name", ["cube", "irregular_polyhedron"])
def test_translation_and_rotation_loops_are_what_they_claim(name):
    A = analysis(name)
    W = enumerate_walks(A.table, 0, 3000, 1e-9 * A.size)
    tol = LoopTolerances.exact(A.size)
    finder = LoopFinder(A.table, 0, W, tol, lambda a, f: akey(a))
    pool = finder.pool()
    s_idx, a_idx, tc, lenb = pool
    assert np.all(np.diff(lenb) >= 0) and np.all(np.abs(tc) > tol.zero)
    gens = finder.translation_loops(pool)
    assert gens
    for g in gens:
        m = A.table.word_motion(0, g.word)
        assert g.word[-1] == 0 and g.length == len(g.word)
        assert abs(wrap_angle_np(m.angle)) <= 1e-9 and abs(m.z - g.t) < 1e-15 * A.size + 1e-18
        assert g.cancel == junction_cancel(g.word, 0)
    for i, g in enumerate(gens):  # distinct up to sign
        assert all(abs(g.t - h.t) >= tol.zero and abs(g.t + h.t) >= tol.zero for h in gens[i + 1:])
    rots = finder.rotation_loops([r["word"] for r in A.rotation_generators])
    angles = [a for _, a, _ in rots]
    assert rots and len(set(np.round(np.abs(angles), 9))) == len(rots)
    for w, a, n in rots:
        m = A.table.word_motion(0, w)
        assert w[-1] == 0 and n == len(w) and abs(wrap_angle_np(m.angle - a)) < 1e-12 and abs(a) > 1e-9
    assert finder.cost > 0


# ---------------------------------------------------------------- cores
def test_exact_heading_cores_turn_by_the_heading_and_end_on_the_goal_face():
    A = analysis("cube")
    W = enumerate_walks(A.table, 0, 3000, 1e-9 * A.size)
    B = enumerate_walks(A.table, 3, 2000, 1e-9 * A.size)
    idx = CoreIndex(W, lambda a, f: akey(a), rho=10.0)
    from planning.tumbling.motions import Motion
    M = Motion(math.pi / 2, 0.3 + 0.1j)
    h = A.development[3][2] + math.pi  # a reachable heading of face 3
    cores = idx.exact_heading(B, M, h)
    # best first: estimates compared at RANK_DECIMALS (noise-level differences tie), then walk index
    assert cores and len(cores) <= 24
    assert cores == sorted(cores, key=lambda c: (round(c[0], RANK_DECIMALS), c[1], c[2]))
    for est, ia, ib in cores:
        w = purge(concat(W.word(ia), inverse(B.word(ib), 3)), 0)
        assert (w[-1] if w else 0) == 3
        m = A.table.word_motion(0, w)
        assert abs(wrap_angle_np(m.angle - h)) < 1e-9
        assert est >= len(w)  # the estimate counts the unpurged core plus translation
    # brute force: no core of two depth-<=2 walks with that heading is missed by the index
    short = [w for w in idx.short(B, 0, 3) if abs(wrap_angle_np(A.table.word_motion(0, w).angle - h)) < 1e-9]
    assert short


def test_dense_cores_are_within_eta():
    A = analysis("irregular_polyhedron")
    W = enumerate_walks(A.table, 0, 3000, 1e-9 * A.size)
    B = enumerate_walks(A.table, 2, 2000, 1e-9 * A.size)
    idx = CoreIndex(W, lambda a, f: akey(a), rho=5.0)
    from planning.tumbling.motions import Motion
    M = Motion(1.0, 0.1 - 0.2j)
    e = Effort.unlimited()
    cores = idx.dense(B, M, 0.05, effort=e)
    assert cores and e.used > 0
    for est, ia, ib in cores:
        w = purge(concat(W.word(ia), inverse(B.word(ib), 2)), 0)
        m = A.table.word_motion(0, w)
        assert abs(wrap_angle_np(m.angle - M.angle)) <= 0.05 + 1e-12
    # the chunked matching gives the same cores as one pass (brute force over all pairs)
    best = []
    for ia in range(len(W)):
        for ib in np.flatnonzero(B.face == W.face[ia]):
            ang = W.ang[ia] - B.ang[ib]
            if abs(wrap_angle_np(ang - M.angle)) <= 0.05:
                t = M.z - (W.z[ia] - np.exp(1j * ang) * B.z[ib])
                best.append(W.depth[ia] + B.depth[ib] + 5.0 * abs(t))
    assert sorted(best)[0] == pytest.approx(cores[0][0], rel=1e-12)
