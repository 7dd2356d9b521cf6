"""Marginal stability (issue 21): an edge whose centre-of-mass foot lies at one
of its ends (within ``kernels.polygon.MARGINAL_FOOT`` of the edge's length).

Such an edge is not stable: flush on the fence, the part balances on the end
vertex with the centre of mass straight above it (an unstable equilibrium).
The exact replay stops there (``PushOutcome.marginal``); the push function of
the push stability diagram resolves it as an arbitrarily small perturbation
does (the part rolls over the vertex to the next edge), so it has no band of
"no stable edge"; the planner never lands a marginal edge.  The resolution is
checked against the exact replay, the numpy oracle and the quasi-static kernel
on parts whose centre of mass is moved a hair off the marginal position.
"""
from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from kernels import polygon as pg
from kernels.push import replay_push
from oracles import push_numpy as oracle
from planning import plan_pose, prepare_part
from planning.pushing.stability import push_stability
from tests.test_quasistatic import sim_many   # its compiled batch (shared in a suite run)

# Edge [0, 1] (along x) has the foot of the centre of mass exactly at vertex 0
# (com x = vertex 0's x); edges [1, 2] and [2, 0] are stable.  Rolling over
# vertex 0 off edge [0, 1] lands edge [2, 0].
MARGINAL = np.array([[0.0, 0.0], [0.2, 0.0], [-0.2, 0.1]])
MARGINAL_COM = np.array([0.0, 0.1 / 3.0])   # the area centroid
ROLL_TO = (2, 0)
# the same part turned by T_ROT rad: rounding puts the foot at +5.6e-18 of the edge
# (before issue 21 the edge counted as stable and the part as nice-stable)
T_ROT = 0.4025641025641026


def _rot(t):
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, -s], [s, c]])


def _hull_edge(part, pair):
    return part.polygon.caller_edge_to_hull(pair)


def _gaps(final_edge) -> list[int]:
    """Lengths of the circular runs of -1 ("no stable edge") in a sampled push function."""
    bad = np.asarray(final_edge) < 0
    if bad.all():
        return [len(bad)]
    k = int(np.argmin(bad))          # start the scan on a good sample
    runs, run = [], 0
    for b in np.roll(bad, -k):
        if b:
            run += 1
        elif run:
            runs.append(run)
            run = 0
    if run:
        runs.append(run)
    return runs


# --------------------------------------------------------------------------
# geometry: a marginal edge is not stable (numpy oracle agrees)
# --------------------------------------------------------------------------
@pytest.mark.float64
@pytest.mark.parametrize("turn", [0.0, T_ROT])
def test_marginal_edge_is_not_stable(turn):
    part = prepare_part(MARGINAL @ _rot(turn).T, _rot(turn) @ MARGINAL_COM)
    m = _hull_edge(part, (0, 1))
    g = part.geom
    assert abs(float(g.foot[m])) <= pg.MARGINAL_FOOT
    assert bool(g.marginal[m]) and not bool(g.stable[m])
    assert np.flatnonzero(np.asarray(g.marginal)).tolist() == [m]
    assert m not in part.stable and len(part.stable) == 2
    assert part.class_name == "biplus-stable"
    assert np.all(part.max_reorient[m] == 0.0) and np.all(part.step[m] == 0.0)
    assert oracle.stable_edges(part.body) == list(part.stable)


# --------------------------------------------------------------------------
# the exact replay stops at the unstable equilibrium (and says so)
# --------------------------------------------------------------------------
@pytest.mark.float64
@pytest.mark.parametrize("foot", [0.0, 4e-13, -4e-13])
def test_replay_stops_at_marginal_equilibrium(foot):
    """A push rolling onto a marginal edge ends there, on a vertex (edge -1),
    with ``marginal`` naming the edge; the oracle agrees.  The foot a few 1e-13
    inside or outside is marginal too (before: stable, or the replay rolled on
    or looped)."""
    com = MARGINAL_COM + np.array([foot * 0.2, 0.0])
    part = prepare_part(MARGINAL, com)
    m = _hull_edge(part, (0, 1))
    geom = part.geom
    # orientation 30 deg before edge [0, 1] lies flush, on vertex 1's side: rolls onto it
    te = float(np.mod(-0.5 * math.pi - part.nu[m], 2 * math.pi))
    pose = np.array([0.0, 0.0, te - math.radians(30.0)])
    out = jax.jit(replay_push)(geom, jnp.asarray(pose), jnp.array([0.0, 1.0]), 100.0)
    assert bool(out.finished)
    assert int(out.edge) == -1 and not bool(out.complete)
    assert int(out.marginal) == m
    assert abs(oracle.wrap(float(out.pose[2]) - te)) < 1e-12
    ref = oracle.replay_push(part.body, pose, [0.0, 1.0], 100.0)
    assert ref.edge == -1 and ref.marginal == m
    assert abs(oracle.wrap(float(ref.pose[2]) - te)) < 1e-12


