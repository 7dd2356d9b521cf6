"""Same hull?  The JAX checks of kernels.hulls against host-side references:
polyhedra against kernels.polyhedron.combinatorics_changed (Qhull + greedy face
merge), polygons against scipy.spatial.ConvexHull; random perturbations over
four decades of size and merge tolerance, and perturbations within 1e-7 of the
point where the reference's answer flips."""
from __future__ import annotations

import math
import warnings
import zlib

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.spatial import ConvexHull

from kernels import polygon as pg
from kernels.hulls import (polygon_hull_changed, polyhedron_hull_tables, polyhedron_hull_verdict,
                           polyhedron_hull_verdict_batch)
from kernels.polyhedron import PartWarning, combinatorics_changed, make_polyhedron
from robustness.hulls import polyhedra_changed
from tests.polyhedra import box, example, random_polyhedron

pytestmark = pytest.mark.float64   # calls kernels on float64 arrays directly


def _hexagonal_prism(r=0.05, h=0.04):
    return [[r * math.cos(k * math.pi / 3), r * math.sin(k * math.pi / 3), z]
            for k in range(6) for z in (-h / 2, h / 2)]


def _nearly_flat_edge():
    """A box with one top corner raised 0.5 mm: two top faces meet at ~0.6 degrees."""
    v = [list(p) for p in box(0.1, 0.08, 0.06)]
    v[7][2] += 0.0005
    return v


PARTS = {
    "cube": box(0.1, 0.1, 0.1),                                    # quadrilaterals
    "octahedron": example("octahedron")[0],                        # symmetric: ties of areas
    "irregular": example("irregular_polyhedron")[0],               # a quad and triangles
    "truncated_pyramid": example("truncated_pyramid")[0],
    "hexagonal_prism": _hexagonal_prism(),                         # hexagons: 20 triples a face
    "nearly_flat_edge": _nearly_flat_edge(),                       # merging across an edge
    "random12": random_polyhedron(3, 12).tolist(),                 # 20 triangles, slivers
}


def _poly(vertices):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PartWarning)
        return make_polyhedron(vertices)


def _jax(P, V, tol):
    """The JAX verdict, undecided samples resolved by the reference."""
    return polyhedra_changed(V, P, tol)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(PARTS))
def test_polyhedron_check_matches_reference_on_random_perturbations(name):
    """Each sample its own perturbation size (1e-5 .. 5e-2 of the diameter) and merge
    tolerance (0.3 .. 10 times the size): about half the samples change."""
    P = _poly(PARTS[name])
    V = np.asarray(P.vertices)
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    n = 160
    diam = float(np.max(np.linalg.norm(V[:, None] - V[None], axis=-1)))
    tau = diam * 10 ** rng.uniform(-5.0, -1.3, n)
    tol = np.maximum(1e-7, 10 ** rng.uniform(-0.5, 1.0, n) * tau / diam)
    Vs = V[None] + rng.uniform(-1, 1, (n,) + V.shape) * tau[:, None, None]
    ref = np.array([combinatorics_changed(Vs[i], P, tol=tol[i]) for i in range(n)])
    tb = polyhedron_hull_tables(P.topology)
    one = jax.jit(jax.vmap(lambda v, t: polyhedron_hull_verdict(v, tb, t)))
    got, und = (np.asarray(a) for a in one(jnp.asarray(np.concatenate([Vs, V[None]])),
                                            jnp.asarray(np.r_[tol, 1e-6])))
    assert not und.any()          # no dropped points on these parts: always decided
    assert not got[-1]            # the unperturbed part is never a change
    assert 0.1 < ref.mean() < 0.9 or name in ("nearly_flat_edge", "octahedron"), ref.mean()
    np.testing.assert_array_equal(got[:-1], ref)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(PARTS) + ["dropped_inside", "dropped_on_face"])
def test_polyhedron_check_on_the_boundary_of_the_reference(name):
    """Along random directions (all vertices, or one), find by bisection where the
    reference's answer flips; 1e-7 on either side the JAX check agrees."""
    parts = dict(PARTS, dropped_inside=box(0.1, 0.1, 0.1) + [[0.01, 0.0, 0.02]],
                 dropped_on_face=box(0.1, 0.1, 0.1) + [[0.01, 0.0, 0.05]])
    P = _poly(parts[name])
    V = np.asarray(P.vertices)
    m = len(V)
    diam = float(np.max(np.linalg.norm(V[:, None] - V[None], axis=-1)))
    rng = np.random.default_rng(len(name))
    flips = 0
    for _ in range(8):
        tol = 10 ** rng.uniform(-6.0, -2.5)
        dv = rng.uniform(-1, 1, (m, 3)) * diam
        if rng.random() < 0.5:                       # move one vertex only
            dv *= (np.arange(m) == rng.integers(m))[:, None]
        if combinatorics_changed(V, P, tol=tol) or not combinatorics_changed(V + dv, P, tol=tol):
            continue
        lo, hi = 0.0, 1.0
        for _ in range(48):
            mid = 0.5 * (lo + hi)
            lo, hi = (lo, mid) if combinatorics_changed(V + mid * dv, P, tol=tol) else (mid, hi)
        flips += 1
        pair = np.stack([V + lo * (1 - 1e-7) * dv, V + hi * (1 + 1e-7) * dv])
        np.testing.assert_array_equal(_jax(P, pair, tol), [False, True])
    assert flips >= 4


