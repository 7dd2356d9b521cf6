"""The paper's planning algorithm (Marigo-Bicchi Sec. III steps 1-5, III-A, IV)
for one goal, on a :class:`~planning.tumbling.analysis.TumbleAnalysis`.

Everything is expressed in the start face's frame at the start (the analysis
is rooted there): the goal is the target motion ``M = T_start^-1 o T_goal``
(:mod:`planning.tumbling.motions`).  With ``E_L`` the effect of the transit path
``L_f`` the loop before it must do ``M o E_L^-1 = (gamma_1, z_1)``; step 3
picks ``R_bar^k`` (rotation ``k beta_bar`` about ``C_bar``), step 4 the lattice
point ``k1 X1 + k2 X2`` closest to the remaining translation, and step 5 the
word ``prod v_i^{U_i}, R_bar^k, L_f`` (purged).

Tumble counts are computed without materialising huge words: a loop power
``w^n`` purges to ``|n| (|w| - 2|p|) + 2|p|`` tumbles (``w = p c p^-1``).  The
count is exact when the whole unpurged word has at most
``PAPER_MATERIALISE_CAP`` tumbles (then it is built and purged); beyond that it
is the sum of the purged blocks (junction cancellations between blocks, a few
tumbles each, are ignored; blocks whose words are themselves too long to build
count unpurged).

Bounds (Sec. III-A, IV) are evaluated with logarithms: they overflow to
``inf`` rather than raising; a product with a zero factor is 0 (e.g. every
propagated error when ``tau_v = 0``).  Step 5's position test uses the actual
lattice residual plus the *propagated* part of ``Delta_C_f``
(``2 E d_f d_max^{2N} / Delta``): the paper's ``Delta_C_f`` also contains the
worst-case lattice resolution ``sqrt(Delta/pi)``, which the actual residual
already replaces.
"""
from __future__ import annotations

import cmath
import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Optional

from kernels import wrap_angle_np
from planning.lattice import closest_lattice_point
from planning.tumbling.analysis import TumbleAnalysis
from planning.tumbling.motions import Motion, compose, inverse_motion
from planning.tumbling.words import loop_power_length, power, purge

PAPER_MATERIALISE_CAP = 200_000

__all__ = ["PaperResult", "paper_plan", "PAPER_MATERIALISE_CAP", "nearest_rotation_power"]


@dataclass
class PaperResult:
    """The paper's steps 1-5 for one goal: ``gamma1`` (rad, heading the loop
    must turn), ``k`` (power of ``R_bar``) and ``orientation_residual`` (rad,
    step 3), ``t_star`` (translation left, complex m), ``k12`` (lattice
    coordinates) and ``position_residual`` (m, step 4), ``U_i`` (generator
    counts), ``n_tumbles`` (purged; ``count_exact`` when the word was built),
    ``word`` (None when too long to build), the checks of steps 1 and 5 with
    their reasons, the analytic ``bounds``, and ``budget_skipped`` (the word
    was small enough to build but did not fit the effort budget)."""

    gamma1: float
    k: int
    orientation_residual: float
    t_star: complex
    k12: Optional[tuple]
    position_residual: float
    U_i: list
    n_tumbles: int
    count_exact: bool
    word: Optional[tuple]
    step1_ok: bool
    step1_reasons: list
    step5_ok: bool
    step5_reasons: list
    bounds: dict
    budget_skipped: bool = False


def _log(x: float) -> float:
    return math.log(x) if x > 0 else -math.inf


def _exp(lg: float) -> float:
    if lg > 709.0:
        return math.inf
    if lg < -745.0:
        return 0.0
    return math.exp(lg)


def _mul(*xs: float) -> float:
    if any(x == 0 for x in xs):
        return 0.0
    out = 1.0
    for x in xs:
        out *= x
    return out


def _f(x) -> float:
    try:
        return float(x)
    except OverflowError:
        return math.inf


