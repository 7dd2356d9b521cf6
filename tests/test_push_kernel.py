"""kernels.push: the exact push replay against the independent numpy oracle,
hand-computed pushes, the Peshkin rate ODE, batching and float32."""
from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from kernels.polygon import polygon_geometry
from kernels.push import replay_push, replay_pushes
from tests import strategies as S
from oracles import push_numpy as oracle

pytestmark = pytest.mark.float64  # calls kernels on float64 arrays directly

TOL = 1e-9

_replay_batch = jax.jit(jax.vmap(replay_push, in_axes=(None, 0, 0, 0)))
_replay_seq = jax.jit(replay_pushes)
BATCH = 64  # every batched call is padded to this size: one compile per vertex count


def _replay_many(geom, poses, dirs, dists):
    """Replay independent pushes (padded to BATCH rows); returns numpy outcome fields."""
    poses, dirs, dists = (np.atleast_1d(np.asarray(v, float)) for v in (poses, dirs, dists))
    poses, dirs = poses.reshape(-1, 3), dirs.reshape(-1, 2)
    k = len(dists)
    assert k <= BATCH
    pad = BATCH - k
    out = _replay_batch(geom, jnp.asarray(np.concatenate([poses, np.zeros((pad, 3))])),
                        jnp.asarray(np.concatenate([dirs, np.ones((pad, 2))])),
                        jnp.asarray(np.concatenate([dists, np.zeros(pad)])))
    return jax.tree_util.tree_map(lambda a: np.asarray(a)[:k], out)


def _replay_one(geom, pose, d, s):
    return jax.tree_util.tree_map(lambda a: a[0], _replay_many(geom, pose, d, [s]))


