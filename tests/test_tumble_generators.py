"""Tests of the analysis modules of the tumbling planner, part by part, against
hand-derived facts (rotations -> generators -> lattice -> class):
:mod:`planning.tumbling.development`, :mod:`~planning.tumbling.rotations`,
:mod:`~planning.tumbling.generators`, :mod:`~planning.tumbling.generator_lattice`,
:mod:`~planning.tumbling.reachability`, :mod:`~planning.tumbling.analysis`.

Hand derivations (face F on the plane, its frame at the origin; ``a`` the edge):

* cube: every defect angle is pi/2 exactly, so ``R_j`` is a quarter turn about
  a corner of the development, which lies on ``(a/2 + a Z)^2`` in a frame
  along F's edges; beta_bar = 1/2, q = 2, rotation order 4; the translations
  are the checkerboard ``{(m a, n a): m + n even}``.
* regular tetrahedron: defects pi (half turns), q = 1, only k = 0:
  ``t_j0 = -2 (C_j - C_bar)``; they generate ``2 L`` (L spanned by F's edges).
* regular octahedron: defects 2 pi/3, beta_bar = 2/3 (p even: the smallest
  rotation is 2/3 itself), q = 3, rotation order 3.
"""
from __future__ import annotations

import itertools
import math
from fractions import Fraction

import jax.numpy as jnp
import numpy as np
import pytest

from planning.rationals import best_rational_within
from planning.tumbling.analysis import build_analysis, generator_error
from planning.tumbling.development import development, face_footprint, transit_paths
from planning.tumbling.generator_lattice import (COEF_MAX_DEN, DEFAULT_TAU_G, coefficient_tolerances,
                                                 generator_lattice, independent_pair, rational_coef)
from planning.tumbling.generators import (GEN_LIST_CAP, GEN_LIST_CAP_DENSE, generator_ks,
                                          translation_generators)
from planning.tumbling.motions import TumbleTable, fixed_point
from planning.tumbling.reachability import _integer_combination, classify
from planning.tumbling.rotations import (RATIONAL_DETECT_MAX_DEN, is_tame, rational_defect,
                                         rotation_generators, rotation_group)
from kernels.polyhedron import make_polyhedron
from tests.polyhedra import box, example, noisy

pytestmark = pytest.mark.float64  # builds float64 kernel geometry directly
A_CUBE = 0.1


def parts(name):
    V, com = example(name)
    P = make_polyhedron(V, com)
    geom = P.geometry(jnp.float64)
    table = TumbleTable.from_polyhedron(P, geom)
    paths = transit_paths(table, 0)
    dev_m, dev = development(table, 0, paths)
    return P, geom, table, paths, dev_m, dev


def frame_coords(P, z: complex) -> complex:
    """A start-frame point in units of the cube's edge, axes along F's edges
    (the face frame's x-axis is along edge slot 0, so this is the frame)."""
    return z / A_CUBE


# ---------------------------------------------------------------- development
def test_transit_paths_are_shortest_walks():
    P, geom, table, paths, dev_m, dev = parts("octahedron")
    dist = _bfs_dist_from(table, 0)  # brute-force BFS distances on the face graph
    assert sorted(paths) == list(range(P.n_faces))
    for f, w in paths.items():
        assert len(w) == dist[f]
        assert w == () or w[-1] == f
        prev = 0
        for g in w:
            assert g in table.neighbors[prev]
            prev = g
        # the development pose of f is the effect of L_f
        m = table.word_motion(0, w)
        assert dev_m[f] == m and dev[f][2] == pytest.approx(math.remainder(m.angle, 2 * math.pi))


def _bfs_dist_from(table, root):
    d = {root: 0}
    fr = [root]
    while fr:
        nx = []
        for f in fr:
            for g in table.neighbors[f]:
                if g not in d:
                    d[g] = d[f] + 1
                    nx.append(g)
        fr = nx
    return d


