"""Tests for kernels.polyhedron: hull faces, naming, frames, angles, validation."""
from __future__ import annotations

import itertools
import math
import pathlib
import warnings

import jax


import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
import yaml  # noqa: E402
from hypothesis import given, settings, strategies as st  # noqa: E402

from tests.polyhedra import polyhedra  # noqa: E402
from kernels.polyhedron import (  # noqa: E402
    PartWarning,
    Polyhedron,
    TumbleGeometry,
    combinatorics_changed,
    make_polyhedron,
    tumble_geometry,
)

pytestmark = pytest.mark.float64  # calls kernels on float64 arrays directly

EXAMPLES = pathlib.Path(__file__).resolve().parents[1] / "examples"
PI = math.pi
HSET = settings(derandomize=True, max_examples=12, deadline=None)

CUBE = np.array(list(itertools.product([0.0, 1.0], repeat=3)))
TETRA = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float)
OCTA = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)


def random_points(seed: int, n: int | None = None) -> np.ndarray:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(5, 14)) if n is None else n
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return d * rng.uniform(0.6, 1.0, size=(n, 1)) * rng.uniform(0.05, 2.0)


def quiet(vertices, com=None) -> Polyhedron:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PartWarning)
        return make_polyhedron(vertices, com)


def load_example(name: str) -> Polyhedron:
    doc = yaml.safe_load((EXAMPLES / f"{name}.yaml").read_text())
    assert doc["kind"] == "polyhedron" and doc["name"] == name
    return make_polyhedron(doc["vertices"], doc.get("com"))


EXAMPLE_NAMES = ["cube", "tetrahedron", "octahedron", "truncated_pyramid", "irregular_polyhedron"]


# ---------------------------------------------------------------- counts, angles
def test_cube_counts_and_angles():
    P = make_polyhedron(CUBE)
    assert (P.n_faces, P.n_edges, P.n_vertices) == (6, 12, 8)
    assert all(len(f) == 4 for f in P.faces)
    np.testing.assert_allclose(P.defect_angles, PI / 2, atol=1e-12)
    np.testing.assert_allclose(P.dihedral_angles, PI / 2, atol=1e-12)
    for fa in P.face_angles:
        np.testing.assert_allclose(fa, PI / 2, atol=1e-12)
    np.testing.assert_allclose(P.com, [0.5, 0.5, 0.5], atol=1e-12)
    assert P.volume == pytest.approx(1.0)
    assert P.dropped == ()


@pytest.mark.parametrize(
    "verts, nf, ne, nv, defect, dihedral",
    [
        (TETRA, 4, 6, 4, PI, math.acos(1 / 3)),
        (OCTA, 8, 12, 6, 2 * PI / 3, math.acos(-1 / 3)),
    ],
)
def test_regular_solids(verts, nf, ne, nv, defect, dihedral):
    P = make_polyhedron(verts)
    assert (P.n_faces, P.n_edges, P.n_vertices) == (nf, ne, nv)
    np.testing.assert_allclose(P.defect_angles, defect, atol=1e-12)
    np.testing.assert_allclose(P.dihedral_angles, dihedral, atol=1e-12)
    for fa in P.face_angles:
        np.testing.assert_allclose(fa, PI / 3, atol=1e-12)
    np.testing.assert_allclose(P.com, verts.mean(axis=0), atol=1e-12)


def test_truncated_pyramid_is_not_a_cube():
    P = load_example("truncated_pyramid")
    assert (P.n_faces, P.n_edges, P.n_vertices) == (6, 12, 8)
    np.testing.assert_allclose(P.defect_angles.sum(), 4 * PI, atol=1e-12)
    # defects differ from pi/2 (paper Fig. 2: dense reachable set)
    assert np.all(np.abs(P.defect_angles - PI / 2) > 1e-3)
    # frustum centroid height h (A1 + 2 sqrt(A1 A2) + 3 A2) / (4 (A1 + sqrt(A1 A2) + A2))
    A1, A2, h = 0.01, 0.0081, 0.1
    zc = h * (A1 + 2 * math.sqrt(A1 * A2) + 3 * A2) / (4 * (A1 + math.sqrt(A1 * A2) + A2))
    np.testing.assert_allclose(P.com, [0, 0, zc], atol=1e-12)
    assert P.volume == pytest.approx(h / 3 * (A1 + A2 + math.sqrt(A1 * A2)))


