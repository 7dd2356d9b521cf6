"""The Marigo-Bicchi analysis of a polyhedron, rooted at a start face:
:class:`TumbleAnalysis` and :func:`build_analysis`.

Implements Sec. II-B and the first half of Sec. III of Marigo & Bicchi,
"Planning motions of polyhedral parts by rolling", in the paper's order, one
module per part of its structure:

1. plane development and transit paths (:mod:`planning.tumbling.development`);
2. rotations ``R_j``, rational defect angles, their GCD and ``R_bar``
   (:mod:`planning.tumbling.rotations`);
3. translation generators ``t_jk`` (:mod:`planning.tumbling.generators`);
4. eq. (3): rational coefficients and the lattice by Hermite normal form
   (:mod:`planning.tumbling.generator_lattice`);
5. Remark 3 / Theorem 1: the class of the reachable set, exactly and at the
   part's tolerance (:mod:`planning.tumbling.reachability`).

Near-tame parts.  Parts are known to finite precision: with ``tau_v > 0``
(metres) the defect angles are represented by rationals within
``Delta_beta = 2 (l - 1) tau_v / d_min`` and the generator coefficients by
rationals within the tolerance the paper's generator error
``l tau_v + d_max Delta_gen`` gives them (the paper's Sec. IV).  The class
decided that way (``reachable_class``) is the one the planner uses; the class
decided on the coordinates as given (``reachable_class_exact``) is reported
beside it.  With ``tau_v = 0`` both are the exact class.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Optional

import jax.numpy as jnp
import numpy as np

from kernels import Polyhedron, make_polyhedron, float64
from planning.tumbling.development import development, transit_paths
from planning.tumbling.generator_lattice import generator_lattice
from planning.tumbling.generators import translation_generators
from planning.tumbling.motions import Motion, TumbleTable
from planning.tumbling.reachability import classify, reachable_points
from planning.tumbling.rotations import rotation_generators, rotation_group

__all__ = ["TumbleAnalysis", "build_analysis", "generator_error"]


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
        ``beta_j/pi``), ``angle_exact`` (bool), ``angle_tame`` (bool: rational
        at the part's tolerance), ``angle_float`` (rad, true), ``centre``
        (``C_j``, from the development), ``paper`` (bool: one of the paper's
        m - 1 vertices).
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
      reachable_class: ``discrete`` | ``dense`` | ``dense_lines`` at the part's
        tolerance (the class the planner uses); class_reason: why.
      reachable_class_exact, class_reason_exact: the class decided on the
        coordinates as given (rationality at 1e-12); equal to the above when
        ``tau_v = 0``.
      all_rational: every defect angle is rational at the part's tolerance
        (exactly rational when ``tau_v = 0``); all_rational_exact: exactly.
      generator_error: the paper's error bound of a generator at ``tau_v``
        (m; 0 when exact or when some angle is not tame).
      checks: verification residuals (R_j angle / centre, t_jk replay vs
        closed form).
      d_min, d_max: shortest / longest edge (m); size: the part's largest
        extent (m, the scale of its relative tolerances); static error bounds
        in ``static_bounds``.
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
    reachable_class_exact: str
    class_reason_exact: str
    all_rational: bool
    all_rational_exact: bool
    generator_error: float
    checks: dict
    d_min: float
    d_max: float
    size: float
    static_bounds: dict
    cache: dict = field(default_factory=dict, repr=False)

    # -- convenience --------------------------------------------------------
    @property
    def beta_bar_rad(self) -> float:
        """``beta_bar`` in radians."""
        return float(self.beta_bar) * math.pi

    @property
    def near_tame(self) -> bool:
        """Rational (or a lattice) only at the part's tolerance: the class the
        planner uses is coarser than the exact one."""
        return (self.all_rational and not self.all_rational_exact) or (
            self.reachable_class == "discrete" and self.reachable_class_exact != "discrete")

    @property
    def n_paper_generators(self) -> int:
        """The paper's N = 2 q (m - 1) (a Python int, possibly huge)."""
        m1 = sum(1 for r in self.rotation_generators if r["paper"])
        return 2 * self.q * m1

    def reachable_points(self, radius: float, max_points: int = 200_000) -> np.ndarray:
        """Lattice translations ``k1 X1 + k2 X2`` with norm <= ``radius`` (m), as
        an (n, 2) array: the positions the start face reaches with heading
        unchanged (exactly for the ``discrete`` class; the planner's lattice
        approximation otherwise).  ValueError if more than ``max_points``
        (see :func:`planning.tumbling.reachability.reachable_points`)."""
        return reachable_points(self.lattice_basis, self.mesh_area, self.rank, radius, max_points)