# --------------------------------------------------------------------------
# the push function: no band of "no stable edge"
# --------------------------------------------------------------------------
@pytest.mark.float64
@pytest.mark.parametrize("turn", [0.0, T_ROT])
def test_marginal_triangle_push_function_has_no_band(turn):
    """Before issue 21 an 80-degree band of orientations ended "on a vertex"."""
    part = prepare_part(MARGINAL @ _rot(turn).T, _rot(turn) @ MARGINAL_COM)
    data = push_stability(part, n_grid=3600)
    assert max(_gaps(data.final_edge), default=0) <= 1
    assert set(np.unique(data.final_edge[data.final_edge >= 0])) == set(part.stable)
    m = _hull_edge(part, (0, 1))
    assert [(k, e) for _, e, k in data.marginal] == [(part.polygon.hull_index.index(0), m)]
    assert len(data.divergent) == len(part.stable)
    # the band that rolls over the marginal edge ends on edge [2, 0]
    assert data.via_marginal.sum() > 700
    assert np.all(data.final_edge[data.via_marginal] == _hull_edge(part, ROLL_TO))


def _perturbed(sign: float) -> np.ndarray:
    """The marginal centre of mass moved 1e-9 of the part's size along edge [0, 1]:
    sign +1 into the edge (stable by a hair), -1 beyond vertex 0 (unstable by a hair)."""
    size = pg.hull_extent(MARGINAL)
    return MARGINAL_COM + np.array([sign * 1e-9 * size, 0.0])


@pytest.mark.float64
def test_resolution_matches_perturbed_replay():
    """The resolved push function is the limit of the exact replay as the centre
    of mass moves off the marginal position beyond the edge's end; moved into
    the edge, the pushes that roll over the marginal edge stop on it instead
    (a stable edge by a hair), and only those.  Spot checks with the numpy oracle."""
    part = prepare_part(MARGINAL, MARGINAL_COM)
    data = push_stability(part, n_grid=3600)
    m = _hull_edge(part, (0, 1))
    out_part = prepare_part(MARGINAL, _perturbed(-1.0))
    in_part = prepare_part(MARGINAL, _perturbed(+1.0))
    assert m not in out_part.stable and m in in_part.stable
    out = push_stability(out_part, n_grid=3600)
    inn = push_stability(in_part, n_grid=3600)
    assert np.array_equal(out.final_edge, data.final_edge)
    assert not out.via_marginal.any() and not inn.via_marginal.any()
    via = data.via_marginal
    assert np.array_equal(inn.final_edge[~via], data.final_edge[~via])
    assert np.all(inn.final_edge[via] == m)
    for p, ref in ((out_part, out), (in_part, inn)):
        for i in range(0, 3600, 90):
            o = oracle.replay_push(p.body, [0.0, 0.0, data.theta[i]], [0.0, 1.0], 1e4)
            assert o.edge == ref.final_edge[i], (i, o.edge, ref.final_edge[i])


@pytest.mark.float64
def test_resolution_matches_quasistatic_kernel():
    """The quasi-static kernel (sticking fence, Peshkin's ratio) on the part with
    the centre of mass 1e-9 beyond the edge's end ends every sampled push where
    the resolution says; a hair inside, on the marginal edge in the band."""
    part = prepare_part(MARGINAL, MARGINAL_COM)
    data = push_stability(part, n_grid=3600)
    m = _hull_edge(part, (0, 1))
    idx = np.arange(5, 3600, 113)
    idx = idx[np.min(np.abs(np.subtract.outer(data.theta[idx], [x for x, _ in data.divergent])), axis=1)
              > 0.02]
    assert data.via_marginal[idx].sum() >= 5
    for sign in (-1.0, +1.0):
        p = prepare_part(MARGINAL, _perturbed(sign))
        k = len(idx)
        radius = float(p.geom.radius)
        sim = sim_many(p.body, np.c_[np.zeros((k, 2)), data.theta[idx]], np.tile([0.0, 1.0], (k, 1)),
                       np.full(k, 1e3 * radius), np.full(k, radius), np.full(k, math.inf))
        want = data.final_edge[idx].copy()
        if sign > 0:
            want[data.via_marginal[idx]] = m
        assert not np.any(sim.truncated)
        assert np.array_equal(sim.edge, want), (sign, sim.edge, want)


