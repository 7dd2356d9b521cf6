"""The pose LP (Akella & Mason section 4.2) and its closed form, against cvxpy
(LP and MILP), brute-force enumeration of column pairs, and the JAX twin."""
from __future__ import annotations

import itertools
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from planning.pushing import pose_lp

pytestmark = pytest.mark.float64  # calls kernels on float64 arrays directly

K_MAX = 12
REL = 1e-7


def _instance(rng):
    """A random LP: unit columns (angles), mask, merged flags, target.

    Mixes uniform column sets, clustered ones (cone narrower than pi: many
    infeasible targets), sets with exactly antiparallel pairs and duplicates,
    targets along a column, tiny/zero targets.
    """
    k = int(rng.integers(1, K_MAX + 1))
    kind = rng.choice(["uniform", "clustered", "antipodal"], p=[0.5, 0.3, 0.2])
    if kind == "uniform":
        ang = rng.uniform(-math.pi, math.pi, k)
    elif kind == "clustered":
        ang = rng.uniform(-1.0, 1.0) * math.pi + rng.uniform(-0.5, 0.5, k) * rng.uniform(0.2, 2.5)
    else:
        ang = rng.uniform(-math.pi, math.pi, k)
        for i in range(0, k - 1, 3):
            ang[i + 1] = ang[i] + math.pi
        if k >= 3:
            ang[-1] = ang[0]          # a duplicate column
    mask = rng.random(k) < rng.uniform(0.3, 1.0)
    merged = rng.random(k) < 0.3
    u = rng.random()
    scale = 10 ** rng.uniform(-3, 1)
    if u < 0.04:
        target = np.zeros(2)
    elif u < 0.12:
        j = int(rng.integers(k))
        target = scale * np.array([math.cos(ang[j]), math.sin(ang[j])])
    else:
        target = rng.normal(size=2) * scale
    return ang, mask, merged, target


def _instances(seed, count):
    rng = np.random.default_rng(seed)
    return [_instance(rng) for _ in range(count)]


def _check_weights(sol, ang, mask, target):
    w = sol.weights
    assert np.all(w >= 0.0)
    assert np.all(w[~np.asarray(mask)] == 0.0)
    cols = np.stack([np.cos(ang), np.sin(ang)], axis=1)
    scale = max(1.0, float(np.hypot(*target)))
    np.testing.assert_allclose(w @ cols, target, atol=1e-9 * scale)
    assert sol.cost == pytest.approx(float(w.sum()), rel=1e-12, abs=1e-15)


def _brute_force(ang, mask, merged, target, objective="distance"):
    """Optimum over every single column and every pair of columns (a basic
    optimum of a 2-row LP has at most two non-zero columns)."""
    idx = np.flatnonzero(mask)
    nt = float(np.hypot(*target))
    if nt <= pose_lp.ZERO_TARGET:
        return True, 0.0, 0
    best = None
    cols = {i: np.array([math.cos(ang[i]), math.sin(ang[i])]) for i in idx}

    def consider(used, cost):
        nonlocal best
        npush = sum(1 for i, w in used if w > pose_lp.DROP and not merged[i])
        key = (npush, cost) if objective == "pushes" else (cost,)
        if best is None or key < best[0]:
            best = (key, cost, npush)

    for i in idx:
        along = float(cols[i] @ target)
        if along > 0 and abs(float(cols[i][0] * target[1] - cols[i][1] * target[0])) <= 1e-12 * nt:
            consider([(i, along)], along)
    for i, j in itertools.combinations(idx, 2):
        a = np.stack([cols[i], cols[j]], axis=1)
        det = np.linalg.det(a)
        if abs(det) < 1e-9:
            continue
        x = np.linalg.solve(a, target)
        if np.all(x >= -1e-12 * nt):
            consider([(i, x[0]), (j, x[1])], float(max(x[0], 0) + max(x[1], 0)))
    if best is None:
        return False, math.inf, 0
    return True, best[1], best[2]


# --------------------------------------------------------------------------
# closed form against cvxpy (the slow part: ~1000 LPs)
# --------------------------------------------------------------------------
@pytest.mark.slow
def test_closed_form_matches_cvxpy_lp():
    insts = _instances(0, 1000)
    n_feas = n_infeas = 0
    for ang, mask, merged, target in insts:
        cf = pose_lp.solve_closed_form(ang, mask, merged, target)
        ref = pose_lp.solve_cvxpy(ang, mask, merged, target)
        assert cf.feasible == ref.feasible, (ang, mask, target, cf, ref)
        if cf.feasible:
            n_feas += 1
            assert cf.cost == pytest.approx(ref.cost, rel=REL, abs=1e-12), (ang, mask, target)
            _check_weights(cf, ang, mask, target)
        else:
            n_infeas += 1
            assert math.isinf(cf.cost)
    assert n_feas > 300 and n_infeas > 200  # both verdicts are exercised


