"""Rotations of a rolling polyhedron (Marigo-Bicchi Sec. II-B, III): the
rotation generators ``R_j``, their defect angles as rationals, and ``R_bar``.

Rooted at a start face ``F`` (the paper's ``F_1``):

* for every hull vertex ``V_j`` the word ``S_j`` around it (faces CCW seen
  from outside, starting at the face ``j_1`` around ``V_j`` with the shortest
  transit path) and ``R_j = purge(L_{j_1} S_j L_{j_1}^{-1})``.  Its effect is a
  rotation by ``+beta_j`` (the defect angle) about ``C_j``, the position of
  ``V_j`` on polygon ``j_1`` of the development (verified: ``checks``);
* the defect angles as rationals ``beta_j / pi = p_j / q_j``
  (:func:`rational_defect`): exactly rational (detected on the coordinates as
  given), or the smallest-denominator rational within the part's tolerance
  ``Delta_beta`` (the paper's representation); an angle is **tame** when it is
  exactly rational, or when its tolerance determines that rational
  (:func:`is_tame`);
* their GCD ``beta_bar = p/q`` and Bezout integers ``n_j`` (iterated extended
  Euclid, reduced mod ``2 q_j``), ``h_j = beta_j / beta_bar``, over the paper's
  ``m - 1`` vertices (all hull vertices but the last one), and
  ``R_bar = prod R_j^{n_j}``: a rotation by ``beta_bar`` about ``C_bar``.

Angles are in units of pi when they are ``Fraction`` (as in
:mod:`planning.rationals`), in radians when they are floats; positions in
metres, in the start face's frame at the start configuration.
"""
from __future__ import annotations

import cmath
import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Optional

import numpy as np

from kernels import wrap_angle_np
from planning.rationals import best_rational_within
from planning.tumbling.angle_gcd import extended_gcd_coeffs, rotation_step
from planning.tumbling.motions import Motion, compose, fixed_point, power_motion, rotation_about
from planning.tumbling.words import WORD_CAP, concat, inverse, junction_cancel, purge