@HSET
@given(st.integers(0, 2**31 - 1))
def test_descartes_and_euler_on_random_hulls(seed):
    P = quiet(random_points(seed))
    assert P.n_vertices - P.n_edges + P.n_faces == 2
    np.testing.assert_allclose(P.defect_angles.sum(), 4 * PI, atol=1e-9)
    assert np.all(P.defect_angles > 0)
    for cyc, fa in zip(P.face_cycles, P.face_angles):
        assert fa.sum() == pytest.approx((len(cyc) - 2) * PI, abs=1e-9)
    assert np.all((P.dihedral_angles > 0) & (P.dihedral_angles < PI))
    _check_structure(P)


# ---------------------------------------------------------------- naming and frames
def _check_structure(P: Polyhedron):
    v = P.vertices
    # faces: sorted tuples in lexicographic order; cycles start at the min
    assert all(tuple(sorted(f)) == f for f in P.faces)
    assert list(P.faces) == sorted(P.faces)
    for f, cyc in zip(P.faces, P.face_cycles):
        assert set(cyc) == set(f) and cyc[0] == min(cyc)
    # edges (a < b), sorted, each in exactly two faces with adjacency recorded
    assert list(P.edges) == sorted(P.edges) and all(a < b for a, b in P.edges)
    for (a, b), (f, g), dih in zip(P.edges, P.edge_faces, P.dihedral_angles):
        owners = [i for i, c in enumerate(P.face_cycles) if a in c and b in c]
        assert owners == [f, g]
        assert P.shared_edge(f, g) == (a, b)
        assert g in P.neighbors(f) and f in P.neighbors(g)
        n1, n2 = P.normals[f], P.normals[g]
        # atan2, not acos: accurate for nearly coplanar faces (dihedral near pi)
        assert dih == pytest.approx(PI - math.atan2(np.linalg.norm(np.cross(n1, n2)), n1 @ n2),
                                    abs=1e-9)
    for f, cyc in enumerate(P.face_cycles):
        n = P.normals[f]
        s = len(cyc)
        assert len(P.neighbors(f)) == s
        for k in range(s):
            p, q, r = v[cyc[k - 1]], v[cyc[k]], v[cyc[(k + 1) % s]]
            # CCW seen from outside: (q - p) x (r - q) along the outward normal
            assert np.cross(q - p, r - q) @ n > 0
        # outward: all hull vertices on the inner side
        hv = v[list(P.hull_vertices)]
        d = hv @ n - v[cyc[0]] @ n
        assert np.all(d <= 1e-9 * np.ptp(v, axis=0).max())
        # frame
        R, o = P.face_rotations[f], P.face_origins[f]
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(R) == pytest.approx(1.0)
        np.testing.assert_allclose(R[2], -n, atol=1e-12)  # z inward
        e = v[cyc[1]] - v[cyc[0]]
        np.testing.assert_allclose(R[0], e / np.linalg.norm(e), atol=1e-12)  # x along slot 0
        np.testing.assert_allclose(R[1], np.cross(R[2], R[0]), atol=1e-12)
        # origin: projection of com onto the face plane
        assert (o - v[cyc[0]]) @ n == pytest.approx(0.0, abs=1e-12)
        np.testing.assert_allclose(np.cross(P.com - o, n), 0.0, atol=1e-12)
        assert (P.com - o) @ R[2] > 0  # com above the face when it is down
        # 2-D corners match 3-D, and run clockwise in face coordinates
        c2 = P.face_corners_2d[f]
        np.testing.assert_allclose(((v[list(cyc)] - o) @ R.T)[:, :2], c2, atol=1e-12)
        area2 = np.sum(c2[:, 0] * np.roll(c2[:, 1], -1) - np.roll(c2[:, 0], -1) * c2[:, 1])
        assert area2 < 0
    # vertex_faces: cyclic, consecutive faces share an edge through the vertex
    for i in P.hull_vertices:
        ring = P.vertex_faces(i)
        assert ring[0] == min(ring)
        assert sorted(ring) == [f for f, c in enumerate(P.face_cycles) if i in c]
        for f, g in zip(ring, ring[1:] + ring[:1]):
            assert i in P.shared_edge(f, g)