def test_cvxpy_paper_form_equals_xy_form():
    for ang, mask, merged, target in _instances(1, 60):
        a = pose_lp.solve_cvxpy(ang, mask, merged, target, paper_form=True)
        b = pose_lp.solve_cvxpy(ang, mask, merged, target, paper_form=False)
        assert a.feasible == b.feasible
        if a.feasible:
            assert a.cost == pytest.approx(b.cost, rel=REL, abs=1e-12)


# --------------------------------------------------------------------------
# closed form against brute force (cheap: many instances, both objectives)
# --------------------------------------------------------------------------
@pytest.mark.parametrize("objective", ["distance", "pushes"])
def test_closed_form_matches_brute_force(objective):
    n_feas = 0
    for ang, mask, merged, target in _instances(2, 3000):
        cf = pose_lp.solve_closed_form(ang, mask, merged, target, objective)
        ok, cost, npush = _brute_force(ang, mask, merged, target, objective)
        assert cf.feasible == ok, (ang, mask, merged, target)
        if ok:
            n_feas += 1
            assert cf.cost == pytest.approx(cost, rel=1e-9, abs=1e-13), (ang, mask, merged, target)
            if objective == "pushes":
                assert cf.pushes == npush, (ang, mask, merged, target)
            _check_weights(cf, ang, mask, target)
            assert cf.pushes == int(np.sum((cf.weights > pose_lp.DROP) & ~(np.asarray(merged) & mask)))
    assert n_feas > 1000


def test_closed_form_hand_cases():
    # target between two orthogonal columns: weights are its coordinates
    s = pose_lp.solve_closed_form([0.0, math.pi / 2], [True, True], [False, False], [3.0, 4.0])
    assert s.feasible and s.cost == pytest.approx(7.0) and s.pushes == 2
    np.testing.assert_allclose(s.weights, [3.0, 4.0], atol=1e-12)
    # a third column along the target is cheaper (|T| = 5)
    s = pose_lp.solve_closed_form([0.0, math.pi / 2, math.atan2(4, 3)], [True] * 3, [False] * 3, [3.0, 4.0])
    assert s.cost == pytest.approx(5.0) and s.pushes == 1
    # ...unless it is masked out
    s = pose_lp.solve_closed_form([0.0, math.pi / 2, math.atan2(4, 3)], [True, True, False], [False] * 3,
                                  [3.0, 4.0])
    assert s.cost == pytest.approx(7.0)
    # columns in a half plane cannot reach a target behind them
    s = pose_lp.solve_closed_form([0.0, 0.5, 1.0], [True] * 3, [False] * 3, [-1.0, -0.1])
    assert not s.feasible and math.isinf(s.cost)
    # antiparallel pair: only targets along the line are reachable
    s = pose_lp.solve_closed_form([0.0, math.pi], [True, True], [False, False], [0.0, 1.0])
    assert not s.feasible
    s = pose_lp.solve_closed_form([0.0, math.pi], [True, True], [False, False], [-2.0, 0.0])
    assert s.feasible and s.cost == pytest.approx(2.0)
    # zero target: feasible at no cost even with no columns
    s = pose_lp.solve_closed_form([0.0], [False], [False], [0.0, 0.0])
    assert s.feasible and s.cost == 0.0 and s.pushes == 0
    # "pushes": a merged (free) pair beats a shorter single pushed column
    ang = [math.radians(60), math.radians(-60), 0.0]
    s_d = pose_lp.solve_closed_form(ang, [True] * 3, [True, True, False], [1.0, 0.0], "distance")
    s_p = pose_lp.solve_closed_form(ang, [True] * 3, [True, True, False], [1.0, 0.0], "pushes")
    assert s_d.cost == pytest.approx(1.0) and s_d.pushes == 1
    assert s_p.pushes == 0 and s_p.cost == pytest.approx(2.0)
    with pytest.raises(ValueError, match="objective"):
        pose_lp.solve_closed_form(ang, [True] * 3, [False] * 3, [1.0, 0.0], "time")


# --------------------------------------------------------------------------
# JAX twin, vmapped over the whole batch (one compile per objective)
# --------------------------------------------------------------------------
def _padded(insts):
    b = len(insts)
    ang = np.zeros((b, K_MAX))
    mask = np.zeros((b, K_MAX), bool)
    merged = np.zeros((b, K_MAX), bool)
    tgt = np.zeros((b, 2))
    for i, (a, m, g, t) in enumerate(insts):
        k = len(a)
        ang[i, :k], mask[i, :k], merged[i, :k], tgt[i] = a, m, g, t
        ang[i, k:] = np.linspace(-3, 3, K_MAX - k)  # padding columns are masked out
        merged[i, k:] = True
    return ang, mask, merged, tgt