@st.composite
def near_marginal_triangles(draw):
    """A triangle with an edge along x from (x0, y0) to (x0 + L, y0), an obtuse
    angle at one of its ends, and the centre of mass above that end moved by
    ``delta`` of L along the edge (0: exactly marginal; 1e-17..1e-6, inside or
    beyond the end, marginal below ``MARGINAL_FOOT``); the x offsets are exact
    in binary, so delta 0 is exact."""
    x0 = draw(st.sampled_from([0.0, 0.125, -0.5]))
    y0 = draw(st.sampled_from([0.0, 0.25]))
    length = draw(st.sampled_from([0.125, 0.25, 0.5]))
    at_end = draw(st.integers(0, 1))
    over = draw(st.floats(0.2, 1.5)) * length      # how far the apex leans beyond the obtuse end
    apex_y = draw(st.floats(0.15, 0.8)) * length
    com_y = draw(st.floats(0.2, 0.6)) * apex_y * (length / (length + over))
    exponent = draw(st.sampled_from([None, -16, -14, -13, -12, -11, -10, -9, -8, -7, -6]))
    delta = 0.0 if exponent is None else draw(st.floats(1.0, 9.9)) * 10.0 ** (exponent - 1)
    sign = draw(st.sampled_from([1.0, -1.0]))
    if at_end == 0:
        apex_x, end_x, inward = x0 - over, x0, 1.0
    else:
        apex_x, end_x, inward = x0 + length + over, x0 + length, -1.0
    verts = np.array([[x0, y0], [x0 + length, y0], [apex_x, y0 + apex_y]])
    com = np.array([end_x + inward * sign * delta * length, y0 + com_y])
    return verts, com, delta


@pytest.mark.float64
@settings(max_examples=40)
@given(near_marginal_triangles())
def test_near_marginal_push_function_isolated_gaps(tri):
    """The push function of a (near-)marginal triangle never says "no stable
    edge" except at isolated orientations, and never lands a marginal edge."""
    verts, com, delta = tri
    part = prepare_part(verts, com)
    data = push_stability(part, n_grid=3600)   # the compile shared with the tests above
    assert max(_gaps(data.final_edge), default=0) <= 1, (delta, np.asarray(part.geom.foot))
    marginal = set(np.flatnonzero(np.asarray(part.geom.marginal)).tolist())
    assert not marginal & set(np.unique(data.final_edge).tolist())
    if delta == 0.0:
        assert marginal and data.marginal


# --------------------------------------------------------------------------
# the planner never lands a marginal edge
# --------------------------------------------------------------------------
@pytest.mark.parametrize("turn", [0.0, T_ROT])
def test_planner_never_lands_marginal_edge(turn):
    """Before issue 21 the turned part (marginal edge counted stable by rounding)
    got plans landing edge [0, 1] (the second to fourth pairs), and for the
    first pair one whose replay ended at the equilibrium (a PlanningError)."""
    verts, com = MARGINAL @ _rot(turn).T, _rot(turn) @ MARGINAL_COM
    for a, b in ((-1.0, 1.2), (0.0, 2.5), (-2.5, 0.3), (1.5, 2.9)):
        plan = plan_pose(verts, [0.0, 0.0, a], [0.3, 0.1, b], com=com)
        assert all(set(p.edge) != {0, 1} for p in plan.pushes), [p.edge for p in plan.pushes]


# --------------------------------------------------------------------------
# the figure marks the equilibrium
# --------------------------------------------------------------------------
def test_psd_figure_marks_marginal_equilibrium(tmp_path, monkeypatch):
    """The PSD of the marginal triangle has no "ends on a vertex" band and a
    legend entry for the unstable equilibrium and the band that rolls over it."""
    from sweeps.figures import push as figs
    kept = []
    monkeypatch.setattr(figs.plt, "close", kept.append)
    data = figs.plot_psd(MARGINAL, tmp_path / "m.png", com=MARGINAL_COM)
    assert (tmp_path / "m.png").stat().st_size > 0
    labels = [t.get_text() for t in kept[0].axes[0].get_legend().get_texts()]
    assert "unstable equilibrium (marginal edge [0, 1])" in labels
    assert any(lab.startswith("rolls over the marginal edge") for lab in labels)
    assert "ends on a vertex" not in labels
    assert data.marginal and data.via_marginal.any()
    monkeypatch.undo()
    figs.plt.close(kept[0])