@pytest.mark.parametrize("name", EXAMPLE_NAMES)
def test_examples_load_and_are_consistent(name):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        P = load_example(name)
    _check_structure(P)
    np.testing.assert_allclose(P.defect_angles.sum(), 4 * PI, atol=1e-12)


def test_cube_face_numbering_and_frames_explicit():
    P = make_polyhedron(CUBE)
    # vertex i has coordinates given by the bits of i: (i>>2, (i>>1)&1, i&1)
    assert P.faces == ((0, 1, 2, 3), (0, 1, 4, 5), (0, 2, 4, 6), (1, 3, 5, 7), (2, 3, 6, 7), (4, 5, 6, 7))
    assert P.face_cycles[0] == (0, 1, 3, 2)  # x = 0 face, CCW seen from -x
    R = P.face_rotations[0]
    np.testing.assert_allclose(R[0], [0, 0, 1], atol=1e-15)  # 0 -> 1 is +z
    np.testing.assert_allclose(R[2], [1, 0, 0], atol=1e-15)  # inward
    np.testing.assert_allclose(R[1], [0, -1, 0], atol=1e-15)
    np.testing.assert_allclose(P.face_origins[0], [0, 0.5, 0.5], atol=1e-15)
    np.testing.assert_allclose(P.face_corners_2d[0], [[-0.5, 0.5], [0.5, 0.5], [0.5, -0.5], [-0.5, -0.5]], atol=1e-15)
    assert P.face_index([3, 2, 1, 0]) == 0
    assert P.vertex_faces(7) == (3, 5, 4)
    assert P.neighbors(0) == (1, 3, 4, 2)


def test_vertex_order_is_kept_and_com_is_honoured():
    perm = [5, 2, 7, 0, 3, 6, 1, 4]
    V = CUBE[perm]
    P = make_polyhedron(V, com=[0.4, 0.5, 0.6])
    names = {tuple(sorted(perm.index(i) for i in f)) for f in make_polyhedron(CUBE).faces}
    assert set(P.faces) == names
    np.testing.assert_allclose(P.com, [0.4, 0.5, 0.6])
    for f, cyc in enumerate(P.face_cycles):
        o = P.face_origins[f]
        np.testing.assert_allclose(np.cross(P.com - o, P.normals[f]), 0, atol=1e-12)


def test_merging_cube_given_with_rounding_noise():
    rng = np.random.default_rng(3)
    V = CUBE + rng.uniform(-1e-13, 1e-13, CUBE.shape)
    P = make_polyhedron(V)
    assert P.n_faces == 6 and P.n_edges == 12


# ---------------------------------------------------------------- dropped points
def test_interior_and_boundary_points_are_dropped_with_warning():
    V = np.vstack([CUBE, [[0.5, 0.5, 0.5], [0.5, 0.5, 1.0], [1.0, 1.0, 0.5], CUBE[3]]])
    with pytest.warns(PartWarning, match=r"\[8, 9, 10, 11\]"):
        P = make_polyhedron(V)
    assert P.dropped == (8, 9, 10, 11)
    assert P.hull_vertices == tuple(range(8))
    assert P.faces == make_polyhedron(CUBE).faces
    np.testing.assert_allclose(P.com, [0.5, 0.5, 0.5], atol=1e-12)


# ---------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    "verts, pattern",
    [
        (np.vstack([CUBE[:7], [[np.nan, 0, 0]]]), r"vertices.*\[7\].*not finite"),
        (np.vstack([CUBE[:7], [[0, np.inf, 0]]]), r"vertices.*not finite"),
        (CUBE[:, :2], r"vertices.*\(m, 3\)"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], r"vertices.*at least 4"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0.3, 0.2, 0]], r"vertices.*coplanar"),
        ([[0, 0, 0], [1, 1, 1], [2, 2, 2], [3, 3, 3]], r"vertices.*coplanar"),
        ([[0, 0, 0]] * 5, r"vertices.*coplanar"),
        ([["a", 0, 0]] * 4, r"vertices"),
    ],
)
def test_bad_vertices(verts, pattern):
    with pytest.raises(ValueError, match=pattern):
        make_polyhedron(verts)


