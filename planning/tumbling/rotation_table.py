"""Headings by rotation loops (dense defect angles): the rotation table.

When some defect angle is not a rational multiple of pi, the headings a face
can reach are dense, and a plan's heading can be corrected by a product of
short **rotation loops** at the start face (:meth:`LoopFinder.rotation_loops
<planning.tumbling.loops.LoopFinder.rotation_loops>`).  :class:`RotationTables`
finds the cheapest product (in tumbles) for every heading, by Dial's
algorithm (Dijkstra with integer costs) over heading bins of a given width,
tracking the exact angle reached in each bin; :meth:`RotationTables.word`
reads off a loop word turning by a target angle within a tolerance.
Angles in radians.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from kernels import wrap_angle_np
from planning.tumbling.effort import VECTOR_OPS
from planning.tumbling.words import inverse, purge

__all__ = ["RotationTables", "RotationTable", "MAX_BINS", "MAX_COST"]

TWO_PI = 2.0 * math.pi
#: Finest table: this many heading bins.
MAX_BINS = 1 << 17
#: Products of rotation loops are searched up to this many tumbles.
MAX_COST = 50_000
_INF = np.iinfo(np.int64).max


@dataclass
class RotationTable:
    """Cheapest loop products per heading bin: ``nb`` bins of ``width`` rad;
    per bin ``dist`` (tumbles, int64 max = unreached), ``ang`` (exact angle
    reached), ``pbin``/``pcode`` (predecessor bin and loop code, +-(i+1) for
    loop i or its inverse); ``gap``: the largest distance (rad) from any
    heading to a reached one; ``cost``: operations to build it."""

    nb: int
    width: float
    dist: np.ndarray
    ang: np.ndarray
    pbin: np.ndarray
    pcode: np.ndarray
    gap: float
    cost: int

    def bin_of(self, a) -> np.ndarray:
        """Bin index of headings ``a`` (rad, any range)."""
        return (np.floor(np.mod(a, TWO_PI) / self.width).astype(np.int64)) % self.nb


def _dial(loops, nb: int, effort) -> RotationTable:
    """Dial's algorithm over ``nb`` heading bins (see the module doc); a window
    of ``lmin`` cost levels at a time: children of a node settled in
    ``[c, c + lmin)`` cost ``>= c + lmin``, so the window is final."""
    w = TWO_PI / nb
    tab = RotationTable(nb, w, np.full(nb, _INF, dtype=np.int64), np.zeros(nb),
                        np.full(nb, -1, dtype=np.int64), np.zeros(nb, dtype=np.int64), math.inf, nb)
    dist, ang, pbin, pcode = tab.dist, tab.ang, tab.pbin, tab.pcode
    b0 = int(tab.bin_of(np.array([0.0]))[0])
    dist[b0] = 0
    A_ = np.array([a for _, a, _ in loops] + [-a for _, a, _ in loops])
    L_ = np.array([L for _, _, L in loops] * 2, dtype=np.int64)
    C_ = np.array([i + 1 for i in range(len(loops))] + [-(i + 1) for i in range(len(loops))])
    lmin = int(L_.min()) if L_.size else 1
    pending = {0: [np.array([b0])]}
    while pending:
        c = min(pending)
        if c > MAX_COST:
            break
        keys = [k for k in pending if k < c + lmin]
        fr = np.unique(np.concatenate([a for k in keys for a in pending.pop(k)]))
        fr = fr[(dist[fr] >= c) & (dist[fr] < c + lmin)]
        if not fr.size:
            continue
        tab.cost += (fr.size * A_.size) // VECTOR_OPS + 1
        if effort is not None:
            effort.check(tab.cost, "rotation table")
        na = (ang[fr][:, None] + A_[None, :]).ravel()
        nc = (dist[fr][:, None] + L_[None, :]).ravel()
        src = np.repeat(fr, A_.size)
        code = np.tile(C_, fr.size)
        nbn = tab.bin_of(na)
        better = nc < dist[nbn]
        if not np.any(better):
            continue
        na, nc, src, code, nbn = na[better], nc[better], src[better], code[better], nbn[better]
        o = np.lexsort((nc, nbn))
        nbn_o = nbn[o]
        first = np.ones(o.size, dtype=bool)
        first[1:] = nbn_o[1:] != nbn_o[:-1]
        o = o[first]
        uq = nbn[o]
        dist[uq] = nc[o]
        ang[uq] = wrap_angle_np(na[o])
        pbin[uq] = src[o]
        pcode[uq] = code[o]
        for cc in np.unique(nc[o]):
            pending.setdefault(int(cc), []).append(uq[nc[o] == cc])
    reached = np.sort(ang[dist < _INF])
    if reached.size:
        gaps = np.diff(np.r_[reached, reached[0] + TWO_PI])
        tab.gap = float(gaps.max()) / 2.0  # worst distance of a heading to a reached one
    return tab


class RotationTables:
    """Rotation tables of the loops ``loops`` (``(word, angle, length)``) at
    face ``F``, cached per bin count."""

    def __init__(self, loops, F: int):
        self.loops = loops
        self.F = F
        self._tables: dict = {}

    def table(self, width: float, effort=None) -> RotationTable:
        """The table over bins of about ``width`` rad (at least 64 and at most
        ``MAX_BINS`` bins); its build cost is charged to ``effort``."""
        nb = int(min(MAX_BINS, max(64, math.ceil(TWO_PI / width))))
        if nb not in self._tables:
            self._tables[nb] = _dial(self.loops, nb, effort)
        tab = self._tables[nb]
        if effort is not None:
            effort.charge_once(tab, tab.cost, "rotation table")
        return tab

    def word(self, target: float, tol: float, effort=None):
        """Product of rotation loops turning by ``target`` rad within ``tol``
        (or as close as the table gets): ``(word, angle)``; ``((), 0.0)`` if
        none is needed; None when no bin near the target is reached."""
        if abs(float(wrap_angle_np(target))) <= tol:
            return (), 0.0
        tab = None
        for div in (8, 32, 128):
            tab = self.table(max(tol / div, 1e-12), effort)
            if tab.gap <= tol or tab.nb >= MAX_BINS:
                break
        b = int(tab.bin_of(np.array([target]))[0])
        best = None
        for cb in [(b + d) % tab.nb for d in (-1, 0, 1)]:
            if tab.dist[cb] == _INF:
                continue
            res = abs(float(wrap_angle_np(tab.ang[cb] - target)))
            key = (res > tol, int(tab.dist[cb]) if res <= tol else res)
            if best is None or key < best[0]:
                best = (key, cb)
        if best is None:
            return None
        cb = best[1]
        codes = []
        while tab.pbin[cb] >= 0:
            codes.append(int(tab.pcode[cb]))
            cb = int(tab.pbin[cb])
        codes.reverse()
        parts = []
        for code in codes:
            wd = self.loops[abs(code) - 1][0]
            parts.extend(wd if code > 0 else inverse(wd, self.F))
        if effort is not None:
            effort.charge(len(parts), "rotation word")
        return purge(tuple(parts), self.F), float(tab.ang[best[1]])