def test_development_of_the_cube_is_a_net():
    P, geom, table, paths, dev_m, dev = parts("cube")
    assert dev[0] == (0.0, 0.0, 0.0)
    for f, (x, y, th) in dev.items():
        # every copy is a square of the a-grid, rotated by a multiple of pi/2
        assert abs(math.remainder(th, math.pi / 2)) < 1e-12
        w = face_footprint(P, f, (x, y, th)) / A_CUBE + 0.5
        np.testing.assert_allclose(w, np.round(w), atol=1e-12)
        # its hinge with the previous face of its transit path is shared
        if paths[f]:
            g = paths[f][-2] if len(paths[f]) > 1 else 0
            a, b = P.shared_edge(g, f)
            for v in (a, b):
                pf = face_footprint(P, f, dev[f])[P.face_cycles[f].index(v)]
                pg = face_footprint(P, g, dev[g])[P.face_cycles[g].index(v)]
                np.testing.assert_allclose(pf, pg, atol=1e-12)


# ---------------------------------------------------------------- rotations
def test_rational_defect_exact_and_within_tolerance():
    assert rational_defect(0.5, None) == (Fraction(1, 2), True)
    assert rational_defect(2 / 3, 1e-3) == (Fraction(2, 3), True)
    x = math.acos(1 / 3) / math.pi  # tetrahedral dihedral: irrational
    r, exact = rational_defect(x, 1e-6)
    assert not exact and abs(r - Fraction(x)) <= 1e-6
    assert r == best_rational_within(x, 1e-6)  # the smallest denominator
    # a noisy quarter: exact detection fails at 1e-9 noise, the tolerance finds 1/2
    r, exact = rational_defect(0.5 + 3e-10, 3e-8)
    assert (r, exact) == (Fraction(1, 2), False)
    assert is_tame(r, exact, 3e-8) and not is_tame(r, exact, None)
    big = Fraction(1, RATIONAL_DETECT_MAX_DEN + 1)
    assert not is_tame(big, False, 1e-3)


@pytest.mark.parametrize("name, angle, q, order", [("cube", Fraction(1, 2), 2, 4),
                                                    ("tetrahedron", Fraction(1), 1, 2),
                                                    ("octahedron", Fraction(2, 3), 3, 3)])
def test_rotation_generators_of_regular_solids(name, angle, q, order):
    P, geom, table, paths, dev_m, dev = parts(name)
    rot, checks = rotation_generators(P, table, 0, paths, dev_m, np.asarray(geom.corners_2d), None)
    assert len(rot) == P.n_vertices and sum(r["paper"] for r in rot) == P.n_vertices - 1
    assert checks["R_j_angle_max_err"] < 1e-12 and checks["R_j_centre_max_err"] < 1e-12
    for r in rot:
        assert r["angle"] == angle and r["angle_exact"] and r["angle_tame"]
        m = table.word_motion(0, r["word"])
        assert r["word"] == () or r["word"][-1] == 0  # a loop at F
        assert abs(math.remainder(m.angle - float(angle) * math.pi, 2 * math.pi)) < 1e-12
        c = complex(*r["centre"])
        assert abs(fixed_point(m) - c) < 1e-12
        # the centre is the vertex's copy on the development: a corner of face j1's copy
        corner = face_footprint(P, r["face"], dev[r["face"]])[P.face_cycles[r["face"]].index(r["vertex"])]
        assert abs(complex(*corner) - c) < 1e-12
        if name == "cube":
            z = frame_coords(P, c) + (0.5 + 0.5j)
            assert abs(z - complex(round(z.real), round(z.imag))) < 1e-12
    grp = rotation_group([r for r in rot if r["paper"]], 0)
    assert grp.beta_bar == angle and grp.q == q and grp.rotation_order == order
    fr = [r["angle"] for r in rot if r["paper"]]
    assert ((sum(n * f for n, f in zip(grp.n, fr)) - grp.beta_bar) / 2).denominator == 1  # mod 2
    assert all(h * grp.beta_bar == f for h, f in zip(grp.h, fr))
    # R_bar turns by beta_bar about C_bar
    assert abs(math.remainder(grp.motion.angle - grp.angle_rad, 2 * math.pi)) < 1e-9
    if grp.word is not None:
        assert len(grp.word) == grp.length
        m = table.word_motion(0, grp.word)
        assert abs(math.remainder(m.angle - grp.angle_rad, 2 * math.pi)) < 1e-9
        if grp.angle_rad % (2 * math.pi):
            assert abs(fixed_point(m) - grp.centre) < 1e-9