def nearest_rotation_power(A: TumbleAnalysis, gamma: float) -> tuple[int, float]:
    """Step 3: ``k`` in ``[0, order of R_bar)`` minimising ``|k beta_bar - gamma|``
    (mod 2 pi) and the angle ``k beta_bar`` (rad, in [0, 2 pi)).  Exact integer
    arithmetic, so it works for huge ``q``."""
    p, q = A.p, A.q
    if p == 0:
        return 0, 0.0
    two_q = 2 * q
    g2 = math.gcd(p, two_q)  # 1 or 2
    order = two_q // g2
    # k p = s (mod 2q) with s = nearest multiple of g2 to gamma q / pi
    x = (gamma % (2 * math.pi)) * q / math.pi
    s = int(round(x / g2)) * g2
    s %= two_q
    pinv = pow(p // g2, -1, order) if order > 1 else 0
    k = ((s // g2) * pinv) % order if order > 1 else 0
    ang = float(Fraction(k * p, q) % 2) * math.pi
    return int(k), ang


def paper_plan(A: TumbleAnalysis, M: Motion, goal_face: int, eps: float, effort=None) -> PaperResult:
    """Steps 1-5 of the paper for target motion ``M`` (start frame) ending on
    ``goal_face``; see the module docstring.  ``effort`` (an
    :class:`~planning.tumbling.effort.Effort`): the word is only built when its
    unpurged length fits the remaining budget, and is then counted."""
    L = A.transit_paths[goal_face]
    loop = compose(M, inverse_motion(A.table.word_motion(A.start_face, L)))
    gamma1 = float(wrap_angle_np(loop.angle))

    # ---- step 3 ----
    k, ang_k = nearest_rotation_power(A, gamma1)
    r3 = abs(float(wrap_angle_np(ang_k - gamma1)))
    cbar = complex(*A.rbar_centre)
    t_star = loop.z - (cbar - cmath.exp(1j * ang_k) * cbar)

    # ---- step 4 ----
    k12 = None
    r4 = math.inf
    U_i = [0] * len(A.translation_generators)
    if A.rank == 2:
        k1, k2 = closest_lattice_point(A.lattice_basis, (t_star.real, t_star.imag))
        X1, X2 = A.lattice_basis
        r4 = math.hypot(k1 * X1[0] + k2 * X2[0] - t_star.real, k1 * X1[1] + k2 * X2[1] - t_star.imag)
        k12 = (int(k1), int(k2))
        U_i = [row[0] * k1 + row[1] * k2 for row in A.U]
    elif abs(t_star) < 1e-12 * A.size:
        r4 = abs(t_star)

    # ---- step 5: the word, its length, the checks ----
    word, n_tumbles, skipped = _step5_word(A, U_i, k, L, effort)
    bounds = paper_bounds(A, abs(M.z), sum(abs(u) for u in U_i))
    reasons1, reasons5 = _checks(A, float(eps), r3, r4, bounds)
    return PaperResult(
        gamma1=gamma1, k=k, orientation_residual=r3, t_star=t_star, k12=k12,
        position_residual=r4, U_i=U_i, n_tumbles=int(n_tumbles), count_exact=word is not None,
        word=word, step1_ok=not reasons1, step1_reasons=reasons1, step5_ok=not reasons5,
        step5_reasons=reasons5, bounds=bounds, budget_skipped=bool(skipped),
    )


def _step5_word(A: TumbleAnalysis, U_i: list, k: int, L: tuple, effort):
    """Step 5's word ``prod v_i^{U_i}, R_bar^k, L_f`` (purged) when small enough
    to build (and affordable), else None; its tumble count (exact, or the sum
    of the purged blocks); whether the budget alone kept it from being built."""
    F = A.start_face
    gens = A.translation_generators
    unpurged = sum(abs(u) * g["length"] for u, g in zip(U_i, gens) if u)
    unpurged += k * A.rbar_length + len(L)
    have_words = all(g["word"] is not None for u, g in zip(U_i, gens) if u) and (
        k == 0 or A.rbar_word is not None)
    buildable = have_words and unpurged <= PAPER_MATERIALISE_CAP
    skipped = buildable and effort is not None and not effort.affordable(2 * unpurged)
    if buildable and not skipped:
        if effort is not None:
            effort.add(unpurged)
        parts = []
        for u, g in zip(U_i, gens):
            if u:
                parts.extend(power(g["word"], u, F))
        if k:
            parts.extend(A.rbar_word * k)
        parts.extend(L)
        word = purge(tuple(parts), F)
        return word, len(word), False
    n = sum(loop_power_length(g["length"], g["cancel"], u) for u, g in zip(U_i, gens) if u)
    n += loop_power_length(A.rbar_length, A.rbar_cancel, k) + len(L)
    return None, n, skipped


def _checks(A: TumbleAnalysis, eps: float, r3: float, r4: float, bounds: dict):
    """The reasons steps 1 and 5 give (empty lists when the checks hold)."""
    beta = math.pi / A.q
    reasons1 = []
    if beta > 2 * eps:
        reasons1.append(f"beta = pi/{A.q} = {beta:.4g} > 2 eps: orientation grid too coarse")
    Delta = A.mesh_area
    if A.rank < 2 or 2 * math.sqrt(Delta / math.pi) >= eps:
        reasons1.append(f"lattice mesh too coarse: 2 sqrt(Delta/pi) = "
                        f"{2 * math.sqrt(max(Delta, 0.0) / math.pi):.4g} >= eps")
    reasons5 = []
    if A.tau_v > 0:
        th = r3 + bounds["Delta_theta_f"]
        if not th <= eps:
            reasons5.append(f"step 5: orientation residual + Delta_theta_f = {th:.4g} > eps "
                            f"(eq. 5 with tau_v = {A.tau_v:g})")
        prop = bounds["Delta_C_f"] - math.sqrt(max(Delta, 0.0) / math.pi) if A.rank == 2 else math.inf
        pos = r4 + prop
        if not pos <= eps:
            reasons5.append(f"step 5: position residual + propagated error = {pos:.4g} > eps "
                            f"(eq. 6 with tau_v = {A.tau_v:g})")
    return reasons1, reasons5


def paper_bounds(A: TumbleAnalysis, d_f: float, sum_U: int = 0) -> dict:
    """The paper's analytic bounds (floats; see the module docstring)."""
    P = A.polyhedron
    l = P.n_faces
    m1 = sum(1 for r in A.rotation_generators if r["paper"])
    q = A.q
    tv = A.tau_v
    tg = A.tau_g_used or 0.0
    dmin, dmax = A.d_min, A.d_max
    N = _f(2 * q * m1)
    Delta = A.mesh_area
    D_beta = 2.0 * (l - 1) * tv / dmin
    two_q = _f(2 * q)
    D_gen = _mul(D_beta, 0.5 + two_q * two_q * m1) if D_beta else 0.0
    lg_d = _log(dmax)
    # d_max^{8 N^2 Delta^2}
    e1 = 8.0 * N * N * Delta * Delta
    pw1 = _exp(e1 * lg_d) if math.isfinite(e1) else (0.0 if dmax < 1 else math.inf)
    E = _mul(N, pw1, l * tv + dmax * D_gen + math.sqrt(2.0) * tg)
    # U_max = 2 d_f d_max^{2N(1 + 4 N Delta^2)} / Delta
    e2 = 2.0 * N * (1.0 + 4.0 * N * Delta * Delta)
    pw2 = _exp(e2 * lg_d) if math.isfinite(e2) else (0.0 if dmax < 1 else math.inf)
    U_max = _mul(2.0 * d_f, pw2, 1.0 / Delta) if Delta > 0 else math.inf
    D_th = _mul(two_q, 1.0 + U_max, two_q * m1 * D_beta)
    e3 = 2.0 * N
    pw3 = _exp(e3 * lg_d) if math.isfinite(e3) else (0.0 if dmax < 1 else math.inf)
    D_C = (math.sqrt(Delta / math.pi) + _mul(2.0, E, d_f, pw3, 1.0 / Delta)) if Delta > 0 else math.inf
    n_rbar = _mul(two_q * two_q, m1 * 3.0 * (l - 1))
    n_gen = _mul(3.0 * (l - 1), 1.0 + 2.0 * m1 * two_q * two_q)
    n_trans = _mul(N, U_max, n_gen)
    return {
        "Delta_D": 2.0 * tv,
        "Delta_beta": D_beta,
        "Delta_gen": D_gen,
        "E": E,
        "U_max": U_max,
        "Delta_theta_f": D_th,
        "Delta_C_f": D_C,
        "tumbles_L_f": float(l - 1),
        "tumbles_R_bar_k": n_rbar,
        "tumbles_translation": n_trans,
        "lattice_mesh_Delta": float(Delta),
        "beta": math.pi / _f(q) if q else math.inf,
    }
