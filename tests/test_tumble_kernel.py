"""Tests for kernels.tumble: exact tumble kinematics against geometry and a numpy oracle."""
from __future__ import annotations

import math
import pathlib
from collections import deque

import jax


import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
import yaml  # noqa: E402
from hypothesis import given, settings, strategies as st  # noqa: E402

from kernels.polyhedron import Polyhedron, make_polyhedron  # noqa: E402
from kernels.tumble_geometry import tumble_geometry  # noqa: E402
from kernels.planar import wrap_angle  # noqa: E402
from kernels.tumble import (  # noqa: E402
    TumbleConfig,
    apply_effect,
    compose_effects,
    invert_effect,
    make_config,
    replay,
    replay_trajectory,
    tumble,
    tumble_sequence_effect,
)
from oracles import tumble_numpy as oracle  # noqa: E402

pytestmark = pytest.mark.float64  # calls kernels on float64 arrays directly

EXAMPLES = pathlib.Path(__file__).resolve().parents[1] / "examples"
EXAMPLE_NAMES = ["cube", "tetrahedron", "octahedron", "truncated_pyramid", "irregular_polyhedron"]
PI = math.pi
# Random polyhedra use a few fixed point counts so that jitted kernels (keyed on
# shapes, not on the polyhedron) compile only a few times.
N_POINTS = (7, 10)
HSET = settings(derandomize=True, max_examples=10, deadline=None)


def load_example(name: str) -> Polyhedron:
    doc = yaml.safe_load((EXAMPLES / f"{name}.yaml").read_text())
    return make_polyhedron(doc["vertices"], doc.get("com"))


def random_polyhedron(seed: int) -> Polyhedron:
    rng = np.random.default_rng(seed)
    n = N_POINTS[seed % len(N_POINTS)]
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    # points on an ellipsoid are all hull vertices: F = 2n - 4 triangles, so
    # the array shapes (hence compilations) depend on n only
    V = d * rng.uniform(0.3, 1.0, size=3) * rng.uniform(0.05, 2.0)
    P = make_polyhedron(V)
    assert P.n_faces == 2 * n - 4
    return P


def random_walk(P: Polyhedron, rng, start_face: int, length: int, pad_prob=0.15):
    seq, f = [], start_face
    for _ in range(length):
        if rng.uniform() < pad_prob:
            seq.append(-1)
            continue
        g = int(rng.choice(P.neighbors(f)))
        seq.append(g)
        f = g
    return seq


def pad(seq, n=64):
    """Pad a face sequence with -1 to a fixed length (one compilation per shape)."""
    seq = list(seq)
    assert len(seq) <= n
    return jnp.array(seq + [-1] * (n - len(seq)), dtype=jnp.int32)


def cfg_close(a: TumbleConfig, b, atol):
    """Compare a TumbleConfig with another or with an (x, y, theta, face) tuple."""
    if not isinstance(b, TumbleConfig):
        b = TumbleConfig(np.array(b[:2]), np.array(b[2]), np.array(b[3]))
    assert int(a.face) == int(b.face)
    np.testing.assert_allclose(np.asarray(a.xy), np.asarray(b.xy), atol=atol, rtol=0)
    dth = float(wrap_angle(np.asarray(a.theta, dtype=float) - np.asarray(b.theta, dtype=float)))
    assert abs(dth) <= atol, dth


def world(config: TumbleConfig, q):
    th = float(config.theta)
    R = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
    return R @ np.asarray(q) + np.asarray(config.xy)


def corner_2d(P: Polyhedron, face: int, vertex: int):
    return P.face_corners_2d[face][P.face_cycles[face].index(vertex)]


POLYS = {name: load_example(name) for name in EXAMPLE_NAMES}
POLYS.update({f"random{s}": random_polyhedron(s) for s in range(4)})


# ---------------------------------------------------------------- cube belt
def test_cube_rolled_four_times_in_a_belt():
    P = POLYS["cube"]
    G = P.geometry()
    edge = 0.1
    for f0, k0 in [(0, 0), (0, 1), (3, 2), (5, 3)]:
        # roll "straight": after landing across slot e, go on across the opposite slot
        seq, f, k = [], f0, k0
        for _ in range(4):
            g = P.neighbors(f)[k]
            kk = P.topology.next_slot[f][k]
            seq.append(g)
            f, k = g, (kk + 2) % 4
        assert f == f0 and len(set(seq)) == 4
        start = make_config(0.3, -0.2, 0.7, f0)
        final, ok = replay(G, start, pad(seq))
        assert bool(ok)
        assert int(final.face) == f0
        assert float(wrap_angle(final.theta - start.theta)) == pytest.approx(0.0, abs=1e-12)
        d = np.asarray(final.xy) - np.asarray(start.xy)
        assert np.linalg.norm(d) == pytest.approx(4 * edge, abs=1e-12)
        # the translation is perpendicular to the first edge in the world
        a, b = P.face_cycles[f0][k0], P.face_cycles[f0][(k0 + 1) % 4]
        e = world(start, corner_2d(P, f0, b)) - world(start, corner_2d(P, f0, a))
        assert abs(d @ e) < 1e-12
        # and points away from the part (to the far side of the edge)
        mid = 0.5 * (world(start, corner_2d(P, f0, b)) + world(start, corner_2d(P, f0, a)))
        assert (mid - np.asarray(start.xy)) @ d > 0