def _pose_err(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return max(float(np.max(np.abs(a[:2] - b[:2]))), abs(oracle.wrap(float(a[2] - b[2]))))


def _random_pushes(rng, body, count):
    n = len(body)
    poses = np.c_[rng.uniform(-1, 1, (count, 2)), rng.uniform(-math.pi, math.pi, count)]
    ang = rng.uniform(-math.pi, math.pi, count)
    dirs = np.c_[np.cos(ang), np.sin(ang)] * rng.uniform(0.1, 3.0, (count, 1))  # not normalised
    size = float(np.max(np.hypot(*body.T)))
    # short (stop mid-rotation) to long (roll over unstable edges, then translate)
    dists = size * 10 ** rng.uniform(-3.5, 2.5, count)
    dists[: count // 10] = 0.0
    # start with an edge exactly flush with the fence (as in a plan) for some pushes
    nu = np.arctan2(-(np.roll(body, -1, 0) - body)[:, 0], (np.roll(body, -1, 0) - body)[:, 1])
    for i in range(count // 10, count // 4):
        e = int(rng.integers(n))
        poses[i, 2] = oracle.wrap(math.atan2(-dirs[i, 1], -dirs[i, 0]) - nu[e])
    return poses, dirs, dists


@pytest.mark.slow
def test_kernel_matches_oracle_on_random_parts():
    rng = np.random.default_rng(0)
    stats = dict(partial=0, complete=0, rolled=0, zero=0, n=set())
    for _ in range(36):
        verts, com = (S.numpy_uni_stable_part(rng, n=int(rng.integers(4, 6))) if rng.random() < 0.3
                      else S.numpy_random_part(rng))
        body = oracle.body_from_part(verts, com)[0]
        stats["n"].add(len(body))
        geom = polygon_geometry(jnp.asarray(body))
        poses, dirs, dists = _random_pushes(rng, body, BATCH)
        out = _replay_many(geom, poses, dirs, dists)
        kp, ke, kc = np.asarray(out.pose), np.asarray(out.edge), np.asarray(out.complete)
        krot, kland, kfin = np.asarray(out.rotation), np.asarray(out.landings), np.asarray(out.finished)
        for i in range(len(dists)):
            o = oracle.replay_push(body, poses[i], dirs[i], dists[i])
            msg = (body.tolist(), poses[i].tolist(), dirs[i].tolist(), float(dists[i]))
            assert _pose_err(kp[i], o.pose) < TOL, msg
            assert -math.pi < kp[i, 2] <= math.pi
            assert bool(kfin[i]), msg
            if dists[i] == 0.0:
                stats["zero"] += 1
                np.testing.assert_allclose(kp[i], np.r_[poses[i, :2], oracle.wrap(poses[i, 2])], atol=1e-15)
                assert ke[i] == -1 and not kc[i], msg
                continue
            assert int(ke[i]) == o.edge and bool(kc[i]) == o.complete, msg
            # flush starts included: the rotation itself, not modulo 2 pi
            assert krot[i] == pytest.approx(o.rotation, abs=TOL), msg
            assert int(kland[i]) == o.landings, msg
            stats["complete"] += o.complete
            stats["partial"] += (not o.complete) and o.rotation != 0.0
            stats["rolled"] += o.complete and o.landings >= 2
    # every regime was exercised
    assert stats["partial"] > 200 and stats["complete"] > 600 and stats["rolled"] > 60, stats
    assert stats["n"] >= {3, 4, 5}, stats["n"]


def test_flush_translations_and_long_rolls_match_oracle():
    """Plan-like sequences: land an edge, then push along other edges' inward
    normals from the flush pose; rolls over several unstable edges."""
    rng = np.random.default_rng(1)
    for _ in range(12):
        verts, com = S.numpy_uni_stable_part(rng, n=5) if rng.random() < 0.5 else S.numpy_random_part(rng)
        body = oracle.body_from_part(verts, com)[0]
        geom = polygon_geometry(jnp.asarray(body))
        stable = oracle.stable_edges(body)
        pose = np.array([0.1, -0.2, rng.uniform(-math.pi, math.pi)])
        dirs, dists = [], []
        for k in range(8):
            a = rng.uniform(-math.pi, math.pi)
            dirs.append([math.cos(a), math.sin(a)])
            dists.append(float(rng.uniform(0.5, 3.0)))
        final, outs = _replay_seq(geom, jnp.asarray(pose), jnp.asarray(dirs), jnp.asarray(dists))
        ofinal, oouts = oracle.replay_pushes(body, pose, dirs, dists)
        for k, o in enumerate(oouts):
            assert _pose_err(np.asarray(outs.pose[k]), o.pose) < TOL
            assert int(outs.edge[k]) == o.edge
        assert _pose_err(final, ofinal) < TOL
        # now from each landed pose, translation pushes along every stable edge's inward normal
        p = np.asarray(final)
        for e in stable:
            nu = math.atan2(-(body[(e + 1) % len(body)] - body[e])[0], (body[(e + 1) % len(body)] - body[e])[1])
            d = [math.cos(p[2] + nu + math.pi), math.sin(p[2] + nu + math.pi)]
            k_out = _replay_one(geom, jnp.asarray(p), jnp.asarray(d), 0.37)
            o = oracle.replay_push(body, p, d, 0.37)
            assert o.complete and o.edge == e and abs(o.rotation) < 1e-12
            assert int(k_out.edge) == e and bool(k_out.complete)
            assert _pose_err(k_out.pose, o.pose) < TOL
            np.testing.assert_allclose(np.asarray(k_out.pose[:2]), p[:2] + 0.37 * np.asarray(d), atol=1e-12)


def test_flush_start_rotation():
    """A push that starts with a stable edge exactly flush does not turn the
    part, even when rounding leaves the flush edge a hair (~1e-16 rad) past the
    fence (a rotation to the next landing of 2 pi - 1e-16 would be reported as
    a full turn).  Example: a triangle whose three edges are stable, edge 2 flush."""
    body = np.array([[0.020517150423461326, 0.015160882108190846],
                     [-0.022446101513313242, -0.0014289599388283142],
                     [0.004858067346706976, -0.008659391154106669]])
    pose = np.array([-0.05987140758776355, -0.44354596898303944, 2.434792926852397])
    d = np.array([0.06717756228535147, -0.23148224464590791])
    geom = polygon_geometry(jnp.asarray(body))
    o = oracle.replay_push(body, pose, d, 8.061386947418451e-05)
    assert o.edge == 2 and abs(o.rotation) < 1e-12
    out = _replay_one(geom, jnp.asarray(pose), jnp.asarray(d), 8.061386947418451e-05)
    assert int(out.edge) == 2 and _pose_err(out.pose, o.pose) < TOL
    assert abs(float(out.rotation)) < 1e-9, float(out.rotation)


def test_replay_pushes_is_sequential_replay_and_zero_pads():
    rng = np.random.default_rng(2)
    verts, com = S.numpy_random_part(rng)
    body = oracle.body_from_part(verts, com)[0]
    geom = polygon_geometry(jnp.asarray(body))
    poses, dirs, dists = _random_pushes(rng, body, 8)
    dists[3] = 0.0
    final, outs = _replay_seq(geom, jnp.asarray(poses[0]), jnp.asarray(dirs), jnp.asarray(dists))
    p = poses[0]
    for k in range(8):
        o = _replay_one(geom, jnp.asarray(p), jnp.asarray(dirs[k]), dists[k])
        np.testing.assert_allclose(np.asarray(outs.pose[k]), np.asarray(o.pose), atol=1e-14)
        p = np.asarray(o.pose)
    np.testing.assert_allclose(np.asarray(final), p, atol=1e-14)
    np.testing.assert_allclose(np.asarray(outs.pose[3]), np.asarray(outs.pose[2]), atol=1e-15)


def test_unfinished_push_is_flagged():
    """A replay whose pass limit runs out before the push has spent its distance
    says so (``finished`` False, not complete, no edge) instead of returning
    where it stopped as an ordinary outcome.  With the default limit every
    push finishes (a convex part lands at most n edges before a stable one)."""
    one_pass = jax.jit(jax.vmap(lambda g, p, d, s: replay_push(g, p, d, s, max_passes=1),
                                in_axes=(None, 0, 0, 0)))
    rng = np.random.default_rng(6)
    rolled = 0
    for _ in range(6):
        verts, com = S.numpy_uni_stable_part(rng, n=5)
        body = oracle.body_from_part(verts, com)[0]
        geom = polygon_geometry(jnp.asarray(body))
        poses, dirs, dists = _random_pushes(rng, body, BATCH)
        dists = dists * 0 + 100.0 * float(np.max(np.hypot(*body.T)))
        full = _replay_many(geom, poses, dirs, dists)
        short = one_pass(geom, jnp.asarray(poses), jnp.asarray(dirs), jnp.asarray(dists))
        for i in range(BATCH):
            o = oracle.replay_push(body, poses[i], dirs[i], dists[i])
            assert bool(full.finished[i]) and int(full.edge[i]) == o.edge
            if o.landings >= 2:     # needs at least two passes: one pass is not enough
                rolled += 1
                assert not bool(short.finished[i]) and not bool(short.complete[i]) and int(short.edge[i]) == -1
    assert rolled >= 5


def test_rate_c_is_the_sticking_rate():
    """With ``rate_c`` the replay turns at rho sin(beta) / (c^2 + rho^2): the
    oracle agrees, and the distance that completes a reorient is Peshkin's with
    the radius replaced by c (shorter for c below the radius)."""
    rng = np.random.default_rng(7)
    verts, com = S.numpy_random_part(rng)
    body = oracle.body_from_part(verts, com)[0]
    geom = polygon_geometry(jnp.asarray(body))
    size = float(np.max(np.hypot(*body.T)))
    poses, dirs, dists = _random_pushes(rng, body, BATCH)
    for c in (0.3 * size, 0.8 * size):
        out = jax.jit(jax.vmap(lambda p, d, s: replay_push(geom, p, d, s, rate_c=c)))(
            jnp.asarray(poses), jnp.asarray(dirs), jnp.asarray(dists))
        for i in range(BATCH):
            o = oracle.replay_push(body, poses[i], dirs[i], dists[i], rate_c=c)
            assert _pose_err(np.asarray(out.pose[i]), o.pose) < TOL
            assert int(out.edge[i]) == o.edge


# --------------------------------------------------------------------------
# hand-computed pushes
# --------------------------------------------------------------------------
L = 0.02  # half side of the square, m
SQUARE = np.array([[-L, -L], [L, -L], [L, L], [-L, L]])


def test_square_from_ten_degrees_by_hand():
    """Square at +10 deg, fence below moving +y: it pivots CW about the lowest
    corner (body (-L, -L)) until the bottom edge lands (beta 35 -> 45 deg)."""
    geom = polygon_geometry(jnp.asarray(SQUARE))
    t0 = math.radians(10.0)
    x0, y0 = 0.3, -0.1
    p0 = np.array([x0, y0]) + np.array([[math.cos(t0), -math.sin(t0)], [math.sin(t0), math.cos(t0)]]) @ [-L, -L]
    c = a = L * math.sqrt(2.0)
    k = (a * a + c * c) / c
    s_need = k * math.log(math.tan(math.radians(22.5)) / math.tan(math.radians(17.5)))
    d = np.array([0.0, 1.0])
    # complete: the corner advances s, the square ends square, centre at corner + (L, L)
    s = 1.7 * s_need
    out = _replay_one(geom, jnp.array([x0, y0, t0]), jnp.asarray(d), s)
    want = np.r_[p0 + s * d + [L, L], 0.0]
    np.testing.assert_allclose(np.asarray(out.pose), want, atol=1e-14)
    assert int(out.edge) == 0 and bool(out.complete) and int(out.landings) == 1
    assert float(out.rotation) == pytest.approx(-t0, abs=1e-14)
    # the boundary: just short stops mid-rotation, just long completes
    assert not bool(_replay_one(geom, jnp.array([x0, y0, t0]), jnp.asarray(d), s_need * (1 - 1e-9)).complete)
    assert bool(_replay_one(geom, jnp.array([x0, y0, t0]), jnp.asarray(d), s_need * (1 + 1e-9)).complete)
    # half way: tan(beta/2) = tan(17.5 deg) exp(s / k)
    s = 0.5 * s_need
    beta = 2 * math.atan(math.tan(math.radians(17.5)) * math.exp(s / k))
    th = t0 - (beta - math.radians(35.0))
    out = _replay_one(geom, jnp.array([x0, y0, t0]), jnp.asarray(d), s)
    rot = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
    want = np.r_[p0 + s * d - rot @ [-L, -L], th]
    np.testing.assert_allclose(np.asarray(out.pose), want, atol=1e-14)
    assert int(out.edge) == -1 and not bool(out.complete) and int(out.landings) == 0
    assert math.radians(0) < th < t0


def test_divergent_square_translates():
    """Corner straight down (45 deg): the centre of mass is straight ahead of the
    contact corner, no torque; the part translates and the push is incomplete."""
    geom = polygon_geometry(jnp.asarray(SQUARE))
    out = _replay_one(geom, jnp.array([0.0, 0.0, math.pi / 4]), jnp.array([0.0, 1.0]), 0.5)
    o = oracle.replay_push(SQUARE, [0.0, 0.0, math.pi / 4], [0.0, 1.0], 0.5)
    assert _pose_err(out.pose, o.pose) < TOL
    assert _pose_err(out.pose, [0.0, 0.5, math.pi / 4]) < 1e-12
    assert not bool(out.complete) and int(out.edge) == -1


@pytest.mark.parametrize("seed", range(3))
def test_partial_rotation_matches_peshkin_ode(seed):
    """The rotation after a short push equals the integral of the worst-case
    rate d beta/ds = c sin(beta) / (a^2 + c^2) (scipy solve_ivp), and the
    distance at which the next edge lands equals the ODE's event time."""
    rng = np.random.default_rng(seed)
    verts, com = S.numpy_random_part(rng)
    body = oracle.body_from_part(verts, com)[0]
    geom = polygon_geometry(jnp.asarray(body))
    a2 = float(np.max(np.sum(body ** 2, 1)))
    checked = 0
    while checked < 6:
        pose = np.array([0.0, 0.0, rng.uniform(-math.pi, math.pi)])
        d = np.array([0.0, 1.0])
        w = body @ np.array([[math.cos(pose[2]), -math.sin(pose[2])], [math.sin(pose[2]), math.cos(pose[2])]]).T
        piv = int(np.argmin(w[:, 1]))
        pc = -w[piv]
        c = float(np.hypot(*pc))
        beta1 = math.atan2(abs(pc[0]), pc[1])
        # landing angle of the neighbour in the rotation sense (geometry, not the kernel)
        sigma = -1.0 if pc[0] > 0 else 1.0
        nb = w[(piv + 1) % len(w)] if sigma < 0 else w[(piv - 1) % len(w)]  # CCW polygon
        r = nb - w[piv]
        phi = math.atan2(r[1], abs(r[0]))
        if beta1 < 0.05 or phi < 0.05:
            continue
        rate = lambda s, b: [c * math.sin(b[0]) / (a2 + c * c)]  # noqa: E731
        land = lambda s, b: b[0] - (beta1 + phi)  # noqa: E731
        land.terminal = True
        sol = solve_ivp(rate, [0, 1e6], [beta1], events=land, rtol=1e-12, atol=1e-14)
        s_land = float(sol.t_events[0][0])
        for frac in (0.1, 0.5, 0.9):
            s = frac * s_land
            ode = solve_ivp(rate, [0, s], [beta1], rtol=1e-12, atol=1e-14).y[0, -1]
            out = _replay_one(geom, jnp.asarray(pose), jnp.asarray(d), s)
            assert not bool(out.complete)
            assert float(out.rotation) == pytest.approx(sigma * (ode - beta1), abs=1e-9)
        assert not bool(_replay_one(geom, jnp.asarray(pose), jnp.asarray(d), s_land * (1 - 1e-7)).landings)
        assert int(_replay_one(geom, jnp.asarray(pose), jnp.asarray(d), s_land * (1 + 1e-7)).landings) >= 1
        checked += 1


# --------------------------------------------------------------------------
# batching and precision
# --------------------------------------------------------------------------
def test_vmap_over_perturbed_vertex_sets_equals_loop():
    rng = np.random.default_rng(3)
    verts, com = S.numpy_random_part(rng)
    body = oracle.body_from_part(verts, com)[0]
    size = float(np.max(np.hypot(*body.T)))
    bodies = body[None] + rng.normal(scale=0.01 * size, size=(32,) + body.shape)
    poses, dirs, dists = _random_pushes(rng, body, 32)

    def one(b, p, d, s):
        return replay_push(polygon_geometry(b), p, d, s)

    batched = jax.jit(jax.vmap(one))(jnp.asarray(bodies), jnp.asarray(poses), jnp.asarray(dirs),
                                     jnp.asarray(dists))
    single = jax.jit(one)
    for i in range(32):
        o = single(jnp.asarray(bodies[i]), jnp.asarray(poses[i]), jnp.asarray(dirs[i]), dists[i])
        np.testing.assert_allclose(np.asarray(batched.pose[i]), np.asarray(o.pose), atol=1e-13)
        assert int(batched.edge[i]) == int(o.edge) and bool(batched.complete[i]) == bool(o.complete)
        # and the oracle on the perturbed part
        oo = oracle.replay_push(bodies[i], poses[i], dirs[i], dists[i])
        assert _pose_err(o.pose, oo.pose) < TOL


def test_float32_agrees_with_float64():
    rng = np.random.default_rng(4)
    compared = 0
    bodies = []
    while len(bodies) < 4:  # one vertex count: one float32 compile
        body = oracle.body_from_part(*S.numpy_random_part(rng))[0]
        if len(body) == 4:
            bodies.append(body)
    for body in bodies:
        size = float(np.max(np.hypot(*body.T)))
        poses, dirs, dists = _random_pushes(rng, body, 64)
        poses = poses[len(poses) // 4:]   # generic starts
        dirs, dists = dirs[len(dirs) // 4:], dists[len(dists) // 4:]
        g32 = polygon_geometry(jnp.asarray(body, jnp.float32))
        out32 = _replay_batch(g32, jnp.asarray(poses, jnp.float32),
                                                      jnp.asarray(dirs, jnp.float32),
                                                      jnp.asarray(dists, jnp.float32))
        assert out32.pose.dtype == jnp.float32
        for i in range(len(dists)):
            o = oracle.replay_push(body, poses[i], dirs[i], dists[i])
            # skip pushes within 1e-3 of an event (float32 may land on either side)
            near = [oracle.replay_push(body, poses[i], dirs[i], dists[i] * f) for f in (0.999, 1.001)]
            if any(n.edge != o.edge or n.landings != o.landings for n in near):
                continue
            compared += 1
            assert int(out32.edge[i]) == o.edge
            tol = 2e-4 * max(1.0, dists[i] / size)
            assert float(np.max(np.abs(np.asarray(out32.pose[i, :2], float) - o.pose[:2]))) < tol * size + 1e-5
            assert abs(oracle.wrap(float(out32.pose[i, 2]) - o.pose[2])) < tol
    assert compared > 150