# ---------------------------------------------------------------- generators
def test_generator_ks_by_enumeration():
    for q, n_paper, tame in itertools.product((1, 2, 3, 7, 50, 1000), (0, 1, 5, 7), (True, False)):
        ks, trunc = generator_ks(q, n_paper, tame)
        cap = GEN_LIST_CAP if tame else GEN_LIST_CAP_DENSE
        if n_paper == 0:
            assert ks == [] and not trunc
            continue
        full = list(range(-(q - 1), q))
        if len(full) * n_paper <= cap:
            assert ks == full and not trunc
        else:
            assert trunc and ks == list(range(-ks[-1], ks[-1] + 1)) and len(ks) * n_paper <= cap
            assert (len(ks) + 2) * n_paper > cap  # the largest symmetric range that fits


@pytest.mark.parametrize("name", ["cube", "tetrahedron", "octahedron"])
def test_translation_generators_closed_form_and_lattice(name):
    P, geom, table, paths, dev_m, dev = parts(name)
    rot, _ = rotation_generators(P, table, 0, paths, dev_m, np.asarray(geom.corners_2d), None)
    paper = [r for r in rot if r["paper"]]
    grp = rotation_group(paper, 0)
    gens, trunc, checks = translation_generators(table, 0, paper, grp, True)
    assert not trunc and len(gens) == (2 * grp.q - 1) * len(paper)
    assert checks["t_jk_closed_form_max_err"] < 1e-12 and checks["t_jk_rotation_max"] < 1e-12
    C = np.asarray(geom.corners_2d)[0]
    e1, e2 = complex(*(C[1] - C[0])), complex(*(C[2] - C[0]))
    for g in gens:
        assert g["word"] is not None and (not g["word"] or g["word"][-1] == 0)
        m = table.word_motion(0, g["word"])
        assert abs(math.remainder(m.angle, 2 * math.pi)) < 1e-12  # a pure translation
        t = complex(*g["vector"])
        assert abs(t - m.z) < 1e-15 and abs(t - complex(*g["vector_closed_form"])) < 1e-12
        if name == "cube":  # the checkerboard
            z = frame_coords(P, t)
            m_, n_ = round(z.real), round(z.imag)
            assert abs(z - complex(m_, n_)) < 1e-12 and (m_ + n_) % 2 == 0
        if name == "tetrahedron":  # -2 (C_j - C_bar), in 2 L
            r = paper[g["j"]]
            assert abs(t + 2 * (complex(*r["centre"]) - grp.centre)) < 1e-12
            B = np.array([[e1.real, e2.real], [e1.imag, e2.imag]])
            c = np.linalg.solve(B, [t.real, t.imag]) / 2
            np.testing.assert_allclose(c, np.round(c), atol=1e-9)


# ---------------------------------------------------------------- eq. (3) lattice
def _gens(vectors):
    return [{"vector_closed_form": (complex(v).real, complex(v).imag)} for v in vectors]


def _same_lattice(X, b1, b2):
    """Each basis is an integer combination of the other."""
    def inside(pts, u, v):
        B = np.array([[u.real, v.real], [u.imag, v.imag]])
        c = np.linalg.solve(B, np.array([[p.real for p in pts], [p.imag for p in pts]]))
        return np.allclose(c, np.round(c), atol=1e-9)
    X1, X2 = complex(*X[0]), complex(*X[1])
    return inside([X1, X2], b1, b2) and inside([b1, b2], X1, X2)