# ---------------------------------------------------------------- inverse
@pytest.mark.parametrize("name", sorted(POLYS))
def test_tumble_then_inverse_is_identity(name):
    P = POLYS[name]
    G = P.geometry()
    rng = np.random.default_rng(0)
    for f in range(P.n_faces):
        start = make_config(*rng.uniform(-1, 1, 2), rng.uniform(-PI, PI), f)
        for g in P.neighbors(f):
            mid, ok1 = replay(G, start, pad([g]))
            back, ok2 = replay(G, mid, pad([f]))
            assert bool(ok1) and bool(ok2) and int(mid.face) == g
            cfg_close(back, start, 1e-12)
            # the shared edge stays where it was
            a, b = P.shared_edge(f, g)
            for v in (a, b):
                np.testing.assert_allclose(
                    world(mid, corner_2d(P, g, v)), world(start, corner_2d(P, f, v)), atol=1e-12
                )


# ---------------------------------------------------------------- R_j property
def transit_paths(P: Polyhedron, root: int = 0):
    """BFS transit paths L_i from face ``root`` (lists of faces, root first)."""
    paths = {root: [root]}
    q = deque([root])
    while q:
        f = q.popleft()
        for g in P.neighbors(f):
            if g not in paths:
                paths[g] = paths[f] + [g]
                q.append(g)
    return paths


@pytest.mark.parametrize("name", sorted(POLYS))
def test_rolling_around_a_vertex_rotates_by_its_defect(name):
    P = POLYS[name]
    G = P.geometry()
    rng = np.random.default_rng(1)
    L = transit_paths(P)
    for i, beta in zip(P.hull_vertices, P.defect_angles):
        ring = P.vertex_faces(i)
        f1 = ring[0]
        # S_j from an arbitrary configuration: rotation by +beta about the vertex
        start = make_config(*rng.uniform(-1, 1, 2), rng.uniform(-PI, PI), f1)
        final, ok = replay(G, start, pad(ring[1:] + (f1,)))
        assert bool(ok) and int(final.face) == f1
        assert float(wrap_angle(final.theta - start.theta - beta)) == pytest.approx(0.0, abs=1e-12)
        C = world(start, corner_2d(P, f1, i))
        np.testing.assert_allclose(world(final, corner_2d(P, f1, i)), C, atol=1e-12)
        # the whole pose is rotated by beta about C
        Rb = np.array([[math.cos(beta), -math.sin(beta)], [math.sin(beta), math.cos(beta)]])
        np.testing.assert_allclose(np.asarray(final.xy), C + Rb @ (np.asarray(start.xy) - C), atol=1e-12)
        # the word's effect, in f1's frame: angle beta about the corner
        eff, ok = tumble_sequence_effect(G, f1, pad(ring[1:] + (f1,)))
        assert bool(ok)
        assert float(eff.angle) == pytest.approx(float(wrap_angle(beta)), abs=1e-12)
        np.testing.assert_allclose(np.asarray(eff.fixed_point), corner_2d(P, f1, i), atol=1e-9)
        # the paper's R_j = L S L^-1 from face 0: rotation by beta about C_j,
        # the vertex's position in the development (f1 reached via L)
        Lp = L[f1]
        word = Lp[1:] + list(ring[1:]) + [f1] + Lp[::-1][1:]
        eff, ok = tumble_sequence_effect(G, 0, pad(word))
        assert bool(ok)
        assert float(wrap_angle(eff.angle - beta)) == pytest.approx(0.0, abs=1e-12)
        origin = make_config(0.0, 0.0, 0.0, 0)
        atf1, _ = replay(G, origin, pad(Lp[1:]))
        np.testing.assert_allclose(np.asarray(eff.fixed_point), world(atf1, corner_2d(P, f1, i)), atol=1e-9)


