"""Perturbation samplers: shapes, vmap axes, determinism, bounds, hull checks."""
import dataclasses
import math
import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from kernels import polygon as pg
from kernels.hulls import polygon_hull_changed
from kernels.polyhedron import PartWarning, make_polyhedron
from robustness.hulls import face_merge_tol, polyhedron_combinatorics_changed
from robustness.samplers import Draws, Sampler, parameter_columns
from robustness.tolerances import ExecutionTolerance, FrictionRange, GeometryTolerance

pytestmark = pytest.mark.float64  # calls kernels on float64 arrays directly

PENT = np.array([[0.0, 0.0], [0.028, 0.0], [0.034, 0.016], [0.016, 0.027], [-0.004, 0.015]])
CUBE = np.array([[x, y, z] for x in (-0.05, 0.05) for y in (-0.05, 0.05) for z in (-0.05, 0.05)])
N = 256

FULL = Sampler(
    GeometryTolerance(tau_v=1e-4, tau_com=2e-4, distribution="gaussian", sigma_v=8e-5),
    FrictionRange(mu_f=(0.2, 0.8), mu_s=(0.3, 0.4), support_points=8, weight_concentration=2,
                  support="points"),
    ExecutionTolerance(start_xy=1e-3, start_theta=0.02, fence_angle=0.003, distance_abs=1e-4,
                       distance_rel=0.01, tumble_slip_xy=1e-5, tumble_slip_theta=1e-4))


@pytest.fixture(scope="module")
def poly():
    return pg.make_polygon(PENT)


@pytest.fixture(scope="module")
def drawn(poly):
    return FULL.sample(jax.random.key(3), N, n_vertices=5, dim=2, n_pushes=4, n_tumbles=3,
                       body=poly.body)


def test_shapes_and_in_axes(drawn):
    p, ax = drawn.params, drawn.in_axes
    assert p.geometry.vertex_offset.shape == (N, 5, 2) and ax.geometry.vertex_offset == 0
    assert p.geometry.com_offset.shape == (N, 2) and ax.geometry.com_offset == 0
    assert p.friction.mu_f.shape == (N,) and p.friction.c.shape == (N,)
    assert p.friction.support_points.shape == (N, 8, 2)
    assert p.execution.start_offset.shape == (N, 3)
    assert p.execution.fence_angle.shape == (N, 4) and ax.execution.fence_angle == 0
    assert p.execution.tumble_slip.shape == (N, 3, 3)
    # the in_axes drive jax.vmap directly
    out = jax.vmap(lambda q: q.geometry.vertex_offset.sum() + q.friction.c,
                   in_axes=(ax,))(p)
    assert out.shape == (N,)



@pytest.mark.slow
def test_draws_are_one_value(drawn):
    """Draws: the arrays traced (a pytree through jit), the layout static; slices and
    casts keep the layout and the sample count with it."""
    assert isinstance(drawn, Draws) and drawn.n == N
    leaves, tree = jax.tree_util.tree_flatten(drawn)
    assert len(leaves) == len(jax.tree_util.tree_leaves(drawn.params))
    assert jax.tree_util.tree_unflatten(tree, leaves).in_axes == drawn.in_axes
    total = jax.jit(lambda d: d.params.geometry.vertex_offset.sum(axis=(1, 2)) * d.n)(drawn)
    np.testing.assert_allclose(np.asarray(total),
                               np.asarray(drawn.params.geometry.vertex_offset).sum(axis=(1, 2)) * N)
    part = drawn.slice(10, 20)
    assert part.n == 10 and part.in_axes == drawn.in_axes
    np.testing.assert_array_equal(np.asarray(part.params.friction.mu_f),
                                  np.asarray(drawn.params.friction.mu_f)[10:20])
    assert drawn.slice(250, 300).n == 6
    one = drawn.take(3)
    assert float(one.friction.c) == float(drawn.params.friction.c[3])
    f32 = drawn.astype(jnp.float32)
    assert f32.params.friction.c.dtype == jnp.float32 and f32.n == N
    assert f32.params.friction.family.dtype == drawn.params.friction.family.dtype   # codes kept
    # the first n of a larger draw are the draws of n (what the padded bucket relies on)
    few = FULL.sample(jax.random.key(3), 5, n_vertices=5, dim=2, n_pushes=4, n_tumbles=3,
                      body=pg.make_polygon(PENT).body)
    np.testing.assert_array_equal(np.asarray(few.params.geometry.vertex_offset),
                                  np.asarray(drawn.params.geometry.vertex_offset)[:5])