def test_generator_lattice_recovers_a_known_lattice():
    b1, b2 = 0.3 + 0.1j, -0.05 + 0.2j
    rng = np.random.default_rng(0)
    combos = [(1, 0), (0, 1)] + [tuple(rng.integers(-4, 5, 2)) for _ in range(8)]
    vecs = [a * b1 + b * b2 for a, b in combos]
    gens = _gens(vecs)
    lat = generator_lattice(gens, None)
    assert lat.rank == 2 and lat.tau_g_used == 0.0
    assert _same_lattice(lat.lattice_basis, b1, b2)
    assert lat.mesh_area == pytest.approx(abs((b1.conjugate() * b2).imag), rel=1e-12)
    # every generator is exactly the integer combination U says
    a_i, b_i = lat.coefficient_basis
    for g, row in zip(gens, lat.U):
        assert g["vector_rational"] is not None
    Xc = lat.lattice_basis_coef
    for j in range(2):
        s = [sum(Fraction(lat.U[i][j]) * gens[i]["vector_rational"][c] for i in range(len(gens)))
             for c in range(2)]
        assert tuple(s) == Xc[j]


def test_generator_lattice_tolerances():
    b1, b2 = 1.0 + 0j, 0.5 + 0.75j
    vecs = [b1, b2, 2 * b1 - b2, math.sqrt(2) * b1]
    lat = generator_lattice(_gens(vecs), None)
    assert lat.tau_g_used == DEFAULT_TAU_G  # sqrt(2) is not rational
    lat = generator_lattice(_gens(vecs), 1e-2)
    assert lat.tau_g_used == 1e-2
    a_i, b_i = lat.coefficient_basis
    B = np.array([[vecs[a_i].real, vecs[b_i].real], [vecs[a_i].imag, vecs[b_i].imag]])
    for v, r in zip(vecs, lat.rationals):  # eq. (3): rationals within tau_g of the coefficients
        c = np.linalg.solve(B, [v.real, v.imag])
        assert r == (best_rational_within(c[0], 1e-2), best_rational_within(c[1], 1e-2)) or \
            (a_i, b_i).count(vecs.index(v)) == 1
    # noisy integer combinations: exact detection fails, a generator error of 1e-8 m determines them
    noisy_vecs = [b1, b2, 2 * b1 - b2 + 3e-9, 3 * b2 - b1 - 2e-9j]
    assert generator_lattice(_gens(noisy_vecs), None).tau_g_used == DEFAULT_TAU_G
    lat = generator_lattice(_gens(noisy_vecs), None, gen_err=1e-8)
    assert 0 < lat.tau_g_used < 1e-6 and _same_lattice(lat.lattice_basis, b1, b2)
    a_i, b_i = lat.coefficient_basis
    for v, (ra, rb) in zip(noisy_vecs, lat.rationals):
        assert max(ra.denominator, rb.denominator) <= 4  # small rationals, to the noise
        assert abs(float(ra) * noisy_vecs[a_i] + float(rb) * noisy_vecs[b_i] - v) < 1e-8


def test_rational_coef_and_coefficient_tolerances():
    assert rational_coef(0.25) == Fraction(1, 4)
    assert rational_coef(math.pi) is None
    assert rational_coef(1 + 2e-9) is None  # beyond the exact detection
    assert rational_coef(1 + 2e-9, 1e-6) == 1
    assert rational_coef(math.pi / 10, 0.6) is None  # a tolerance that determines nothing
    assert rational_coef(math.pi / 10, 0.02) == Fraction(1, 3)  # 2 tol s^2 <= 1
    assert rational_coef(math.pi / 10, 1e-3) is None  # 11/35: 2 tol s^2 > 1
    assert rational_coef(Fraction(1, COEF_MAX_DEN + 7).__float__(), 1e-12) is None
    B = np.array([[1.0, 0.2], [0.0, 0.5]])
    coefs = [(1.0, 0.0), (2.0, -3.0)]
    tols = coefficient_tolerances(B, coefs, 1e-6)
    binv = np.linalg.norm(np.linalg.inv(B), 2)
    assert tols == pytest.approx([binv * 1e-6 * 2, binv * 1e-6 * 6])
    i, j, s = independent_pair(np.array([[1.0, 0.0], [0.9, 0.1], [0.0, 1.0], [0.01, 0.0]]), [5, 6, 7, 8])
    assert (i, j) == (5, 7) and s == 1.0  # the most orthogonal long pair


