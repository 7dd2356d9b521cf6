"""Marigo-Bicchi analysis of a polyhedron: rotations, translations, lattice.

Implements Sec. II-B and the first half of Sec. III of Marigo & Bicchi,
"Planning motions of polyhedral parts by rolling", rooted at a start face
``F`` (the paper's ``F_1``):

* the plane development (BFS tree rooted at ``F``) and the transit paths
  ``L_i`` (BFS shortest words ``F -> F_i``, ties to the smaller face number);
* for every hull vertex ``V_j`` the word ``S_j`` around it (faces CCW seen
  from outside, starting at the face ``j_1`` around ``V_j`` with the shortest
  transit path) and ``R_j = purge(L_{j_1} S_j L_{j_1}^{-1})``.  Verified: the
  effect of ``R_j`` is a rotation by ``+beta_j`` about ``C_j``, the position of
  ``V_j`` on polygon ``j_1`` of the development (``checks``);
* rational defect angles ``beta_j / pi = p_j / q_j`` (see
  :func:`rational_defect`), their GCD ``beta_bar`` and Bezout integers
  ``n_j`` (iterated extended Euclid, reduced mod ``2 q_j``) and
  ``h_j = beta_j / beta_bar``, over the paper's ``m - 1`` vertices (all hull
  vertices but the last one);
* ``R_bar = prod R_j^{n_j}`` (rotation by ``beta_bar`` about ``C_bar``) and the
  translation generators ``t_jk = R_bar^{-k} (R_bar^{h_j} R_j^{-1}) R_bar^{k}``,
  ``-q < k < q``;
* eq. (3): every generator written as ``v = a v_a + b v_b`` in two independent
  ones, ``a, b`` replaced by rationals within ``tau_g``; the lattice
  ``[X1 X2 0] = V U`` by Hermite normal form and its mesh area ``Delta``;
* Remark 3 / Theorem 1: the class of the reachable set (``discrete``,
  ``dense``, ``dense_lines``).

Sign convention verified here (and in the tests): with effects composed
frame-relatively (:mod:`planning.tumbling.motions`),
``t_jk = (C_j - C_bar)(e^{i beta_j} - 1) e^{-i k beta_bar}``; the paper prints
``e^{+i k beta_bar}``, the same set of vectors since ``k`` ranges over
``-q < k < q``.

Angles are in units of pi when they are ``Fraction`` (as in
:mod:`planning.rationals`), in radians when they are floats.
"""
from __future__ import annotations

import cmath
import math
from collections import deque
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Optional

import numpy as np

from kernels.polyhedron import Polyhedron, make_polyhedron
from planning.lattice import lagrange_gauss_reduce, lattice_basis
from planning.rationals import best_rational_within, extended_gcd_coeffs, rotation_step
from planning.tumbling.motions import Motion, TumbleTable, compose, fixed_point, power_motion, rotation_about
from kernels.planar import wrap_angle_np
from planning.tumbling.words import concat, inverse, purge

__all__ = [
    "TumbleAnalysis",
    "build_analysis",
    "rational_defect",
    "DEFAULT_BETA_TOL",
    "DEFAULT_TAU_G",
    "RATIONAL_DETECT_TOL",
    "RATIONAL_DETECT_MAX_DEN",
    "WORD_CAP",
]

#: tau_v == 0 and a defect angle that is not a rational multiple of pi:
#: representation tolerance (units of pi) of its continued-fraction approximant.
DEFAULT_BETA_TOL = 1e-9
#: A defect angle is *exactly* rational if ``beta/pi`` is within this of a
#: rational with denominator <= RATIONAL_DETECT_MAX_DEN.  The cap is what makes
#: the test meaningful: by Dirichlet every real is within 1/(q Q) of some p/q
#: with q <= Q, so (tol * Q^2) must be << 1 (here 1e-6: a random irrational
#: passes with probability ~1e-6).
RATIONAL_DETECT_TOL = 1e-12
RATIONAL_DETECT_MAX_DEN = 1000
#: tau_g == None and generator coefficients that are not (detected) rational.
DEFAULT_TAU_G = 1e-6
#: Coefficient rationality test (Remark 3): |a - r/s| <= COEF_TOL * max(1, |a|)
#: with s <= COEF_MAX_DEN (false-positive rate ~1e-3 per coefficient; a class
#: is called discrete only if *all* coefficients pass).
COEF_TOL = 1e-9
COEF_MAX_DEN = 1000
#: Words longer than this (before purging) are not materialised: they are
#: handled by their length and their effect (motion algebra) only.
WORD_CAP = 100_000
#: At most this many translation generators t_jk are listed (and enter the
#: Hermite normal form); beyond it only |k| <= K is kept (``generators_truncated``).
GEN_LIST_CAP = 256
GEN_LIST_CAP_DENSE = 64


