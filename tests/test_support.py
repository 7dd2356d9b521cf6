"""Support pressure distributions: points in the part, weights centred under the
centre of mass (checked against scipy's minimiser of the same convex dual)."""
import numpy as np
import pytest
import jax
import jax.numpy as jnp
from hypothesis import given, settings, strategies as st
from scipy.optimize import minimize

from kernels import polygon as pg
from robustness import FrictionRange, Sampler
from robustness.support import centre_weights, centroid_offset, support_from_u

pytestmark = pytest.mark.float64

PENT = np.array([[0.0, 0.0], [0.028, 0.0], [0.034, 0.016], [0.016, 0.027], [-0.004, 0.015]])
THIN = np.array([[0.0, 0.0], [0.04, 0.0], [0.003, 0.006]])   # an obtuse sliver


#: one compiled centring per shape (the op-by-op vmap of the Newton loop took seconds per call)
_centre = jax.jit(jax.vmap(centre_weights))


def _draw(body, n, S, k, seed):
    u = jax.random.uniform(jax.random.key(seed), (n, S * (3 + k)), jnp.float64)
    return _support(u, jnp.asarray(body), S, k)


_support = jax.jit(lambda u, body, S, k: support_from_u(u, body, S, k, jnp.float64),
                   static_argnums=(2, 3))


@pytest.mark.slow
@settings(max_examples=25)
@given(st.integers(0, 10_000), st.sampled_from([(PENT, 16, 1), (PENT, 4, 8), (THIN, 16, 1),
                                                (THIN, 32, 64)]))
def test_centred_weights_balance_the_part(seed, case):
    poly, S, k = case
    body = pg.make_polygon(poly).body
    a = float(np.max(np.linalg.norm(body, axis=1)))
    pts, w = _draw(body, 8, S, k, seed)
    q = _centre(pts, w)
    q, pts = np.asarray(q), np.asarray(pts)
    assert np.all(q >= 0) and np.allclose(q.sum(axis=1), 1.0, atol=1e-12)
    off = np.linalg.norm(np.einsum("ns,nsd->nd", q, pts), axis=1)
    # centred wherever the centre of mass lies inside the points' hull (by 1% of the size)
    inside = np.array([_depth(p) for p in pts]) > 0.01 * a
    assert np.all(off[inside] <= 1e-8 * a), off[inside].max()


def _depth(points) -> float:
    """How deep the origin lies inside the points' convex hull (m; < 0 outside)."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        h = ConvexHull(points)
    except QhullError:
        return -1.0
    return float(-np.max(h.equations[:, 2]))


@pytest.mark.slow
def test_tilt_is_the_minimiser_of_the_convex_dual():
    body = pg.make_polygon(PENT).body
    pts, w = _draw(body, 1, 16, 1, 7)
    pts, w = np.asarray(pts[0]), np.asarray(w[0])
    a = np.max(np.linalg.norm(pts, axis=1))

    def dual(lam):
        z = np.log(w) + (pts / a) @ lam
        return np.log(np.sum(np.exp(z - z.max()))) + z.max()

    lam = minimize(dual, np.zeros(2), method="BFGS", options={"gtol": 1e-14}).x
    ref = w * np.exp((pts / a) @ lam)
    ref /= ref.sum()
    got = np.asarray(centre_weights(jnp.asarray(pts), jnp.asarray(w), iterations=30))
    assert np.allclose(got, ref, rtol=1e-6, atol=1e-12)


def test_sampler_support_is_centred_and_c_in_range():
    body = pg.make_polygon(PENT).body
    draws = Sampler(friction=FrictionRange(support_points=16, support="points")).sample(
        jax.random.key(0), 64, n_vertices=5, dim=2, body=body)
    f = draws.params.friction
    off = np.asarray(jax.vmap(centroid_offset)(f.support_points, f.support_weights))
    a = float(np.max(np.linalg.norm(body, axis=1)))
    assert np.quantile(off, 0.98) <= 1e-8 * a   # (a rare draw of 16 points leaves the centre
    assert np.mean(off <= 1e-6 * a) >= 0.98     # of mass outside their hull: the closest tilt)
    c = np.asarray(f.c)
    assert np.all((c > 0) & (c <= a))
    from kernels.quasistatic import limit_surface_ratio
    assert np.allclose(c, np.asarray(jax.vmap(limit_surface_ratio)(f.support_points, f.support_weights)))