# ---------------------------------------------------------------- classes
def _rot(angles, centres, exact=True, tame=True):
    return [{"vertex": i, "angle": Fraction(a), "centre": (c.real, c.imag), "angle_exact": exact,
             "angle_tame": tame, "paper": True} for i, (a, c) in enumerate(zip(angles, centres))]


def _half_turns(ts, exact=True, tame=True):
    """Half turns (angle pi) about C_j = -t_j / 2: the generators are t_j (C_bar = 0)."""
    return _rot([1] * len(ts), [-t / 2 for t in ts], exact=exact, tame=tame)


def test_classify_on_half_turns():
    def cls(ts):
        rot = _half_turns(ts)
        return classify(rot, rot, 2, 0j, math.pi)[0]
    assert cls([1.0, 1j, 1 + 2j]) == "discrete"
    assert cls([1.0, 1j, math.sqrt(2) + 0j]) == "dense_lines"  # dense along x, a lattice in y
    assert cls([1.0, 1j, math.sqrt(2) + math.sqrt(3) * 1j]) == "dense"
    assert cls([1.0, 2.0, 3.0]) == "dense_lines"  # all parallel
    assert _integer_combination(np.array([[1.0, 0.0], [0.0, 1.0], [math.sqrt(2), 0.0]]),
                                np.zeros(3)) in ((0, 1), (0, -1))
    # Theorem 1: an angle that is not rational makes it dense, whatever the translations
    rot = _half_turns([1.0, 1j], exact=False, tame=False)
    assert classify(rot, rot, 2, 0j, math.pi)[0] == "dense"


def test_classify_at_tolerance():
    """A generator off the lattice by ~1e-7: not discrete exactly, discrete when
    the generators are known to 1e-5 m; order 5 is never a lattice."""
    ts = [1.0, 1j, 1 + 2j + 1e-7 * (math.sqrt(2) + math.sqrt(3) * 1j)]
    rot = _half_turns(ts, exact=False, tame=True)
    assert classify(rot, rot, 2, 0j, math.pi, gen_err=1e-5, at_tolerance=True)[0] == "discrete"
    rot_x = _half_turns(ts)
    assert classify(rot_x, rot_x, 2, 0j, math.pi)[0] != "discrete"
    rot5 = _rot([Fraction(2, 5)] * 2, [1.0, 1j])
    assert "crystallographic" in classify(rot5, rot5, 5, 0j, 2 * math.pi / 5)[1]
    # a huge rotation order is decided without listing its rotations
    rot_big = _rot([Fraction(1, 997), Fraction(1, 991)], [1.0, 1j])
    assert "crystallographic" in classify(rot_big, rot_big, 10**12, 0j, 1e-12)[1]


def test_a_coarse_tolerance_determines_no_rational_model():
    """tau_v = 2e-5 on the 12 cm irregular part: Delta_beta ~ 5e-3 rad, so the
    rationals within it (denominators ~30) are not determined (2 tol s^2 > 1):
    the part is not tame at that tolerance (a few angles are), and its classes
    stay dense."""
    V, com = example("irregular_polyhedron")
    A = build_analysis(V, com, tau_v=2e-5)
    tame = [r for r in A.rotation_generators if r["angle_tame"]]
    assert len(tame) < len(A.rotation_generators)  # e.g. 23/34: 2 x 1.5e-3 x 34^2 > 1
    tol = A.static_bounds["Delta_beta"] / math.pi
    assert all(2 * tol * r["angle"].denominator ** 2 <= 1 for r in tame)
    assert (A.reachable_class, A.reachable_class_exact, A.near_tame) == ("dense", "dense", False)
    assert not A.generators_truncated or len(A.translation_generators) <= GEN_LIST_CAP_DENSE