def rational_defect(beta_over_pi: float, tol: float | None) -> tuple[Fraction, bool]:
    """Rational representation ``p/q`` of a defect angle in units of pi.

    Returns ``(fraction, exact)``.  First the exact detection (within
    ``RATIONAL_DETECT_TOL`` of a rational with denominator <=
    ``RATIONAL_DETECT_MAX_DEN``): then ``exact`` is True and that rational is
    used whatever ``tol``.  Otherwise the smallest-denominator rational within
    ``tol`` (``DEFAULT_BETA_TOL`` if ``tol`` is None or 0): a truncated
    continued fraction (convergent or semiconvergent) with
    ``|beta/pi - p/q| <= tol`` -- the paper's requirement
    ``|beta - p/q pi| <= Delta_beta``.  (The paper's literal rule, the first
    convergent with ``q >= ceil(tol^-1/2)``, can overshoot to huge
    denominators when a partial quotient is large; the smallest admissible
    denominator keeps ``q`` and hence the plans small.)
    """
    r = best_rational_within(beta_over_pi, RATIONAL_DETECT_TOL)
    if r.denominator <= RATIONAL_DETECT_MAX_DEN:
        return r, True
    t = DEFAULT_BETA_TOL if not tol else float(tol)
    return best_rational_within(beta_over_pi, t), False


def _is_rational_coef(a: float) -> Optional[Fraction]:
    r = best_rational_within(a, COEF_TOL * max(1.0, abs(a)))
    return r if r.denominator <= COEF_MAX_DEN else None


def loop_power_length(word_len: int, junction_cancel: int, n: int) -> int:
    """Length of ``purge(w^n)`` for a reduced loop ``w = p c p^-1`` with
    ``|p| = junction_cancel``: ``|n| (|w| - 2|p|) + 2|p|`` (0 for n = 0)."""
    if n == 0 or word_len == 0:
        return 0
    return abs(n) * (word_len - 2 * junction_cancel) + 2 * junction_cancel


def junction_cancel(word: tuple, start: int) -> int:
    """``|p|`` for a reduced loop ``w = p c p^-1`` at ``start``."""
    if not word:
        return 0
    return (2 * len(word) - len(purge(word + word, start))) // 2