def test_zero_tolerances_are_unbatched(poly):
    draws = Sampler(friction=FrictionRange(mu_f=(0.5, 0.5))).sample(
        jax.random.key(0), 8, n_vertices=5, dim=2, n_pushes=2, body=poly.body)
    p, ax = draws.params, draws.in_axes
    assert ax.geometry.vertex_offset is None and p.geometry.vertex_offset.shape == (5, 2)
    assert ax.friction.mu_f is None and float(p.friction.mu_f) == 0.5
    assert ax.execution.fence_angle is None and ax.execution.start_offset is None
    assert ax.friction.c == 0  # c still comes from a sampled pressure distribution
    full = draws.broadcast()
    assert full.geometry.vertex_offset.shape == (8, 5, 2)
    assert np.all(np.asarray(full.geometry.vertex_offset) == 0)
    one = draws.take(3)
    assert one.friction.c.shape == ()


def test_deterministic_by_key(poly, drawn):
    p = drawn.params
    draws = FULL.sample(jax.random.key(3), N, n_vertices=5, dim=2, n_pushes=4, n_tumbles=3,
                        body=poly.body)
    q = draws.params
    draws = FULL.sample(jax.random.key(4), N, n_vertices=5, dim=2, n_pushes=4, n_tumbles=3,
                        body=poly.body)
    r = draws.params
    for a, b, c in zip(jax.tree_util.tree_leaves(p), jax.tree_util.tree_leaves(q),
                       jax.tree_util.tree_leaves(r)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    assert not np.array_equal(np.asarray(p.geometry.vertex_offset), np.asarray(r.geometry.vertex_offset))
    # groups draw from their own sub-keys: other friction settings leave the geometry draws alone
    s2 = dataclasses.replace(FULL, friction=FrictionRange(mu_f=(0.1, 0.2), support_points=4,
                                                                       support="points"))
    draws = s2.sample(jax.random.key(3), N, n_vertices=5, dim=2, n_pushes=4, n_tumbles=3,
                      body=poly.body)
    q2 = draws.params
    np.testing.assert_array_equal(np.asarray(p.geometry.vertex_offset),
                                  np.asarray(q2.geometry.vertex_offset))


def test_bounds_respected(poly, drawn):
    p = drawn.params
    g, f, e = p.geometry, p.friction, p.execution
    assert np.max(np.abs(np.asarray(g.vertex_offset))) <= 1e-4
    assert np.max(np.linalg.norm(np.asarray(g.com_offset), axis=1)) <= 2e-4 * (1 + 1e-12)
    assert np.asarray(g.vertex_offset).std() > 1e-5  # not degenerate
    mu = np.asarray(f.mu_f)
    assert mu.min() >= 0.2 and mu.max() <= 0.8
    radius = float(np.max(np.linalg.norm(poly.body, axis=1)))
    c = np.asarray(f.c)
    assert np.all(c > 0) and np.all(c <= radius)
    w = np.asarray(f.support_weights)
    np.testing.assert_allclose(w.sum(axis=1), 1.0, rtol=1e-12)
    # support points inside the (convex, CCW) body polygon
    pts = np.asarray(f.support_points).reshape(-1, 2)
    e0 = np.roll(poly.body, -1, axis=0) - poly.body
    rel = pts[:, None, :] - poly.body[None]
    assert np.all(e0[None, :, 0] * rel[..., 1] - e0[None, :, 1] * rel[..., 0] >= -1e-15)
    for arr, half in ((e.start_offset[:, :2], 1e-3), (e.start_offset[:, 2], 0.02),
                      (e.fence_angle, 0.003), (e.distance_abs, 1e-4), (e.distance_rel, 0.01),
                      (e.tumble_slip[..., :2], 1e-5), (e.tumble_slip[..., 2], 1e-4)):
        a = np.asarray(arr)
        assert np.max(np.abs(a)) <= half and np.max(np.abs(a)) > 0.3 * half


def test_settings_validated():
    with pytest.raises(ValueError, match="tau_v"):
        GeometryTolerance(tau_v=-1e-4)
    with pytest.raises(ValueError, match="tau_com"):
        GeometryTolerance(tau_com=float("nan"))
    with pytest.raises(ValueError, match="mu_f"):
        FrictionRange(mu_f=(0.8, 0.2))
    with pytest.raises(ValueError, match="fence_angle"):
        ExecutionTolerance(fence_angle=-0.1)
    with pytest.raises(ValueError, match="distribution"):
        GeometryTolerance(distribution="cauchy")


@pytest.mark.slow
def test_polygon_hull_change_detection(poly):
    V0 = jnp.asarray(poly.vertices)
    com = jnp.asarray(poly.com)
    hi = tuple(poly.hull_index)
    check = jax.jit(jax.vmap(lambda dv, dc: polygon_hull_changed(V0 + dv, com + dc, jnp.asarray(hi))))
    for tau, expect in ((1e-5, "none"), (1.5e-2, "some")):
        draws = Sampler(GeometryTolerance(tau_v=tau)).sample(
            jax.random.key(1), 400, n_vertices=5, dim=2, body=poly.body)
        p = draws.broadcast()
        changed = np.asarray(check(p.geometry.vertex_offset, p.geometry.com_offset))
        if expect == "none":
            assert not changed.any()
        else:
            assert changed.any() and not changed.all()
    # a reflex vertex by construction
    bad = np.asarray(poly.vertices).copy()
    bad[2] = 0.5 * (bad[1] + bad[3]) - np.array([0.003, 0.003])
    assert bool(polygon_hull_changed(jnp.asarray(bad), com, jnp.asarray(hi)))


def test_polyhedron_combinatorics_change_detection():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PartWarning)
        cube = make_polyhedron(CUBE)
    diam = float(np.max(np.linalg.norm(CUBE[:, None] - CUBE[None], axis=-1)))
    for tau, expect in ((1e-5, False), (3e-2, True)):
        draws = Sampler(GeometryTolerance(tau_v=tau)).sample(jax.random.key(2), 12, n_vertices=8,
                                                               dim=3)
        p = draws.params
        V = CUBE[None] + np.asarray(p.geometry.vertex_offset)
        changed = polyhedron_combinatorics_changed(V, cube, face_merge_tol(tau, diam))
        assert changed.shape == (12,)
        assert changed.any() == expect and (expect or not changed.any())