def generator_error(tau_v: float, n_faces: int, n_paper: int, q: int, d_min: float,
                    d_max: float) -> float:
    """The paper's bound (Sec. IV) on the error of a translation generator
    when vertices are known to ``tau_v`` metres: ``l tau_v + d_max Delta_gen``
    with ``Delta_gen = Delta_beta (1/2 + (2q)^2 (m - 1))`` and ``Delta_beta =
    2 (l - 1) tau_v / d_min`` (metres; ``inf`` when it overflows)."""
    if tau_v <= 0:
        return 0.0
    d_beta = 2.0 * (n_faces - 1) * tau_v / d_min
    try:
        d_gen = d_beta * (0.5 + float(2 * q) ** 2 * n_paper)
    except OverflowError:
        return math.inf
    return n_faces * tau_v + d_max * d_gen


@float64
def build_analysis(vertices, com=None, tau_v: float = 0.0, tau_g: Optional[float] = None,
                   start_face: int = 0, polyhedron: Optional[Polyhedron] = None) -> TumbleAnalysis:
    """Compute the :class:`TumbleAnalysis` (uncached, float64; see
    :func:`planning.tumbling.planner.analyze_polyhedron` for the arguments).
    ``polyhedron``: an already validated part for ``(vertices, com)`` (skips
    rebuilding it)."""
    P = polyhedron if polyhedron is not None else make_polyhedron(vertices, com, tau_v=tau_v)
    F = int(start_face)
    geom = P.geometry(jnp.float64)
    table = TumbleTable.from_polyhedron(P, geom)
    l = P.n_faces
    paths = transit_paths(table, F)
    dev_m, dev = development(table, F, paths)
    edge_len = [float(np.linalg.norm(P.vertices[a] - P.vertices[b])) for a, b in P.edges]
    d_min, d_max = min(edge_len), max(edge_len)
    hv = P.vertices[list(P.hull_vertices)]
    size = float(np.max(np.linalg.norm(hv[:, None] - hv[None], axis=-1)))
    delta_beta = 2.0 * (l - 1) * tau_v / d_min if tau_v > 0 else 0.0

    rot, checks = rotation_generators(P, table, F, paths, dev_m, np.asarray(geom.corners_2d),
                                      delta_beta / math.pi if tau_v > 0 else None)
    paper_rot = [r for r in rot if r["paper"]]
    all_exact = all(r["angle_exact"] for r in rot)
    all_tame = all(r["angle_tame"] for r in rot)
    grp = rotation_group(paper_rot, F)
    gens, truncated, gchecks = translation_generators(table, F, paper_rot, grp, all_tame)
    checks.update(gchecks)
    checks["descartes_sum_over_pi"] = float(np.sum(P.defect_angles)) / math.pi
    gen_err = generator_error(tau_v, l, len(paper_rot), grp.q, d_min, d_max) if all_tame else 0.0
    lat = generator_lattice(gens, tau_g, gen_err if math.isfinite(gen_err) else 0.0)

    cls_x, why_x = classify(rot, paper_rot, grp.rotation_order, grp.centre, grp.angle_rad)
    cls, why = cls_x, why_x
    if tau_v > 0:
        cls, why = classify(rot, paper_rot, grp.rotation_order, grp.centre, grp.angle_rad,
                            gen_err=gen_err if math.isfinite(gen_err) else 0.0, at_tolerance=True)
        why = f"at the part's tolerance tau_v = {tau_v:g} m: {why}"
    return TumbleAnalysis(
        polyhedron=P, table=table, start_face=F, tau_v=float(tau_v), tau_g=tau_g,
        tau_g_used=lat.tau_g_used, development=dev, transit_paths=paths,
        rotation_generators=rot, beta_bar=grp.beta_bar, p=grp.p, q=grp.q, beta=Fraction(1, grp.q),
        smallest_rotation=grp.smallest_rotation, rotation_order=grp.rotation_order, n=grp.n,
        h=grp.h, rbar_word=grp.word, rbar_length=grp.length, rbar_cancel=grp.cancel,
        rbar_centre=(grp.centre.real, grp.centre.imag), rbar_motion=grp.motion,
        translation_generators=gens, generators_truncated=truncated,
        coefficient_basis=lat.coefficient_basis, lattice_basis=lat.lattice_basis,
        lattice_basis_coef=lat.lattice_basis_coef, U=lat.U, rank=lat.rank,
        mesh_area=lat.mesh_area, reachable_class=cls, class_reason=why,
        reachable_class_exact=cls_x, class_reason_exact=why_x, all_rational=all_tame,
        all_rational_exact=all_exact, generator_error=float(gen_err), checks=checks,
        d_min=d_min, d_max=d_max, size=size,
        static_bounds={"Delta_D": 2.0 * tau_v, "Delta_beta": delta_beta, "d_min": d_min,
                       "d_max": d_max},
    )