@dataclass(frozen=True, eq=False)
class TumbleAnalysis:
    """The Marigo-Bicchi structure of a part rooted at ``start_face``.

    Main attributes (see the module docstring; Fractions are in units of pi):
      polyhedron: the validated :class:`~kernels.polyhedron.Polyhedron`.
      table: its :class:`~planning.tumbling.motions.TumbleTable` (numpy effects
        of words, checked against the kernel in the tests).
      start_face, tau_v, tau_g (as given; None = automatic), tau_g_used.
      development: face -> ``(x, y, theta)`` pose of its polygon in the plane
        development rooted at the start face (= the effect of ``L_face``).
      transit_paths: face -> word ``L_face`` (``()`` for the start face).
      rotation_generators: one dict per hull vertex: ``vertex``, ``face``
        (``j_1``), ``word`` (``R_j``), ``angle`` (Fraction, the rational
        ``beta_j/pi``), ``angle_exact`` (bool), ``angle_float`` (rad, true),
        ``centre`` (``C_j``, from the development), ``paper`` (bool: one of the
        paper's m - 1 vertices).
      beta_bar: Fraction ``p/q``; p, q; beta: ``Fraction(1, q)``;
        smallest_rotation: ``beta`` if p odd else ``2 beta``;
        rotation_order: ``2 / smallest_rotation``.
      n, h: Bezout coefficients / ``beta_j / beta_bar`` over the paper vertices.
      rbar_word (None when longer than ``WORD_CAP``), rbar_length (unpurged
        upper bound when not materialised), rbar_centre ``C_bar`` (x, y),
        rbar_motion (true kinematics, Motion), rbar_cancel.
      translation_generators: dicts ``j`` (index into the paper vertices),
        ``vertex``, ``k``, ``word`` (None if not materialised), ``length``
        (purged length, or an unpurged upper bound when not materialised),
        ``cancel`` (|p| in ``w = p c p^-1``), ``vector`` (x, y: replayed effect
        when materialised, else closed form), ``vector_closed_form``,
        ``rotation_residual`` (rad, of the replayed word; None if not
        replayed), ``vector_rational`` (Fractions ``(a, b)``: the eq. (3)
        approximation ``a v_a + b v_b``).
      generators_truncated: True when not all ``-q < k < q`` are listed.
      coefficient_basis: indices ``(a, b)`` of ``v_a, v_b`` in the generator list.
      lattice_basis: ``(X1, X2)`` float tuples; lattice_basis_coef: the same in
        the ``(v_a, v_b)`` basis as Fractions; U: the unimodular matrix
        (rows = generators); rank; mesh_area (``Delta``, m^2).
      reachable_class: ``discrete`` | ``dense`` | ``dense_lines``;
        class_reason: why.
      all_rational: every defect angle is exactly a rational multiple of pi.
      checks: verification residuals (R_j angle / centre, t_jk replay vs
        closed form).
      d_min, d_max: shortest / longest edge (m); static error bounds in
        ``static_bounds``.
      cache: per-analysis memo used by the planner (short-plan tables, the
        float64 kernel geometry); not part of the analysis' value.

    Positions (``development``, ``centre``, ``rbar_centre``, vectors, the
    lattice) are in the start face's frame at the start configuration
    ``(0, 0, 0, start_face)``.
    """

    polyhedron: Polyhedron
    table: TumbleTable
    start_face: int
    tau_v: float
    tau_g: Optional[float]
    tau_g_used: Optional[float]
    development: dict
    transit_paths: dict
    rotation_generators: list
    beta_bar: Fraction
    p: int
    q: int
    beta: Fraction
    smallest_rotation: Fraction
    rotation_order: int
    n: list
    h: list
    rbar_word: Optional[tuple]
    rbar_length: int
    rbar_cancel: int
    rbar_centre: tuple
    rbar_motion: Motion
    translation_generators: list
    generators_truncated: bool
    coefficient_basis: tuple
    lattice_basis: tuple
    lattice_basis_coef: tuple
    U: tuple
    rank: int
    mesh_area: float
    reachable_class: str
    class_reason: str
    all_rational: bool
    checks: dict
    d_min: float
    d_max: float
    static_bounds: dict
    cache: dict = field(default_factory=dict, repr=False)

    # -- convenience --------------------------------------------------------
    @property
    def beta_bar_rad(self) -> float:
        return float(self.beta_bar) * math.pi

    @property
    def n_paper_generators(self) -> int:
        """The paper's N = 2 q (m - 1) (a Python int, possibly huge)."""
        m1 = sum(1 for r in self.rotation_generators if r["paper"])
        return 2 * self.q * m1

    def reachable_points(self, radius: float, max_points: int = 200_000) -> np.ndarray:
        """Lattice translations ``k1 X1 + k2 X2`` with norm <= ``radius`` (m), as
        an (n, 2) array: the positions the start face reaches with heading
        unchanged (exactly for the ``discrete`` class; the planner's lattice
        approximation otherwise).  ValueError if more than ``max_points``."""
        if not (radius >= 0):
            raise ValueError("radius: must be a non-negative number of metres")
        if self.rank < 2 or self.mesh_area <= 0:
            raise ValueError("the translation lattice is degenerate (rank < 2)")
        est = math.pi * radius * radius / self.mesh_area
        if est > max_points:
            raise ValueError(f"radius: about {est:.3g} lattice points within {radius} m "
                             f"(more than max_points={max_points}); use a smaller radius")
        X1, X2 = self.lattice_basis
        r1, r2, _ = lagrange_gauss_reduce(X1, X2)
        b1 = np.array([float(r1[0]), float(r1[1])])
        b2 = np.array([float(r2[0]), float(r2[1])])
        det = abs(b1[0] * b2[1] - b1[1] * b2[0])
        k1m = int(math.ceil(radius * np.linalg.norm(b2) / det)) + 1
        k2m = int(math.ceil(radius * np.linalg.norm(b1) / det)) + 1
        box = (2.0 * k1m + 1) * (2.0 * k2m + 1)
        if box > 8 * max_points:  # a skewed lattice (in floating point) enumerates a long box
            raise ValueError(f"radius: enumerating the lattice within {radius} m visits {box:.3g} "
                             f"candidates (more than 8 x max_points={max_points}); use a smaller radius")
        k1, k2 = np.meshgrid(np.arange(-k1m, k1m + 1), np.arange(-k2m, k2m + 1), indexing="ij")
        pts = k1.reshape(-1, 1) * b1 + k2.reshape(-1, 1) * b2
        keep = np.linalg.norm(pts, axis=1) <= radius * (1 + 1e-12)
        return pts[keep]