def test_parameter_columns(drawn):
    p = drawn.params
    cols = parameter_columns(drawn, n_vertices=5, dim=2, n_pushes=4, n_tumbles=3,
                             max_pushes=6)
    assert "dv4_y_m" in cols and "dcom_x_m" in cols and "c_m" in cols
    assert "fence_angle_err_rad_p3" in cols and np.all(np.isnan(cols["push_dist_abs_err_m_p5"]))
    assert "slip_sum_dtheta_rad" in cols
    assert all(len(v) == N for v in cols.values())
    assert all(np.asarray(v).dtype == np.float64 for k, v in cols.items() if k != "support")
    assert set(cols["support"]) == {"points"}
    assert math.isclose(cols["dv1_x_m"][7], float(p.geometry.vertex_offset[7, 1, 0]))


# --------------------------------------------------------------------------
# Only the used columns are drawn, and they are the full block's numbers
# --------------------------------------------------------------------------
from hypothesis import given, settings, strategies as st  # noqa: E402

from robustness import samplers as smp  # noqa: E402
from robustness.uniforms import threefry2x32, uniform_columns  # noqa: E402


@settings(max_examples=25, deadline=None)
@given(k=st.tuples(st.integers(0, 2 ** 32 - 1), st.integers(0, 2 ** 32 - 1)),
       x=st.lists(st.tuples(st.integers(0, 2 ** 32 - 1), st.integers(0, 2 ** 32 - 1)),
                  min_size=1, max_size=40))
