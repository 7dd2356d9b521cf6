"""Short loops at the start face, found among enumerated walks
(:mod:`planning.tumbling.walks`): translation loops and rotation loops.

* A **translation loop** ``s a^-1`` joins two walks ``s, a`` that end on the
  same face with the same heading: it moves the part by the pure translation
  ``z_s - z_a`` (for any defect angles: equal heading means equal net winding
  about the vertices).  :meth:`LoopFinder.translation_loops` keeps the
  shortest ones and, per direction bin, the most efficient one (translation
  per tumble).
* A **rotation loop** ``s a^-1`` joins a walk ``s`` and the shortest walk
  ``a`` to the same face: it turns the part by the heading difference.
  :meth:`LoopFinder.rotation_loops` keeps loops with distinct turning angles
  (plus the analysis's ``R_j``).

Tolerances (:class:`LoopTolerances`) are relative to the part's size.  For a
part whose class holds only at its tolerance (near-tame), a loop whose
translation is within the tolerance of zero is no translation, and a loop
whose heading snaps to zero on the rotation grid is a pure translation.

Positions in metres, angles in radians, in the start face's frame.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from kernels import wrap_angle_np
from planning.tumbling.walks import Walks, akey
from planning.tumbling.words import concat, inverse, junction_cancel, purge

__all__ = ["Gen", "LoopTolerances", "LoopFinder", "N_SHORT", "N_DIR_BINS"]

#: Translation loops kept: the N_SHORT shortest, and the most efficient one in
#: each of N_DIR_BINS direction bins (over [0, pi)).
N_SHORT = 10
N_DIR_BINS = 16


@dataclass
class Gen:
    """A translation loop at the start face: its word, translation ``t``
    (complex, metres), length and ``cancel`` (``|p|`` for ``w = p c p^-1``:
    ``|purge(w^n)| = |n| (length - 2 cancel) + 2 cancel``)."""

    word: tuple
    t: complex
    length: int
    cancel: int


@dataclass(frozen=True)
class LoopTolerances:
    """Tolerances of the loop search (metres unless noted).

    pos: position quantum of walk deduplication; zero: a translation at most
    this long is no translation; sign: |x| below which a coordinate counts as
    zero (canonical sign of a translation); quantum: translations closer than
    this are the same loop; angle: a loop turning by at most this (rad) is a
    pure translation."""

    pos: float
    zero: float
    sign: float
    quantum: float
    angle: float

    @classmethod
    def exact(cls, scale: float) -> "LoopTolerances":
        """Rounding-level tolerances for a part ``scale`` metres across."""
        return cls(pos=1e-9 * scale, zero=1e-9 * scale, sign=1e-12 * scale, quantum=1e-7 * scale,
                   angle=1e-9)

    @classmethod
    def near_tame(cls, scale: float, gen_err: float, step: float, spacing: float) -> "LoopTolerances":
        """Tolerances for a part whose class holds at its tolerance: positions to
        ``4 gen_err`` (the paper's generator error), kept below 1e-3 of the
        lattice ``spacing`` but never below the rounding level ``1e-9 scale``
        (a lattice at the tolerance can be as fine as 1e-31 m); a loop is a
        translation when its heading is within ``step / 4`` of zero (``step``
        the rotation grid, rad)."""
        pos = max(1e-9 * scale, min(4.0 * gen_err, 1e-3 * spacing))
        return cls(pos=pos, zero=pos, sign=1e-12 * scale, quantum=max(1e-7 * scale, pos),
                   angle=0.25 * step)


class LoopFinder:
    """Loops at face ``F`` among the walks ``W`` (rooted at ``F``).

    Args:
      table: the part's TumbleTable; F: the start face; W: walks from F.
      tol: :class:`LoopTolerances`; key: heading key of the walks
        (:func:`~planning.tumbling.walks.akey` or a rotation-grid key).
    """

    def __init__(self, table, F: int, W: Walks, tol: LoopTolerances, key):
        self.table = table
        self.F = F
        self.W = W
        self.tol = tol
        self.key = key
        self.cost = 0  # operations (tumbles composed) spent making loops

    def pool(self):
        """Candidate translation loops ``(s_idx, a_idx, t, length bound)``: each
        walk paired with the first walk of its (face, heading) group, zero and
        duplicate translations dropped (``t`` and ``-t`` are one loop), sorted
        by the unpurged length ``depth_s + depth_a``."""
        W, tol = self.W, self.tol
        ak = self.key(W.ang, W.face)
        order = np.lexsort((np.arange(len(W)), ak, W.face))
        fo, ako = W.face[order], ak[order]
        start = np.ones(len(order), dtype=bool)
        start[1:] = (fo[1:] != fo[:-1]) | (ako[1:] != ako[:-1])
        grp = np.cumsum(start) - 1
        anchors = order[start][grp]
        mask = order != anchors
        s_idx = order[mask]
        a_idx = anchors[mask]
        t = W.z[s_idx] - W.z[a_idx]
        lenb = W.depth[s_idx] + W.depth[a_idx]
        nz = np.abs(t) > tol.zero
        s_idx, a_idx, t, lenb = s_idx[nz], a_idx[nz], t[nz], lenb[nz]
        flip = (t.real < -tol.sign) | ((np.abs(t.real) <= tol.sign) & (t.imag < 0))
        tc = np.where(flip, -t, t)
        q = np.round(np.stack([tc.real, tc.imag], 1) / tol.quantum).astype(np.int64)
        o = np.lexsort((lenb, q[:, 1], q[:, 0]))
        qo = q[o]
        first = np.ones(len(o), dtype=bool)
        first[1:] = np.any(qo[1:] != qo[:-1], axis=1)
        o = o[first]
        o = o[np.argsort(lenb[o], kind="stable")]
        return s_idx[o], a_idx[o], tc[o], lenb[o]

    def make(self, s: int, a: int) -> Optional[Gen]:
        """The loop ``purge(s a^-1)`` of walks ``s, a``, if a pure translation."""
        w = purge(concat(self.W.word(s), inverse(self.W.word(a), self.F)), self.F)
        return self.from_word(w)

    def from_word(self, w: tuple) -> Optional[Gen]:
        """A :class:`Gen` for loop ``w`` at F if it is a pure, non-zero
        translation (its effect computed exactly), else None."""
        if not w:
            return None
        self.cost += 2 * len(w)
        m = self.table.word_motion(self.F, w)
        if abs(float(wrap_angle_np(m.angle))) > self.tol.angle:
            return None
        if abs(m.z) <= self.tol.zero:
            return None
        return Gen(word=w, t=m.z, length=len(w), cancel=junction_cancel(w, self.F))

    def translation_loops(self, pool) -> list[Gen]:
        """The shortest ``N_SHORT`` candidates and the most efficient one per
        direction bin (``N_DIR_BINS`` over [0, pi)), as distinct loops."""
        s_idx, a_idx, tc, lenb = pool
        chosen = list(range(min(N_SHORT, len(s_idx))))
        if len(s_idx):
            ang = np.mod(np.angle(tc), math.pi)
            bins = np.minimum((ang / math.pi * N_DIR_BINS).astype(int), N_DIR_BINS - 1)
            eff = np.abs(tc) / np.maximum(lenb, 1)
            for b in range(N_DIR_BINS):
                ii = np.flatnonzero(bins == b)
                if ii.size:
                    chosen.append(int(ii[np.argmax(eff[ii])]))
        seen = set()
        gens: list[Gen] = []
        for i in chosen:
            if i in seen:
                continue
            seen.add(i)
            g = self.make(int(s_idx[i]), int(a_idx[i]))
            if g is not None and not any(abs(g.t - h.t) < self.tol.zero or
                                         abs(g.t + h.t) < self.tol.zero for h in gens):
                gens.append(g)
        return gens

    def rotation_loops(self, extra_words=(), n: int = 16) -> list:
        """Short loops at F with distinct non-zero turning angles (``s a^-1`` of
        a walk ``s`` and the shortest walk ``a`` to the same face, and the
        ``extra_words``, e.g. the analysis's ``R_j``), as ``(word, angle rad,
        length)``, at most ``n``, shortest first."""
        W, F = self.W, self.F
        first = {}
        for i, f in enumerate(W.face.tolist()):
            if f not in first:
                first[f] = i
        anc = np.array([first[f] for f in W.face.tolist()])
        d = wrap_angle_np(W.ang - W.ang[anc])
        lenb = W.depth + W.depth[anc]
        idx = np.flatnonzero(np.abs(d) > self.tol.angle)
        key = np.minimum(akey(d[idx]), akey(-d[idx]))
        o = np.lexsort((lenb[idx], key))
        ko = key[o]
        firstk = np.ones(len(o), dtype=bool)
        firstk[1:] = ko[1:] != ko[:-1]
        cand = idx[o[firstk]]
        cand = cand[np.argsort(lenb[cand], kind="stable")][: 4 * n]
        words = [purge(concat(W.word(int(s)), inverse(W.word(int(anc[s])), F)), F) for s in cand]
        words += list(extra_words)
        loops = []
        seen = set()
        for w in sorted(words, key=len):
            if not w:
                continue
            self.cost += len(w)
            m = self.table.word_motion(F, w)
            a = float(wrap_angle_np(m.angle))
            if abs(a) <= self.tol.angle:
                continue
            k = min(int(akey(np.array([a]))[0]), int(akey(np.array([-a]))[0]))
            if k in seen:
                continue
            seen.add(k)
            loops.append((w, a, len(w)))
            if len(loops) >= n:
                break
        return loops