# --------------------------------------------------------------------------
def _bfs(table: TumbleTable, root: int):
    parent = {root: None}
    order = [root]
    dq = deque([root])
    while dq:
        f = dq.popleft()
        for g in sorted(table.neighbors[f]):
            if g not in parent:
                parent[g] = f
                order.append(g)
                dq.append(g)
    paths = {}
    for f in order:
        w = []
        g = f
        while parent[g] is not None:
            w.append(g)
            g = parent[g]
        paths[f] = tuple(reversed(w))
    return paths


def _cz(m: Motion, p: complex) -> complex:
    return cmath.exp(1j * m.angle) * p + m.z


def build_analysis(vertices, com=None, tau_v: float = 0.0, tau_g: Optional[float] = None,
                   start_face: int = 0, polyhedron: Optional[Polyhedron] = None) -> TumbleAnalysis:
    """Compute the :class:`TumbleAnalysis` (uncached; see
    :func:`planning.tumbling.planner.analyze_polyhedron`).  ``polyhedron``: an
    already validated part for ``(vertices, com)`` (skips rebuilding it)."""
    P = polyhedron if polyhedron is not None else make_polyhedron(vertices, com)
    F = int(start_face)
    geom = P.geometry()
    table = TumbleTable.from_polyhedron(P, geom)
    corners = np.asarray(geom.corners_2d)
    l = P.n_faces

    paths = _bfs(table, F)
    dev_m = {f: table.word_motion(F, w) for f, w in paths.items()}
    development = {f: (m.z.real, m.z.imag, float(wrap_angle_np(m.angle))) for f, m in dev_m.items()}

    edge_len = [float(np.linalg.norm(P.vertices[a] - P.vertices[b])) for a, b in P.edges]
    d_min, d_max = min(edge_len), max(edge_len)
    if tau_v > 0:
        delta_beta = 2.0 * (l - 1) * tau_v / d_min
        beta_tol = delta_beta / math.pi
    else:
        delta_beta = 0.0
        beta_tol = None

    # ---- rotations R_j ----------------------------------------------------
    rot = []
    paper_vertices = P.hull_vertices[:-1]
    max_angle_err = 0.0
    max_centre_err = 0.0
    for v in P.hull_vertices:
        ring = P.vertex_faces(v)
        j1 = min(ring, key=lambda f: (len(paths[f]), f))
        i = ring.index(j1)
        seq = ring[i:] + ring[:i]
        S = tuple(seq[1:]) + (j1,)
        L = paths[j1]
        word = purge(concat(L, S, inverse(L, F)), F)
        eff = table.word_motion(F, word)
        beta = float(P.defect_angle(v))
        frac, exact = rational_defect(beta / math.pi, beta_tol)
        k = P.face_cycles[j1].index(v)
        c_local = complex(corners[j1, k, 0], corners[j1, k, 1])
        centre = _cz(dev_m[j1], c_local)
        fp = fixed_point(eff)
        max_angle_err = max(max_angle_err, abs(float(wrap_angle_np(eff.angle - beta))))
        if fp is not None:
            max_centre_err = max(max_centre_err, abs(fp - centre))
        rot.append({
            "vertex": int(v), "face": int(j1), "word": word, "length": len(word),
            "cancel": junction_cancel(word, F),
            "angle": frac, "angle_exact": bool(exact), "angle_float": beta,
            "centre": (centre.real, centre.imag), "paper": v in paper_vertices,
            "motion": eff,
        })
    all_rational = all(r["angle_exact"] for r in rot)
    paper_rot = [r for r in rot if r["paper"]]

    # ---- GCD, R_bar ---------------------------------------------------------
    fracs = [r["angle"] for r in paper_rot]
    g = extended_gcd_coeffs(fracs)
    beta_bar = g.gcd
    n_coef = [int(x) for x in g.n]
    h_coef = [int(x) for x in g.h]
    p, q = beta_bar.numerator, beta_bar.denominator
    smallest = rotation_step(fracs)
    rot_order = int(Fraction(2) / smallest)

    rbar_len_unpurged = sum(nj * r["length"] for nj, r in zip(n_coef, paper_rot))
    rbar_word = None
    if rbar_len_unpurged <= WORD_CAP:
        w = []
        for nj, r in zip(n_coef, paper_rot):
            w.extend(r["word"] * nj)
        rbar_word = purge(tuple(w), F)
        rbar_len = len(rbar_word)
        rbar_cancel = junction_cancel(rbar_word, F)
    else:
        rbar_len = rbar_len_unpurged
        rbar_cancel = 0
    # true kinematics of R_bar (motion algebra) and the rational model
    rbar_true = Motion(0.0, 0j)
    rbar_model = Motion(0.0, 0j)
    for nj, r in zip(n_coef, paper_rot):
        rbar_true = compose(rbar_true, power_motion(r["motion"], nj))
        ang = float((nj * r["angle"]) % 2) * math.pi
        rbar_model = compose(rbar_model, rotation_about(complex(*r["centre"]), ang))
    cbar = fixed_point(rbar_model)
    if cbar is None:  # beta_bar == 2 (mod 2): no rotation at all
        cbar = 0j
    bb = float(beta_bar % 2) * math.pi

    # ---- translation generators t_jk -------------------------------------
    mp = len(paper_rot)
    dense_angles = not all_rational
    cap = GEN_LIST_CAP_DENSE if dense_angles else GEN_LIST_CAP
    if mp == 0:
        ks = []
        truncated = False
    elif (2 * q - 1) * mp <= cap:
        ks = list(range(-(q - 1), q))
        truncated = False
    else:
        K = max(0, (cap // mp - 1) // 2)
        ks = list(range(-K, K + 1))
        truncated = True
    gens = []
    max_gen_err = 0.0
    max_gen_rot = 0.0
    rbar_inv = inverse(rbar_word, F) if rbar_word is not None else None
    for jj, r in enumerate(paper_rot):
        hj = h_coef[jj]
        cj = complex(*r["centre"])
        bj = float(r["angle"] % 2) * math.pi
        a_j = (cj - cbar) * (cmath.exp(1j * bj) - 1.0)
        rj_inv = inverse(r["word"], F)
        for k in ks:
            closed = a_j * cmath.exp(-1j * k * bb)
            word = None
            unp = (2 * abs(k) + hj) * rbar_len + r["length"]
            if rbar_word is not None and unp <= WORD_CAP:
                conj = rbar_inv * k if k >= 0 else rbar_word * (-k)
                conj_inv = rbar_word * k if k >= 0 else rbar_inv * (-k)
                word = purge(concat(conj, rbar_word * hj, rj_inv, conj_inv), F)
            if word is not None:
                eff = table.word_motion(F, word)
                vec = eff.z
                rres = float(wrap_angle_np(eff.angle))
                max_gen_err = max(max_gen_err, abs(vec - closed))
                max_gen_rot = max(max_gen_rot, abs(rres))
                length = len(word)
                canc = junction_cancel(word, F)
            else:
                vec = closed
                rres = None
                length = unp
                canc = 0
            gens.append({"j": jj, "vertex": r["vertex"], "k": k, "word": word, "length": length,
                         "cancel": canc, "vector": (vec.real, vec.imag),
                         "vector_closed_form": (closed.real, closed.imag),
                         "rotation_residual": rres})

    # ---- eq. (3): rational coefficients in two generators, HNF ----------
    scale = max([abs(complex(*gg["vector_closed_form"])) for gg in gens] + [0.0])
    nz = [i for i, gg in enumerate(gens) if abs(complex(*gg["vector_closed_form"])) > 1e-9 * max(scale, 1e-300)]
    coef_basis = (-1, -1)
    X = ((0.0, 0.0), (0.0, 0.0))
    Xc = ((Fraction(0), Fraction(0)), (Fraction(0), Fraction(0)))
    U: tuple = ()
    rank = 0
    mesh = 0.0
    tau_g_used = tau_g
    coefs_float = []
    if nz:
        vecs = np.array([gens[i]["vector_closed_form"] for i in nz])
        norms = np.linalg.norm(vecs, axis=1)
        big = [nz[i] for i in range(len(nz)) if norms[i] >= 0.25 * norms.max()]
        best = None
        for ia in range(len(big)):
            va = np.array(gens[big[ia]]["vector_closed_form"])
            for ib in range(ia + 1, len(big)):
                vb = np.array(gens[big[ib]]["vector_closed_form"])
                s = abs(va[0] * vb[1] - va[1] * vb[0]) / (np.linalg.norm(va) * np.linalg.norm(vb))
                key = (round(s, 9), -(np.linalg.norm(va) + np.linalg.norm(vb)))
                if best is None or key > best[0]:
                    best = (key, big[ia], big[ib])
        if best is not None and best[0][0] > 1e-9:
            a_i, b_i = best[1], best[2]
            coef_basis = (a_i, b_i)
            B = np.array([gens[a_i]["vector_closed_form"], gens[b_i]["vector_closed_form"]]).T
            Binv = np.linalg.inv(B)
            coefs_float = [Binv @ np.array(gg["vector_closed_form"]) for gg in gens]
            exact_mode = tau_g is None or tau_g == 0
            rats = []
            for cf in coefs_float:
                if exact_mode:
                    rats.append([_is_rational_coef(float(x)) for x in cf])
                else:
                    rats.append([best_rational_within(float(x), float(tau_g)) for x in cf])
            if exact_mode and any(r_ is None for pr in rats for r_ in pr):
                tau_g_used = DEFAULT_TAU_G
                rats = [[r_ if r_ is not None else best_rational_within(float(x), DEFAULT_TAU_G)
                         for r_, x in zip(pr, cf)] for pr, cf in zip(rats, coefs_float)]
            elif exact_mode:
                tau_g_used = 0.0
            rats[a_i] = [Fraction(1), Fraction(0)]
            rats[b_i] = [Fraction(0), Fraction(1)]
            for gg, pr in zip(gens, rats):
                gg["vector_rational"] = (pr[0], pr[1])
            Xcl, U_, rank = lattice_basis([tuple(pr) for pr in rats])
            U = tuple(tuple(int(x) for x in row) for row in U_)
            if rank == 2:
                Xc = (tuple(Xcl[0]), tuple(Xcl[1]))
                X1 = B @ np.array([float(Xc[0][0]), float(Xc[0][1])])
                X2 = B @ np.array([float(Xc[1][0]), float(Xc[1][1])])
                X = ((float(X1[0]), float(X1[1])), (float(X2[0]), float(X2[1])))
                mesh = abs(X1[0] * X2[1] - X1[1] * X2[0])
    for gg in gens:
        gg.setdefault("vector_rational", None)

    # ---- Remark 3 / Theorem 1 -------------------------------------------
    cls, why = _classify(all_rational, rot, paper_rot, rot_order, cbar, bb)

    sb = {
        "Delta_D": 2.0 * tau_v,
        "Delta_beta": delta_beta,
        "d_min": d_min,
        "d_max": d_max,
    }
    checks = {
        "R_j_angle_max_err": max_angle_err,
        "R_j_centre_max_err": max_centre_err,
        "t_jk_closed_form_max_err": max_gen_err,
        "t_jk_rotation_max": max_gen_rot,
        "descartes_sum_over_pi": float(np.sum(P.defect_angles)) / math.pi,
    }
    return TumbleAnalysis(
        polyhedron=P, table=table, start_face=F, tau_v=float(tau_v), tau_g=tau_g,
        tau_g_used=tau_g_used, development=development, transit_paths=paths,
        rotation_generators=rot, beta_bar=beta_bar, p=p, q=q, beta=Fraction(1, q),
        smallest_rotation=smallest, rotation_order=rot_order, n=n_coef, h=h_coef,
        rbar_word=rbar_word, rbar_length=rbar_len, rbar_cancel=rbar_cancel,
        rbar_centre=(cbar.real, cbar.imag), rbar_motion=rbar_true,
        translation_generators=gens, generators_truncated=truncated,
        coefficient_basis=coef_basis, lattice_basis=X, lattice_basis_coef=Xc, U=U,
        rank=rank, mesh_area=float(mesh), reachable_class=cls, class_reason=why,
        all_rational=all_rational, checks=checks, d_min=d_min, d_max=d_max, static_bounds=sb,
    )


def _classify(all_rational, rot, paper_rot, rot_order, cbar, bb):
    """Reachable-set class from the generators (Remark 3), see module doc."""
    if not all_rational:
        bad = [r["vertex"] for r in rot if not r["angle_exact"]]
        return "dense", (f"Theorem 1: defect angles at vertices {bad} are not rational "
                         "multiples of pi (dense in position and heading)")
    vecs = []
    for r in paper_rot:
        cj = complex(*r["centre"])
        bj = float(r["angle"] % 2) * math.pi
        a_j = (cj - cbar) * (cmath.exp(1j * bj) - 1.0)
        for k in range(rot_order if rot_order > 0 else 1):
            vecs.append(a_j * cmath.exp(-1j * k * bb))
    scale = max([abs(v) for v in vecs] + [0.0])
    vecs = [v for v in vecs if abs(v) > 1e-9 * scale] if scale > 0 else []
    if not vecs:
        return "discrete", "no translation generator (finite reachable set)"
    if rot_order not in (1, 2, 3, 4, 6):
        return "dense", (f"Remark 3 + crystallographic restriction: the translations are "
                         f"invariant under rotation by 2 pi/{rot_order}, so they are not a lattice")
    # two most independent generators
    best = None
    for i in range(len(vecs)):
        for j in range(i + 1, len(vecs)):
            s = abs((vecs[i].conjugate() * vecs[j]).imag) / (abs(vecs[i]) * abs(vecs[j]))
            if best is None or s > best[0]:
                best = (s, i, j)
    if best is None or best[0] < 1e-9:
        return "dense_lines", "all translation generators are parallel"
    va, vb = vecs[best[1]], vecs[best[2]]
    B = np.array([[va.real, vb.real], [va.imag, vb.imag]])
    Binv = np.linalg.inv(B)
    coefs = [Binv @ np.array([v.real, v.imag]) for v in vecs]
    irr = [(i, c) for i, c in enumerate(coefs) if any(_is_rational_coef(float(x)) is None for x in c)]
    if not irr:
        return "discrete", ("Remark 3: every generator is a rational combination of two "
                            "independent ones (a lattice)")
    # not dense iff some integer (u1, u2) != 0 maps every coefficient pair to Z
    A = np.array(coefs)
    rng = np.arange(-30, 31)
    U1, U2 = np.meshgrid(rng, rng, indexing="ij")
    U1, U2 = U1.ravel(), U2.ravel()
    keep = (np.abs(U1) + np.abs(U2)) > 0
    U1, U2 = U1[keep], U2[keep]
    vals = A[:, 0][None, :] * U1[:, None] + A[:, 1][None, :] * U2[:, None]
    ok = np.all(np.abs(vals - np.round(vals)) <= 1e-8 * np.maximum(1.0, np.abs(vals)), axis=1)
    if np.any(ok):
        i = int(np.flatnonzero(ok)[np.argmin((np.abs(U1) + np.abs(U2))[ok])])
        return "dense_lines", (f"Remark 3: coefficients are irrational but {U1[i]} a + {U2[i]} b "
                               "is an integer for all of them (closure = parallel lines)")
    return "dense", "Remark 3: generator coefficients are irrational (dense translations)"