def test_threefry_written_out_is_jaxs_primitive(k, x):
    """The hash round by round gives the bits of JAX's threefry2x32 primitive
    (the oracle), for any key and counters, eagerly and under jit."""
    from jax.extend.random import threefry2x32_p

    k1, k2 = (jnp.uint32(v) for v in k)
    x1, x2 = (jnp.asarray(np.array(c, np.uint32)) for c in zip(*x))
    want = [np.asarray(w) for w in threefry2x32_p.bind(k1, k2, x1, x2)]
    for fn in (threefry2x32, jax.jit(threefry2x32)):
        got = fn(k1, k2, x1, x2)
        for g, w in zip(got, want):
            assert g.dtype == jnp.uint32
            np.testing.assert_array_equal(np.asarray(g), w)


@settings(max_examples=15)
@given(n=st.integers(0, 40), width=st.integers(1, 90), data=st.data(),
       f64=st.booleans(), typed=st.booleans(), seed=st.integers(0, 2 ** 31 - 1))
def test_uniform_columns_are_the_full_blocks(n, width, data, f64, typed, seed):
    cols = data.draw(st.lists(st.integers(0, width - 1), max_size=12))
    dt = jnp.float64 if f64 else jnp.float32
    key = jax.random.key(seed) if typed else jax.random.PRNGKey(seed)
    want = np.asarray(jax.random.uniform(key, (n, width), dt))[:, cols]
    got = uniform_columns(key, n, width, cols, dt)
    assert got.dtype == want.dtype and got.shape == want.shape
    np.testing.assert_array_equal(np.asarray(got), want)


def test_uniform_columns_under_jit_and_x32():
    key = jax.random.key(9)
    cols = [0, 40, 7, 7, 63]
    want = np.asarray(jax.random.uniform(key, (33, 64), jnp.float64))[:, cols]
    got = jax.jit(lambda k: uniform_columns(k, 33, 64, cols, jnp.float64))(key)
    np.testing.assert_array_equal(np.asarray(got), want)
    with jax.enable_x64(False):
        want = np.asarray(jax.random.uniform(key, (33, 64), jnp.float32))[:, cols]
        np.testing.assert_array_equal(np.asarray(uniform_columns(key, 33, 64, cols, jnp.float32)),
                                      want)


def test_uniform_columns_without_partitionable_threefry_slices_the_block():
    key = jax.random.key(5)
    with jax.threefry_partitionable(False):
        want = np.asarray(jax.random.uniform(key, (7, 30), jnp.float64))[:, [2, 29, 3]]
        np.testing.assert_array_equal(np.asarray(uniform_columns(key, 7, 30, [2, 29, 3])), want)
    with pytest.raises(ValueError, match="columns"):
        uniform_columns(key, 7, 30, [30])