def test_polyhedron_check_undecided_is_left_to_the_reference():
    """A point listed on a face that pops out by less than the merge distance is left to
    the reference (undecided); sunk, it is no change; out by more, a change."""
    P = _poly(box(0.1, 0.1, 0.1) + [[0.01, 0.0, 0.05]])   # on the top face (z = 0.05)
    tb = polyhedron_hull_tables(P.topology)
    V = np.asarray(P.vertices)
    tol, diam = 1e-4, 2 * float(np.max(np.linalg.norm(V - V.mean(0), axis=1)))
    cases = ((-1e-6, False, False), (0.3 * tol * diam, False, True), (3 * tol * diam, True, False))
    W = np.repeat(V[None], len(cases), axis=0)
    W[:, 8, 2] += [dz for dz, _, _ in cases]
    c, u = jax.jit(lambda w: polyhedron_hull_verdict_batch(w, tb, tol))(jnp.asarray(W))
    assert np.asarray(c).tolist() == [ch for _, ch, _ in cases]
    assert np.asarray(u).tolist() == [un for _, _, un in cases]
    np.testing.assert_array_equal(polyhedra_changed(W, P, tol),
                                  [combinatorics_changed(w, P, tol=tol) for w in W])


def test_polyhedron_batch_equals_single_and_blocks():
    """The batch-last layout, its blocks and the single-sample function agree."""
    P = _poly(PARTS["irregular"])
    tb = polyhedron_hull_tables(P.topology)
    V = np.asarray(P.vertices)
    rng = np.random.default_rng(5)
    Vs = jnp.asarray(V[None] + rng.uniform(-3e-3, 3e-3, (700,) + V.shape))
    whole = jax.jit(lambda v: polyhedron_hull_verdict_batch(v, tb, 1e-2, block=10_000))(Vs)
    blocked = jax.jit(lambda v: polyhedron_hull_verdict_batch(v, tb, 1e-2, block=128))(Vs)
    single = jax.jit(jax.vmap(lambda v: polyhedron_hull_verdict(v, tb, 1e-2)))(Vs[:50])
    for a, b in zip(whole, blocked):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    np.testing.assert_array_equal(np.asarray(whole[0])[:50], np.asarray(single[0]))
    assert 0 < np.asarray(whole[0]).sum() < 700


# --------------------------------------------------------------------------
# polygons
# --------------------------------------------------------------------------
def _scipy_polygon_changed(pts, com) -> bool:
    """Reference: the hull of the points (in nominal hull order) keeps every point as a
    vertex, in the same cyclic CCW order, and has the centre of mass strictly inside."""
    try:
        h = ConvexHull(pts)
    except Exception:   # degenerate (collinear): changed
        return True
    ring = list(h.vertices)                                      # CCW in 2-D
    if len(ring) != len(pts):
        return True
    k = ring.index(0)
    if ring[k:] + ring[:k] != list(range(len(pts))):
        return True
    return not bool(np.all(h.equations[:, :2] @ com + h.equations[:, 2] < 0.0))


POLYGONS = {
    "pentagon": ([[0.0, 0.0], [0.028, 0.0], [0.034, 0.016], [0.016, 0.027], [-0.004, 0.015]], None),
    "biplus": ([[0.0, 0.0], [0.04, 0.0], [0.008, 0.006]], None),
    "flat_octagon": ([[math.cos(a) * 0.05, math.sin(a) * 0.05]
                      for a in np.arange(8) * math.pi / 4 + 0.1], None),
    "com_near_edge": ([[0.0, 0.0], [0.04, 0.0], [0.04, 0.02], [0.0, 0.02]], [0.02, 0.0008]),
}


@pytest.mark.parametrize("name", sorted(POLYGONS))
def test_polygon_check_matches_scipy(name):
    verts, com = POLYGONS[name]
    poly = pg.make_polygon(verts, com)
    hi = np.asarray(poly.hull_index)
    V0, c0 = np.asarray(poly.vertices), np.asarray(poly.com)
    size = float(np.max(np.linalg.norm(V0 - c0, axis=1)))
    rng = np.random.default_rng(len(name))
    n = 400
    tau = size * 10 ** rng.uniform(-3.0, 0.0, n)
    dv = rng.uniform(-1, 1, (n,) + V0.shape) * tau[:, None, None]
    dc = rng.uniform(-1, 1, (n, 2)) * tau[:, None]
    got = np.asarray(jax.jit(jax.vmap(lambda v, c: polygon_hull_changed(v, c, hi)))(
        jnp.asarray(V0 + dv), jnp.asarray(c0 + dc)))
    ref = np.array([_scipy_polygon_changed((V0 + dv[i])[hi], c0 + dc[i]) for i in range(n)])
    assert 0.03 < ref.mean() < 0.97, ref.mean()
    np.testing.assert_array_equal(got, ref)
    # on the boundary: bisect the reference's flip along a random direction
    flips = 0
    for _ in range(6):
        d, e = rng.uniform(-1, 1, V0.shape) * size, rng.uniform(-1, 1, 2) * size * 0.2
        if _scipy_polygon_changed(V0[hi], c0) or not _scipy_polygon_changed((V0 + d)[hi], c0 + e):
            continue
        lo, up = 0.0, 1.0
        for _ in range(48):
            mid = 0.5 * (lo + up)
            bad = _scipy_polygon_changed((V0 + mid * d)[hi], c0 + mid * e)
            lo, up = (lo, mid) if bad else (mid, up)
        flips += 1
        for s, want in ((lo * (1 - 1e-7), False), (up * (1 + 1e-7), True)):
            assert bool(polygon_hull_changed(jnp.asarray(V0 + s * d), jnp.asarray(c0 + s * e),
                                             hi)) == want
    assert flips >= 3