def test_octahedron_paper_figure_4_word():
    # the paper's Fig. 4: a closed word around one vertex rotates by 2 pi / 3
    P = POLYS["octahedron"]
    G = P.geometry()
    for i in P.hull_vertices:
        ring = P.vertex_faces(i)
        eff, ok = tumble_sequence_effect(G, ring[0], pad(ring[1:] + (ring[0],)))
        assert bool(ok) and float(eff.angle) == pytest.approx(2 * PI / 3, abs=1e-12)


# ---------------------------------------------------------------- oracle
def _oracle_check(P, G, seed, length, atol, dtype):
    rng = np.random.default_rng(seed)
    f0 = int(rng.integers(P.n_faces))
    seq = random_walk(P, rng, f0, length)
    x, y, th = rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-PI, PI)
    start = make_config(x, y, th, f0, dtype=dtype)
    final, ok, traj = replay_trajectory(G, start, pad(seq))
    assert bool(ok)
    assert final.xy.dtype == dtype and final.theta.dtype == dtype
    o_final, o_traj = oracle.replay(P.vertices, P.com, P.face_cycles, (x, y, th, f0), seq)
    cfg_close(final, o_final, atol)
    for k in range(len(seq)):
        cfg_close(TumbleConfig(traj.xy[k], traj.theta[k], traj.face[k]), o_traj[k], atol)


@HSET
@given(st.integers(0, 2**31 - 1))
def test_kernel_matches_numpy_oracle_float64(seed):
    P = random_polyhedron(seed)
    scale = float(np.ptp(P.vertices, axis=0).max())
    _oracle_check(P, P.geometry(), seed, 32, 1e-9 * max(scale, 1.0), jnp.float64)


@pytest.mark.parametrize("name", EXAMPLE_NAMES)
def test_kernel_matches_numpy_oracle_examples(name):
    P = POLYS[name]
    for seed in range(3):
        _oracle_check(P, P.geometry(), seed, 32, 1e-10, jnp.float64)