@pytest.mark.parametrize("n_pushes,n_tumbles", [(3, 0), (17, 0), (0, 5), (0, 200)])
def test_the_draws_keep_the_blocks_layout(poly, n_pushes, n_tumbles):
    """Each field is read from its place in its group's block of uniforms,
    ``uniform(fold_in(key, group), (n, width))`` (the layout every table was
    drawn with): vertices then centre of mass; mu_f, mu_s, c, then the points
    family's columns; start, then per push the fence angle, relative and
    absolute distance errors (a bucket of columns each), then per tumble the
    slip.  The sampler computes only the used columns; the numbers are the
    block's."""
    dim = 2 if n_pushes else 3
    nv, n = (5, 9) if dim == 2 else (8, 9)
    s = Sampler(GeometryTolerance(tau_v=1e-4, tau_com=2e-4, com_shape="box"),
                FrictionRange(mu_f=(0.2, 0.8), mu_s=(0.3, 0.4), c=(0.004, 0.009), support="tripod"),
                ExecutionTolerance(start_xy=1e-3, start_theta=0.02, fence_angle=0.003,
                                   distance_abs=1e-4, distance_rel=0.01, tumble_slip_xy=1e-5,
                                   tumble_slip_theta=1e-4))
    key = jax.random.key(4)
    d = s.sample(key, n, n_vertices=nv, dim=dim, n_pushes=n_pushes, n_tumbles=n_tumbles,
                 body=poly.body if dim == 2 else None)
    p = d.params

    def block(group, width):
        return np.asarray(jax.random.uniform(jax.random.fold_in(key, group), (n, width),
                                             jnp.float64))

    def close(got, want):
        np.testing.assert_allclose(np.asarray(got), want, rtol=1e-13, atol=0)

    mv = nv * dim
    g = block(smp.GEOMETRY, mv + dim + 1)
    close(p.geometry.vertex_offset, ((2 * g[:, :mv] - 1) * 1e-4).reshape(n, nv, dim))
    close(p.geometry.com_offset, (2 * g[:, mv:mv + dim] - 1) * 2e-4)
    f = block(smp.FRICTION, 3 + 16 * 4)
    close(p.friction.mu_f, 0.2 + f[:, 0] * 0.6)
    close(p.friction.mu_s, 0.3 + f[:, 1] * (0.4 - 0.3))
    if dim == 2:
        close(p.friction.c, 0.004 + f[:, 2] * (0.009 - 0.004))
    P, L = smp.steps_bucket(n_pushes), smp.steps_bucket(n_tumbles)
    e = block(smp.EXECUTION, 3 + 3 * P + 3 * L)
    close(p.execution.start_offset, (2 * e[:, :3] - 1) * np.array([1e-3, 1e-3, 0.02]))
    if n_pushes:
        for field, at, half in (("fence_angle", 3, 0.003), ("distance_rel", 3 + P, 0.01),
                                ("distance_abs", 3 + 2 * P, 1e-4)):
            close(getattr(p.execution, field), (2 * e[:, at:at + n_pushes] - 1) * half)
    else:
        us = e[:, 3 + 3 * P:].reshape(n, L, 3)[:, :n_tumbles]
        close(p.execution.tumble_slip, (2 * us - 1) * np.array([1e-5, 1e-5, 1e-4]))


def test_drawn_steps():
    assert [smp.drawn_steps(k) for k in (0, 1, 3, 9, 16, 17, 200, 256, 1000)] == \
        [0, 1, 4, 16, 16, 18, 208, 256, 1024]
    for k in range(1, 3000):
        assert k <= smp.drawn_steps(k) <= smp.steps_bucket(k)
        assert k <= 16 or smp.drawn_steps(k) <= k * 9 // 8 + 1


@settings(max_examples=40, deadline=None)
@given(n=st.integers(0, 600), L=st.integers(0, 300), f32=st.booleans(),
       seed=st.integers(0, 2 ** 31 - 1), data=st.data())
def test_slip_sums_are_numpys_sums_bit_for_bit(n, L, f32, seed, data):
    """The compiled in-order sum of the slips gives the bits of numpy's sum over
    the tumbles (the slip_sum_* columns of every tumble table), for any shape and
    over the first k tumbles (draws that carry more columns than the plan's);
    the values span six decades, so a summation in another order (pairwise,
    blocked) would show in the last bits."""
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((n, L, 3)) * 10.0 ** rng.uniform(-6, 0, (n, L, 3))
    a = a.astype(np.float32) if f32 else a
    want = np.asarray(a, np.float64).sum(axis=1)
    got = smp.slip_sums(jnp.asarray(a))
    assert got.dtype == np.float64 and got.shape == (n, 3)
    np.testing.assert_array_equal(got, want)
    k = data.draw(st.integers(0, L))
    np.testing.assert_array_equal(smp.slip_sums(jnp.asarray(a), k),
                                  np.asarray(a, np.float64)[:, :k].sum(axis=1))


def test_slip_sums_without_x64_are_numpys():
    a = np.random.default_rng(1).standard_normal((5, 9, 3))
    with jax.enable_x64(False):
        np.testing.assert_array_equal(smp.slip_sums(a), a.sum(axis=1))
        np.testing.assert_array_equal(smp.slip_sums(a, 4), a[:, :4].sum(axis=1))
    with pytest.raises(ValueError, match="k: expected 0..9"):
        smp.slip_sums(a, 10)