@pytest.mark.parametrize("objective", ["distance", "pushes"])
def test_solve_jax_vmapped_matches_closed_form(objective):
    insts = _instances(3, 2000)
    ang, mask, merged, tgt = _padded(insts)
    fn = jax.jit(jax.vmap(lambda a, m, g, t: pose_lp.solve_jax(a, m, g, t, objective)))
    feas, cost, npush, ia, xa, ib, xb = (np.asarray(v) for v in fn(
        jnp.asarray(ang), jnp.asarray(mask), jnp.asarray(merged), jnp.asarray(tgt)))
    for i, (a, m, g, t) in enumerate(insts):
        cf = pose_lp.solve_closed_form(a, m, g, t, objective)
        assert bool(feas[i]) == cf.feasible, (a, m, g, t)
        if not cf.feasible:
            continue
        assert cost[i] == pytest.approx(cf.cost, rel=1e-9, abs=1e-13)
        assert int(npush[i]) == cf.pushes
        w = np.zeros(K_MAX)
        w[ia[i]] += xa[i]
        w[ib[i]] += xb[i]
        assert np.all(w[len(a):] == 0.0) and np.all(w[:len(a)][~m] == 0.0)
        np.testing.assert_allclose(w[:len(a)], cf.weights, atol=1e-9 * max(1.0, np.hypot(*t)))


# --------------------------------------------------------------------------
# objective="pushes": closed form against the cvxpy MILP
# --------------------------------------------------------------------------
def test_pushes_objective_matches_cvxpy_milp(monkeypatch):
    """Every instance, infeasible ones and those whose optimum needs large
    weights included; the reference never asks the closed form anything."""
    closed_form = pose_lp.solve_closed_form
    rng = np.random.default_rng(4)
    insts = [_instance(rng) for _ in range(240)]
    expected = [(closed_form(*i, "pushes"), closed_form(*i, "distance")) for i in insts]

    def forbidden(*args, **kwargs):
        raise AssertionError("the cvxpy reference called the closed form")

    monkeypatch.setattr(pose_lp, "solve_closed_form", forbidden)
    done = multi = infeasible = 0
    for (ang, mask, merged, target), (cf, dist) in zip(insts, expected):
        ref = pose_lp.solve_cvxpy(ang, mask, merged, target, "pushes")
        assert ref.feasible == cf.feasible, (ang, mask, merged, target)
        if not cf.feasible:
            infeasible += 1
            assert math.isinf(ref.cost)
            continue
        assert cf.pushes == ref.pushes, (ang, mask, merged, target)
        # HiGHS' MIP feasibility tolerance (1e-6 on the equality rows) limits the match
        assert cf.cost == pytest.approx(ref.cost, rel=1e-6, abs=1e-5), (ang, mask, merged, target)
        assert cf.cost >= dist.cost * (1 - 1e-12)
        assert cf.pushes <= dist.pushes
        multi += cf.pushes != dist.pushes
        done += 1
    assert multi >= 5 and infeasible >= 50 and done >= 90  # every kind of instance is there


def test_cvxpy_milp_reports_infeasible():
    """An infeasible instance comes back as infeasible, as for the LP (the
    solver's verdict; big-M comes from the data, not from an optimum)."""
    args = ([0.0, 0.5], [True, True], [False, False], [0.0, -1.0])
    assert not pose_lp.solve_cvxpy(*args, objective="distance").feasible
    sol = pose_lp.solve_cvxpy(*args, objective="pushes")
    assert not sol.feasible and math.isinf(sol.cost)


def test_cvxpy_no_columns_is_infeasible():
    """With every column masked out a non-zero target is unreachable (no
    zero-length variable is handed to the solver)."""
    assert not pose_lp.solve_closed_form([0.3], [False], [False], [1.0, 0.0]).feasible
    sol = pose_lp.solve_cvxpy([0.3], [False], [False], [1.0, 0.0])
    assert not sol.feasible and math.isinf(sol.cost)


def test_cvxpy_milp_big_m():
    """The MILP reference must find the fewest-push optimum.

    Here one push suffices: the free (merged) column 0 plus the non-merged
    column 1, nearly antiparallel to it, reach the target with weights ~200 m
    (checked below); a big-M below that (e.g. one scaled by the distance
    optimum, 0.66 m) would cut the optimum off and return a 2-push plan.
    """
    ang = [0.0, math.pi + 0.0005, -0.3]
    args = (ang, [True] * 3, [True, False, False], [0.0, -0.1])
    cf = pose_lp.solve_closed_form(*args, "pushes")
    assert cf.feasible and cf.pushes == 1
    _check_weights(cf, np.array(ang), np.array([True] * 3), np.array([0.0, -0.1]))
    ref = pose_lp.solve_cvxpy(*args, "pushes")
    assert ref.pushes == 1
    assert ref.cost == pytest.approx(cf.cost, rel=1e-6)