@pytest.mark.parametrize(
    "com, pattern",
    [
        ([2.0, 0.5, 0.5], r"com.*outside"),
        ([0.5, 0.5, 1.0], r"com.*on the boundary"),
        ([1.0, 1.0, 1.0], r"com.*on the boundary"),
        ([np.nan, 0.5, 0.5], r"com.*not finite"),
        ([0.5, 0.5], r"com.*shape"),
    ],
)
def test_bad_com(com, pattern):
    with pytest.raises(ValueError, match=pattern):
        make_polyhedron(CUBE, com)


# ---------------------------------------------------------------- JAX geometry
def _assert_geometry_matches(P: Polyhedron, G: TumbleGeometry, atol):
    np.testing.assert_allclose(np.asarray(G.normals), P.normals, atol=atol)
    np.testing.assert_allclose(np.asarray(G.origins), P.face_origins, atol=atol)
    np.testing.assert_allclose(np.asarray(G.rotations), P.face_rotations, atol=atol)
    for f, c2 in enumerate(P.face_corners_2d):
        np.testing.assert_allclose(np.asarray(G.corners_2d[f, : len(c2)]), c2, atol=atol)


@pytest.mark.parametrize("name", EXAMPLE_NAMES)
def test_tumble_geometry_matches_host_frames(name):
    P = load_example(name)
    G = P.geometry()
    assert G.corners_2d.dtype == jnp.float64
    _assert_geometry_matches(P, G, 1e-12)
    G32 = P.geometry(jnp.float32)
    assert G32.corners_2d.dtype == jnp.float32 and G32.rotations.dtype == jnp.float32
    _assert_geometry_matches(P, G32, 1e-6)
    assert G.topology.n_faces == P.n_faces
    np.testing.assert_array_equal(G.next_face[0][: len(P.neighbors(0))], P.neighbors(0))


@HSET
@given(st.integers(0, 2**31 - 1))
def test_tumble_geometry_matches_host_frames_random(seed):
    # two point counts only: the jitted builder compiles per array shape
    P = quiet(random_points(seed, n=(7, 10)[seed % 2]))
    _assert_geometry_matches(P, P.geometry(), 1e-10)


def test_tumble_geometry_is_a_pytree_and_vmaps():
    P = load_example("irregular_polyhedron")
    leaves, treedef = jax.tree_util.tree_flatten(P.geometry())
    assert len(leaves) == 7
    hash(P.topology)
    rng = np.random.default_rng(0)
    V = P.vertices[None] + rng.normal(scale=1e-4, size=(6,) + P.vertices.shape)
    build = jax.jit(jax.vmap(tumble_geometry, in_axes=(0, None, None)), static_argnums=2)
    Gb = build(jnp.asarray(V), jnp.asarray(P.com), P.topology)
    assert Gb.rotations.shape == (6, P.n_faces, 3, 3)
    for i in range(6):
        Gi = tumble_geometry(jnp.asarray(V[i]), jnp.asarray(P.com), P.topology)
        for a, b in zip(jax.tree_util.tree_leaves(Gi), jax.tree_util.tree_leaves(Gb)):
            np.testing.assert_allclose(np.asarray(b[i]), np.asarray(a), atol=1e-14)


def test_newell_normals_on_nonplanar_perturbed_faces():
    P = make_polyhedron(CUBE)
    rng = np.random.default_rng(1)
    V = CUBE + rng.normal(scale=1e-3, size=CUBE.shape)
    G = tumble_geometry(jnp.asarray(V), jnp.asarray(P.com), P.topology)
    n = np.asarray(G.normals)
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-14)
    assert np.max(np.abs(n - P.normals)) < 1e-2
    R = np.asarray(G.rotations)
    for f in range(P.n_faces):
        np.testing.assert_allclose(R[f] @ R[f].T, np.eye(3), atol=1e-13)
        assert np.linalg.det(R[f]) == pytest.approx(1.0)
        o = np.asarray(G.origins[f])
        # origin on the fitted plane (through the corners' mean) and below the com
        assert n[f] @ o == pytest.approx(float(G.offsets[f]), abs=1e-14)
        np.testing.assert_allclose(np.cross(np.asarray(G.com) - o, n[f]), 0, atol=1e-13)
        # 2-D corners are the projections on the fitted plane
        cyc = list(P.face_cycles[f])
        proj = (V[cyc] - o) @ R[f].T
        np.testing.assert_allclose(np.asarray(G.corners_2d[f, : len(cyc)]), proj[:, :2], atol=1e-14)
        assert np.max(np.abs(proj[:, 2])) < 1e-2


