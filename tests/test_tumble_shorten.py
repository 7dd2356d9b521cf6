"""Tests of the short planner (:mod:`planning.tumbling.shorten`): regimes,
optimality against brute-force enumeration on the regular solids, exactness of
the returned effects, the effort budget, and near-tame parts."""
from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from kernels.planar import wrap_angle_np
from planning.tumbling.analysis import build_analysis
from planning.tumbling.effort import Effort
from planning.tumbling.motions import Motion
from planning.tumbling.planner import analyze_polyhedron
from planning.tumbling.shorten import ShortPlanner
from tests.polyhedra import box, example, noisy, non_backtracking_words


def planner(V, com=None, **kw):
    return ShortPlanner(analyze_polyhedron(V, com), **kw)


def shortest_length(table, target: Motion, face: int, up_to: int, scale: float) -> int:
    """Brute force: the fewest tumbles reaching ``target`` on ``face`` (or up_to + 1)."""
    if face == 0 and abs(target.z) < 1e-9 * scale and abs(wrap_angle_np(target.angle)) < 1e-9:
        return 0
    for w in non_backtracking_words(table, 0, up_to):
        if w[-1] != face:
            continue
        m = table.word_motion(0, w)
        if abs(m.z - target.z) < 1e-9 * scale and abs(wrap_angle_np(m.angle - target.angle)) < 1e-9:
            return len(w)
    return up_to + 1


def test_regimes():
    assert planner(*example("cube")).regime == "exact_lattice"
    assert planner(box(0.1, 0.1 * math.sqrt(2), 0.1 * math.sqrt(3))).regime == "exact_heading"
    assert planner(*example("irregular_polyhedron")).regime == "dense"


@pytest.mark.parametrize("name", ["cube", "tetrahedron", "octahedron"])
def test_short_plans_are_optimal_on_the_regular_solids(name):
    """Goals reached by random walks: the short plan is exact and no word of
    fewer tumbles reaches the goal (brute force over all walks)."""
    V, com = example(name)
    A = analyze_polyhedron(V, com)
    SP = ShortPlanner(A)
    rng = np.random.default_rng(7)
    for _ in range(6):
        w, f = [], 0
        for _ in range(int(rng.integers(2, 9))):
            f = int(rng.choice(A.table.neighbors[f]))
            w.append(f)
        M = A.table.word_motion(0, w)
        res = SP.plan(M, f, 1e-9)
        assert res is not None and res.exhausted is None
        assert (res.word[-1] if res.word else 0) == f
        m = A.table.word_motion(0, res.word)
        assert m == res.motion and res.error == max(res.orientation_residual, res.position_residual)
        assert res.error < 1e-12 * A.size + 1e-15
        assert res.core_length + res.translation_length == len(res.word)
        n = len(res.word)
        assert shortest_length(A.table, M, f, n - 1, A.size) == n  # nothing shorter exists


def test_dense_plans_are_within_eps_and_exact_effects():
    V, com = example("irregular_polyhedron")
    SP = planner(V, com)
    rng = np.random.default_rng(1)
    for _ in range(3):
        M = Motion(rng.uniform(-3, 3), complex(*rng.uniform(-0.3, 0.3, 2)))
        G = int(rng.integers(SP.A.polyhedron.n_faces))
        res = SP.plan(M, G, 1e-2)
        assert res.error <= 1e-2 and (res.word[-1] if res.word else 0) == G
        m = SP.table.word_motion(0, res.word)
        assert abs(m.z - M.z) == pytest.approx(res.position_residual, abs=1e-15)
        assert abs(wrap_angle_np(m.angle - M.angle)) == pytest.approx(res.orientation_residual,
                                                                      abs=1e-15)


def test_effort_is_deterministic_and_bounded():
    V, com = example("irregular_polyhedron")
    A = build_analysis(V, com)  # a fresh analysis: no cached tables
    M, G = Motion(0.5, 0.2 - 0.1j), 3
    e1 = Effort.unlimited()
    sp1 = ShortPlanner(A, effort=e1)
    e1.charge_once(sp1, sp1.cost, "short-plan tables")
    r1 = sp1.plan(M, G, 1e-2, effort=e1)
    e2 = Effort.unlimited()  # the same planner again: cached tables, same charges
    e2.charge_once(sp1, sp1.cost, "short-plan tables")
    r2 = sp1.plan(M, G, 1e-2, effort=e2)
    assert r1.word == r2.word and e1.used == e2.used and e1.by_stage == e2.by_stage
    # a budget that runs out inside plan(): the best plan so far, flagged
    e3 = Effort(limit=sp1.cost + 2000, time_limit=None)
    e3.charge_once(sp1, sp1.cost, "short-plan tables")
    r3 = sp1.plan(M, G, 1e-2, effort=e3)
    assert r3 is not None and r3.exhausted is not None and e3.exhausted is not None
    # and building the tables within too small a budget stops early, nothing half-built is kept
    from planning.tumbling.effort import BudgetExhausted
    with pytest.raises(BudgetExhausted):
        ShortPlanner(A, effort=Effort(limit=1000, time_limit=None))


def test_near_tame_cube_plans_on_its_rational_model():
    V = np.array(list(itertools.product([-0.5, 0.5], repeat=3)))
    Vn = noisy(V, 1e-9, 2)
    A = analyze_polyhedron(Vn, tau_v=1e-8)
    tame, exact = ShortPlanner(A), ShortPlanner(A, at_tolerance=False)
    assert tame.near_tame and tame.regime == "exact_lattice"
    assert not exact.near_tame and exact.regime == "dense"
    ideal = ShortPlanner(analyze_polyhedron(V))
    M = Motion(0.0, -3 + 1j)
    r_ideal = ideal.plan(M, 0, 1e-6)
    r_tame = tame.plan(M, 0, 1e-6)
    assert r_ideal.error < 1e-12 and r_tame.error < 1e-7
    assert len(r_tame.word) <= len(r_ideal.word)
    assert tame.lattice.spanned and tame.lattice.issues == 0