__all__ = [
    "rational_defect",
    "is_tame",
    "rotation_generators",
    "RotationGroup",
    "rotation_group",
    "DEFAULT_BETA_TOL",
    "RATIONAL_DETECT_TOL",
    "RATIONAL_DETECT_MAX_DEN",
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


def rational_defect(beta_over_pi: float, tol: Optional[float]) -> tuple[Fraction, bool]:
    """Rational representation ``p/q`` of a defect angle in units of pi.

    Returns ``(fraction, exact)``.  First the exact detection (within
    ``RATIONAL_DETECT_TOL`` of a rational with denominator <=
    ``RATIONAL_DETECT_MAX_DEN``): then ``exact`` is True and that rational is
    used whatever ``tol``.  Otherwise the smallest-denominator rational within
    ``tol`` (units of pi; ``DEFAULT_BETA_TOL`` if ``tol`` is None or 0): a
    truncated continued fraction (convergent or semiconvergent) with
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


def is_tame(frac: Fraction, exact: bool, tol: Optional[float]) -> bool:
    """Whether a defect angle is rational at the part's tolerance: exactly
    rational, or (``tol`` > 0, units of pi) its smallest-denominator rational
    ``p/s`` within ``tol`` is determined by the tolerance: ``s`` at most
    ``RATIONAL_DETECT_MAX_DEN`` and ``2 tol s^2 <= 1`` (no other fraction of
    denominator ``<= s`` within ``tol``; see
    :func:`planning.rationals.rational_at_tolerance`)."""
    if exact:
        return True
    s = frac.denominator
    return bool(tol) and s <= RATIONAL_DETECT_MAX_DEN and 2 * float(tol) * s * s <= 1


def rotation_generators(P, table, F: int, paths: dict, dev_motions: dict, corners: np.ndarray,
                        beta_tol: Optional[float]) -> tuple[list, dict]:
    """The rotation generators ``R_j`` of every hull vertex (see the module doc).

    Args:
      P: the :class:`~kernels.polyhedron.Polyhedron`; table: its
        :class:`~planning.tumbling.motions.TumbleTable`; F: the start face.
      paths, dev_motions: transit paths and their effects
        (:mod:`planning.tumbling.development`).
      corners: (faces, K, 2) face-frame corners (the kernel geometry's
        ``corners_2d``).
      beta_tol: the part's angle tolerance (units of pi), None when exact.

    Returns ``(rot, checks)``: one dict per hull vertex (``vertex``, ``face``
    ``j_1``, ``word``, ``length``, ``cancel``, ``angle`` Fraction, ``angle_exact``,
    ``angle_tame``, ``angle_float`` rad, ``centre`` (x, y), ``paper`` bool,
    ``motion``) and the largest angle / centre residuals of the words' effects.
    """
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
        dm = dev_motions[j1]
        centre = cmath.exp(1j * dm.angle) * complex(corners[j1, k, 0], corners[j1, k, 1]) + dm.z
        fp = fixed_point(eff)
        max_angle_err = max(max_angle_err, abs(float(wrap_angle_np(eff.angle - beta))))
        if fp is not None:
            max_centre_err = max(max_centre_err, abs(fp - centre))
        rot.append({
            "vertex": int(v), "face": int(j1), "word": word, "length": len(word),
            "cancel": junction_cancel(word, F),
            "angle": frac, "angle_exact": bool(exact),
            "angle_tame": is_tame(frac, exact, beta_tol), "angle_float": beta,
            "centre": (centre.real, centre.imag), "paper": v in paper_vertices,
            "motion": eff,
        })
    return rot, {"R_j_angle_max_err": max_angle_err, "R_j_centre_max_err": max_centre_err}


@dataclass(frozen=True)
class RotationGroup:
    """GCD of the paper vertices' defect angles and ``R_bar`` (see module doc).

    Attributes: ``beta_bar`` (Fraction, units of pi) = ``p/q``; ``n``, ``h``
    (Bezout coefficients, ``beta_j / beta_bar``); ``smallest_rotation``
    (Fraction: ``beta_bar`` if p odd else ``2 beta_bar``); ``rotation_order``
    (``2 / smallest_rotation``); ``word`` (``R_bar``, None when longer than
    ``WORD_CAP`` before purging); ``length`` (purged, or the unpurged upper
    bound); ``cancel`` (``|p|`` of ``R_bar = p c p^-1``); ``centre``
    (``C_bar``, complex metres, from the rational model); ``motion`` (the true
    kinematics of the word, Motion); ``angle_rad`` (``beta_bar`` mod 2, rad).
    """

    beta_bar: Fraction
    p: int
    q: int
    n: list
    h: list
    smallest_rotation: Fraction
    rotation_order: int
    word: Optional[tuple]
    length: int
    cancel: int
    centre: complex
    motion: Motion
    angle_rad: float


def rotation_group(paper_rot: list, F: int) -> RotationGroup:
    """GCD, Bezout coefficients and ``R_bar`` of the paper's rotation
    generators ``paper_rot`` (dicts of :func:`rotation_generators`) at face ``F``."""
    fracs = [r["angle"] for r in paper_rot]
    g = extended_gcd_coeffs(fracs)
    n_coef = [int(x) for x in g.n]
    h_coef = [int(x) for x in g.h]
    p, q = g.gcd.numerator, g.gcd.denominator
    smallest = rotation_step(fracs)

    unpurged = sum(nj * r["length"] for nj, r in zip(n_coef, paper_rot))
    word = None
    if unpurged <= WORD_CAP:
        w = []
        for nj, r in zip(n_coef, paper_rot):
            w.extend(r["word"] * nj)
        word = purge(tuple(w), F)
        length, cancel = len(word), junction_cancel(word, F)
    else:
        length, cancel = unpurged, 0
    # true kinematics of R_bar (motion algebra) and the rational model
    true = Motion(0.0, 0j)
    model = Motion(0.0, 0j)
    for nj, r in zip(n_coef, paper_rot):
        true = compose(true, power_motion(r["motion"], nj))
        ang = float((nj * r["angle"]) % 2) * math.pi
        model = compose(model, rotation_about(complex(*r["centre"]), ang))
    cbar = fixed_point(model)
    if cbar is None:  # beta_bar == 2 (mod 2): no rotation at all
        cbar = 0j
    return RotationGroup(beta_bar=g.gcd, p=p, q=q, n=n_coef, h=h_coef, smallest_rotation=smallest,
                         rotation_order=int(Fraction(2) / smallest), word=word, length=length,
                         cancel=cancel, centre=cbar, motion=true,
                         angle_rad=float(g.gcd % 2) * math.pi)