def test_combinatorics_changed():
    P = make_polyhedron(CUBE)
    assert not combinatorics_changed(CUBE, P)
    rng = np.random.default_rng(2)
    V = CUBE + rng.uniform(-1e-8, 1e-8, CUBE.shape)
    assert not combinatorics_changed(V, P, tol=1e-6)  # squares still merge
    V = CUBE + rng.uniform(-1e-3, 1e-3, CUBE.shape)
    assert combinatorics_changed(V, P, tol=1e-6)  # squares split into triangles
    Q = make_polyhedron(TETRA)
    assert not combinatorics_changed(TETRA + 1e-3 * rng.normal(size=(4, 3)), Q)
    # a vertex pushed inside the hull: it is no longer a vertex
    V = OCTA.copy()
    V[0] = [-0.1, 0, 0]
    assert combinatorics_changed(V, make_polyhedron(OCTA))
    with pytest.raises(ValueError, match="vertices"):
        combinatorics_changed(CUBE[:6], P)


# ---------------------------------------------------------------- hard families
@settings(derandomize=True, max_examples=40, deadline=None)
@given(polyhedra())
def test_hard_families_are_consistent(case):
    """Non-triangular faces (prisms, frustums), nearly coplanar faces (a ridge
    from 1e-11 to 1e-4 of the size high: merged, or kept apart with
    nearly straight corners) and slivers: a closed, consistent hull."""
    family, V = case
    P = quiet(V)
    assert P.n_vertices - P.n_edges + P.n_faces == 2
    np.testing.assert_allclose(P.defect_angles.sum(), 4 * PI, atol=1e-9)
    assert np.all(P.defect_angles > -1e-9)
    for cyc, fa in zip(P.face_cycles, P.face_angles):
        assert fa.sum() == pytest.approx((len(cyc) - 2) * PI, abs=1e-9)
    _check_structure(P)
    if family in ("prism", "frustum", "box"):
        assert max(len(c) for c in P.face_cycles) >= 4


def test_nearly_coplanar_ridge_keeps_faces_closed():
    """A ridge just above the merge tolerance on a box's top: the two halves
    stay separate faces and the ridge's ends stay corners of the end faces
    (a per-face choice dropped them from one face only: 'faces do not close
    up')."""
    V = np.array([[x, y, z] for x in (-0.04, 0.04) for y in (-0.03, 0.03) for z in (-0.02, 0.02)])
    for h in (3e-11, 5.9e-11, 8e-11, 1e-10, 1.5e-10, 1e-9, 1e-6):
        W = np.concatenate([V, [[0.0, -0.03, 0.02 + h], [0.0, 0.03, 0.02 + h]]])
        P = quiet(W)
        assert P.n_vertices - P.n_edges + P.n_faces == 2
        _check_structure(P)
        if 8 in P.hull_vertices:
            assert P.n_faces == 7 and sorted(len(c) for c in P.face_cycles) == [4] * 5 + [5] * 2
        else:
            assert P.n_faces == 6 and P.dropped == (8, 9)


@pytest.mark.parametrize("scale, warns", [(1.0, False), (0.05, False), (1e-4, False), (30.0, True),
                                          (1e-6, True), (1e9, True)])
def test_implausible_sizes_warn(scale, warns):
    """A part given in millimetres (30 'metres' across) or nanometres is
    accepted, with a PartWarning that says what was assumed; metres do not warn."""
    V = CUBE * scale
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        P = make_polyhedron(V)
    msgs = [str(w.message) for w in caught if issubclass(w.category, PartWarning)]
    assert bool(msgs) == warns, msgs
    if warns:
        assert "implausible" in msgs[0] and "metres" in msgs[0]
        assert f"{math.sqrt(3) * scale:.3g} m across" in msgs[0]
    # the same part at any scale: relative tolerances, same combinatorics and angles
    assert P.faces == make_polyhedron(CUBE).faces
    np.testing.assert_allclose(P.defect_angles, PI / 2, atol=1e-12)