@settings(derandomize=True, max_examples=6, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_kernel_float32_matches_oracle_loosely(seed):
    P = random_polyhedron(seed)
    scale = float(np.ptp(P.vertices, axis=0).max())
    _oracle_check(P, P.geometry(jnp.float32), seed, 32, 2e-4 * max(scale, 1.0), jnp.float32)


def test_perturbed_random_part_matches_oracle():
    # random hulls have triangular (exactly planar) faces, so the oracle's 3-D
    # rotation applies to the perturbed points too (same nominal combinatorics)
    P = POLYS["random1"]
    rng = np.random.default_rng(5)
    V = P.vertices + rng.normal(scale=1e-4, size=P.vertices.shape)
    G = tumble_geometry(jnp.asarray(V), jnp.asarray(P.com), P.topology)
    seq = random_walk(P, rng, 0, 40)
    start = make_config(0.1, 0.2, 0.3, 0)
    final, ok = replay(G, start, pad(seq))
    o_final, _ = oracle.replay(V, P.com, P.face_cycles, (0.1, 0.2, 0.3, 0), seq)
    assert bool(ok)
    cfg_close(final, o_final, 1e-9)


# ---------------------------------------------------------------- vmap over perturbed parts
@pytest.mark.parametrize("name", ["cube", "truncated_pyramid", "random0"])
def test_vmap_over_perturbed_parts_equals_loop(name):
    P = POLYS[name]
    rng = np.random.default_rng(7)
    B = 16
    scale = float(np.ptp(P.vertices, axis=0).max())
    V = P.vertices[None] + rng.normal(scale=1e-3 * scale, size=(B,) + P.vertices.shape)
    com = jnp.asarray(P.com)
    seq = pad(random_walk(P, rng, 0, 30))
    start = make_config(0.0, 0.0, 0.2, 0)

    @jax.jit
    def run(Vb):
        Gb = jax.vmap(tumble_geometry, in_axes=(0, None, None))(Vb, com, P.topology)
        return jax.vmap(replay, in_axes=(0, None, None))(Gb, start, seq)

    final_b, ok_b = run(jnp.asarray(V))
    assert final_b.xy.shape == (B, 2) and ok_b.shape == (B,)
    for i in range(B):
        G = tumble_geometry(jnp.asarray(V[i]), com, P.topology)
        fi, oki = replay(G, start, seq)
        assert bool(oki) == bool(ok_b[i])
        cfg_close(TumbleConfig(final_b.xy[i], final_b.theta[i], final_b.face[i]), fi, 1e-12)
    # the nominal plan's error on perturbed parts is small but nonzero
    nominal, _ = replay(P.geometry(), start, seq)
    err = np.linalg.norm(np.asarray(final_b.xy) - np.asarray(nominal.xy), axis=1)
    assert np.all(err < 0.5 * scale) and np.any(err > 0)


def test_float32_vmap_runs_in_float32():
    P = POLYS["octahedron"]
    G32 = P.geometry(jnp.float32)
    Gb = jax.tree_util.tree_map(lambda a: jnp.stack([a, a]), G32)
    final, ok = jax.vmap(replay, in_axes=(0, None, None))(
        Gb, make_config(0, 0, 0, 0), jnp.array([P.neighbors(0)[0], -1, 0])
    )
    assert final.xy.dtype == jnp.float32 and bool(ok.all())
    np.testing.assert_allclose(np.asarray(final.xy), 0.0, atol=1e-6)


# ---------------------------------------------------------------- invalid input
def test_invalid_next_face_is_flagged_not_raised():
    P = POLYS["cube"]
    G = P.geometry()
    start = make_config(0.1, 0.2, 0.3, 0)
    opposite = [f for f in range(P.n_faces) if f != 0 and f not in P.neighbors(0)][0]
    for bad in (opposite, 0, P.n_faces, 99):
        out, ok = tumble(G, start, bad)
        assert not bool(ok)
        cfg_close(out, start, 0.0)
    out, ok = tumble(G, start, -1)  # padding: a valid no-op
    assert bool(ok)
    cfg_close(out, start, 0.0)
    g = P.neighbors(0)[0]
    one, ok = tumble(G, start, g)  # a valid single tumble agrees with replay
    assert bool(ok) and int(one.face) == g
    cfg_close(one, replay(G, start, pad([g]))[0], 1e-15)
    _, ok = replay(G, start, pad([g, -1, g]))
    assert not bool(ok)
    final, ok = replay(G, start, pad([-1, g, -1, -1, 0, -1]))
    assert bool(ok)
    cfg_close(final, start, 1e-12)
    # jit: no Python-side checks needed
    _, ok = jax.jit(tumble)(G, start, jnp.int32(opposite))
    assert not bool(ok)
    # a word that does not close
    _, ok = tumble_sequence_effect(G, 0, pad([g]))
    assert not bool(ok)


# ---------------------------------------------------------------- effects algebra
@pytest.mark.parametrize("name", ["irregular_polyhedron", "truncated_pyramid", "random2"])
def test_effect_composition_matches_replay(name):
    P = POLYS[name]
    G = P.geometry()
    rng = np.random.default_rng(11)
    f = 0
    words = []
    for _ in range(2):
        w = random_walk(P, rng, f, 12, pad_prob=0.0)
        w = w + transit_paths(P, w[-1])[f][1:]  # close the word back to f
        words.append(w)
    (e1, ok1), (e2, ok2) = (tumble_sequence_effect(G, f, pad(w)) for w in words)
    assert bool(ok1) and bool(ok2)
    start = make_config(0.3, -0.4, 2.0, f)
    direct, ok = replay(G, start, pad(words[0] + words[1]))
    assert bool(ok)
    cfg_close(apply_effect(compose_effects(e1, e2), start), direct, 1e-12)
    cfg_close(apply_effect(e2, apply_effect(e1, start)), direct, 1e-12)
    # inverse = the reversed word
    erev, ok = tumble_sequence_effect(G, f, pad(words[0][::-1][1:] + [f]))
    inv = invert_effect(e1)
    assert bool(ok)
    assert float(wrap_angle(erev.angle - inv.angle)) == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_allclose(np.asarray(erev.translation), np.asarray(inv.translation), atol=1e-12)
    cfg_close(apply_effect(inv, apply_effect(e1, start)), start, 1e-12)
    # fixed point is fixed
    ang = float(e1.angle)
    if abs(ang) > 1e-6:
        c = np.asarray(e1.fixed_point)
        R = np.array([[math.cos(ang), -math.sin(ang)], [math.sin(ang), math.cos(ang)]])
        np.testing.assert_allclose(R @ c + np.asarray(e1.translation), c, atol=1e-9)


def test_pure_translation_has_nan_fixed_point():
    P = POLYS["cube"]
    G = P.geometry()
    # belt of 4 around face 0 across slot 0
    seq, f, k = [], 0, 0
    for _ in range(4):
        g = P.neighbors(f)[k]
        kk = P.topology.next_slot[f][k]
        seq.append(g)
        f, k = g, (kk + 2) % 4
    eff, ok = tumble_sequence_effect(G, 0, pad(seq + [-1, -1]))
    assert bool(ok)
    assert float(eff.angle) == pytest.approx(0.0, abs=1e-12)
    assert np.linalg.norm(np.asarray(eff.translation)) == pytest.approx(0.4, abs=1e-12)
    assert np.all(np.isnan(np.asarray(eff.fixed_point)))