def test_generator_error_formula():
    # l tau_v + d_max Delta_beta (1/2 + (2q)^2 (m - 1)), Delta_beta = 2 (l - 1) tau_v / d_min
    assert generator_error(0.0, 6, 7, 2, 1.0, 1.0) == 0.0
    assert generator_error(1e-8, 6, 7, 2, 1.0, 1.0) == pytest.approx(6e-8 + 1e-7 * (0.5 + 16 * 7))
    assert generator_error(1e-8, 6, 7, 10**400, 1.0, 1.0) == math.inf


# ---------------------------------------------------------------- analysis
def test_near_tame_cube_is_discrete_at_its_tolerance_with_the_cube_lattice():
    V = np.array(list(itertools.product([-0.5, 0.5], repeat=3)))
    ideal = build_analysis(V)
    Vn = noisy(V, 1e-9, 2)
    exact = build_analysis(Vn)
    tol = build_analysis(Vn, tau_v=1e-8)
    assert ideal.reachable_class == ideal.reachable_class_exact == "discrete"
    assert exact.reachable_class == exact.reachable_class_exact == "dense" and not exact.near_tame
    assert tol.reachable_class == "discrete" and tol.reachable_class_exact == "dense" and tol.near_tame
    assert tol.all_rational and not tol.all_rational_exact and "tolerance" in tol.class_reason
    assert (tol.q, tol.beta_bar, tol.rotation_order) == (2, Fraction(1, 2), 4)
    assert tol.mesh_area == pytest.approx(2.0, rel=1e-7)
    b1, b2 = (complex(*ideal.lattice_basis[0]), complex(*ideal.lattice_basis[1]))
    X1, X2 = complex(*tol.lattice_basis[0]), complex(*tol.lattice_basis[1])
    for z in (X1, X2):  # the checkerboard of the unit cube, to the noise
        B = np.array([[b1.real, b2.real], [b1.imag, b2.imag]])
        c = np.linalg.solve(B, [z.real, z.imag])
        np.testing.assert_allclose(c, np.round(c), atol=1e-7)
    assert 0 < tol.tau_g_used < 1e-3 and tol.generator_error > 0
    # a coarser tolerance does not change the answer; the exact cube is unchanged by one
    assert build_analysis(Vn, tau_v=1e-6).reachable_class == "discrete"
    assert build_analysis(V, tau_v=1e-6).tau_g_used == 0.0


@pytest.mark.filterwarnings("ignore::kernels.errors.PartWarning")  # the huge scale is the point
def test_analysis_is_scale_covariant():
    """All tolerances are relative: at power-of-two scales the analysis is the
    same numbers, scaled."""
    V, com = example("irregular_polyhedron")
    V, com = np.asarray(V), np.asarray(com)
    base = build_analysis(V, com)
    for s in (2.0 ** -10, 2.0 ** 30):
        A = build_analysis(V * s, com * s)
        assert (A.reachable_class, A.q, A.rank) == (base.reachable_class, base.q, base.rank)
        assert A.size == base.size * s and A.mesh_area == base.mesh_area * s * s
        assert [r["word"] for r in A.rotation_generators] == [r["word"] for r in base.rotation_generators]
        assert A.checks["R_j_centre_max_err"] <= 1e-9 * A.size
    box_A = build_analysis(box(0.1, 0.2, 0.3))
    assert box_A.reachable_class == "discrete" and box_A.mesh_area == pytest.approx(0.02)
