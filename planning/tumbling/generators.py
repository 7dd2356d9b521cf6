"""Translation generators of a rolling polyhedron (Marigo-Bicchi Sec. III).

With ``R_bar`` a rotation by ``beta_bar`` about ``C_bar`` and ``R_j`` a
rotation by ``beta_j = h_j beta_bar`` about ``C_j``
(:mod:`planning.tumbling.rotations`), the words

    ``t_jk = R_bar^{-k} (R_bar^{h_j} R_j^{-1}) R_bar^{k}``,  ``-q < k < q``,

are pure translations.  Sign convention verified here (and in the tests):
with effects composed frame-relatively (:mod:`planning.tumbling.motions`),
``t_jk = (C_j - C_bar)(e^{i beta_j} - 1) e^{-i k beta_bar}``; the paper prints
``e^{+i k beta_bar}``, the same set of vectors since ``k`` ranges over
``-q < k < q``.  Words are materialised (and replayed by the numpy motion
algebra) when at most ``WORD_CAP`` tumbles long before purging; otherwise
only their closed form and an upper bound of their length are kept.  At most
``GEN_LIST_CAP`` generators are listed (``GEN_LIST_CAP_DENSE`` when some
defect angle is not rational at the part's tolerance); beyond that only
``|k| <= K`` is kept (``truncated``).

Positions are in metres, in the start face's frame at the start.
"""
from __future__ import annotations

import cmath
import math

from kernels import wrap_angle_np
from planning.tumbling.rotations import RotationGroup
from planning.tumbling.words import WORD_CAP, concat, inverse, junction_cancel, purge

__all__ = ["translation_generators", "generator_ks", "GEN_LIST_CAP", "GEN_LIST_CAP_DENSE"]

#: At most this many translation generators t_jk are listed (and enter the
#: Hermite normal form); beyond it only |k| <= K is kept (``truncated``).
GEN_LIST_CAP = 256
GEN_LIST_CAP_DENSE = 64


def generator_ks(q: int, n_paper: int, tame: bool) -> tuple[list, bool]:
    """The rotation indices ``k`` of the listed generators and whether the
    list is truncated: all ``-q < k < q`` if ``(2q - 1) n_paper`` fits the cap
    (``GEN_LIST_CAP``, or ``GEN_LIST_CAP_DENSE`` when the angles are not all
    tame), else ``|k| <= K`` with ``(2K + 1) n_paper`` within the cap."""
    cap = GEN_LIST_CAP if tame else GEN_LIST_CAP_DENSE
    if n_paper == 0:
        return [], False
    if (2 * q - 1) * n_paper <= cap:
        return list(range(-(q - 1), q)), False
    K = max(0, (cap // n_paper - 1) // 2)
    return list(range(-K, K + 1)), True


def translation_generators(table, F: int, paper_rot: list, group: RotationGroup, tame: bool
                           ) -> tuple[list, bool, dict]:
    """The translation generators ``t_jk`` (see the module doc).

    Args:
      table: the part's :class:`~planning.tumbling.motions.TumbleTable`.
      F: the start face; paper_rot: the paper's rotation generators (dicts of
        :func:`planning.tumbling.rotations.rotation_generators`); group: their
        :class:`~planning.tumbling.rotations.RotationGroup`.
      tame: every defect angle is rational at the part's tolerance.

    Returns ``(gens, truncated, checks)``: one dict per generator (``j``,
    ``vertex``, ``k``, ``word`` or None, ``length``, ``cancel``, ``vector``
    (replayed when materialised, else the closed form), ``vector_closed_form``,
    ``rotation_residual`` (rad, None if not replayed)), whether the list was
    truncated, and the largest replay-vs-closed-form residuals.
    """
    ks, truncated = generator_ks(group.q, len(paper_rot), tame)
    gens = []
    max_gen_err = 0.0
    max_gen_rot = 0.0
    rbar_word, rbar_len, cbar, bb = group.word, group.length, group.centre, group.angle_rad
    rbar_inv = inverse(rbar_word, F) if rbar_word is not None else None
    for jj, r in enumerate(paper_rot):
        hj = group.h[jj]
        bj = float(r["angle"] % 2) * math.pi
        a_j = (complex(*r["centre"]) - cbar) * (cmath.exp(1j * bj) - 1.0)
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
                length, canc = len(word), junction_cancel(word, F)
            else:
                vec, rres, length, canc = closed, None, unp, 0
            gens.append({"j": jj, "vertex": r["vertex"], "k": k, "word": word, "length": length,
                         "cancel": canc, "vector": (vec.real, vec.imag),
                         "vector_closed_form": (closed.real, closed.imag),
                         "rotation_residual": rres})
    checks = {"t_jk_closed_form_max_err": max_gen_err, "t_jk_rotation_max": max_gen_rot}
    return gens, truncated, checks
