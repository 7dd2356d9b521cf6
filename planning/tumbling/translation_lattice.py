"""Translations by loops on a discrete reachable set: exact lattice decomposition.

For the ``discrete`` class the translations the part can make with its
heading unchanged form the lattice of the analysis (HNF of the generators,
:mod:`planning.tumbling.generator_lattice`).  :class:`LatticeLoops` writes
every translation loop (:mod:`planning.tumbling.loops`) in integer
coordinates of a Lagrange-Gauss reduced basis of that lattice (each loop is
checked to lie on it), completes the set until it spans the lattice (more pool
loops, then the paper's ``t_jk`` words, which are guaranteed to), and builds
a Dijkstra table of the cheapest representation (in tumbles) of every small
lattice vector.  :meth:`LatticeLoops.decompose` then writes any lattice vector
as integer loop counts: a pair of loops for the bulk plus the table for the
remainder.
"""
from __future__ import annotations

import heapq
import math
from fractions import Fraction
from typing import Optional

import numpy as np

from planning.lattice import lagrange_gauss_reduce

__all__ = ["LatticeLoops", "DIJKSTRA_R", "COMPLETION_POOL"]

#: The Dijkstra table covers lattice coordinates in [-R, R]^2.
DIJKSTRA_R = 24
#: At most this many pool loops are tried to complete a spanning set.
COMPLETION_POOL = 4000


def _index(ns) -> int:
    """Index of the sublattice spanned by integer vectors ``ns`` (gcd of their
    2x2 minors; 0 when they do not span the plane)."""
    g = 0
    for i in range(len(ns)):
        for j in range(i + 1, len(ns)):
            g = math.gcd(g, ns[i][0] * ns[j][1] - ns[i][1] * ns[j][0])
    return g


class LatticeLoops:
    """Integer coordinates of translation loops in the analysis's lattice.

    Args:
      lattice_basis: ``(X1, X2)`` of the analysis (metres).
      gens: translation loops (:class:`~planning.tumbling.loops.Gen`).
      pool: the loop finder's candidate pool (:meth:`LoopFinder.pool`).
      make: ``make(s, a) -> Gen | None`` (a loop from two pool walks).
      from_word: ``from_word(word) -> Gen | None``.
      extra_words: loop words guaranteed to span the lattice (the ``t_jk``).
      coord_tol: largest distance (in lattice coordinates) of a loop from a
        lattice point.

    Attributes: ``gens`` (the loops on the lattice), ``ncoords`` (their
    integer coordinates), ``spanned`` (they generate the whole lattice),
    ``issues`` (loops found off the lattice: 0 unless the analysis is wrong),
    ``basis_vectors`` (the reduced basis, float pairs).
    """

    def __init__(self, lattice_basis, gens, pool, make, from_word, extra_words=(),
                 coord_tol: float = 1e-6):
        X1, X2 = lattice_basis
        r1, r2, _ = lagrange_gauss_reduce(X1, X2)
        self.B = np.array([[float(r1[0]), float(r2[0])], [float(r1[1]), float(r2[1])]])
        self.Binv = np.linalg.inv(self.B)
        self.basis_vectors = ((float(r1[0]), float(r1[1])), (float(r2[0]), float(r2[1])))
        self.coord_tol = coord_tol
        self.issues = 0
        good, ncoords = [], []
        for g in gens:
            c = self.coords(g.t)
            if c is None:
                self.issues += 1
                continue
            good.append(g)
            ncoords.append(c)
        # complete to a spanning set: more pool loops, then the paper's t_jk
        s_idx, a_idx = pool[0], pool[1]
        i = 0
        extra = list(extra_words)
        while _index(ncoords) != 1:
            g = None
            if i < len(s_idx) and i < COMPLETION_POOL:
                g = make(int(s_idx[i]), int(a_idx[i]))
                i += 1
            elif extra:
                g = from_word(extra.pop(0))
            else:
                break
            if g is None:
                continue
            c = self.coords(g.t)
            if c is None:
                self.issues += 1
                continue
            if c in ncoords or (-c[0], -c[1]) in ncoords:
                continue
            good.append(g)
            ncoords.append(c)
        self.gens = good
        self.ncoords = ncoords
        self.spanned = _index(ncoords) == 1
        self._dijkstra()

    def coords(self, t: complex) -> Optional[tuple[int, int]]:
        """Integer lattice coordinates of translation ``t`` (metres), or None
        when ``t`` is farther than ``coord_tol`` from the lattice."""
        c = self.Binv @ np.array([t.real, t.imag])
        rc = np.round(c)
        if np.max(np.abs(c - rc)) > self.coord_tol:
            return None
        return (int(rc[0]), int(rc[1]))

    def _dijkstra(self):
        R = DIJKSTRA_R
        n = 2 * R + 1
        dist = np.full((n, n), np.inf)
        pred = np.full((n, n, 2), -1, dtype=np.int64)  # (gen index, sign)
        dist[R, R] = 0.0
        heap = [(0.0, 0, 0)]
        steps = []
        for gi, (c, g) in enumerate(zip(self.ncoords, self.gens)):
            steps.append((c[0], c[1], gi, 1, g.length))
            steps.append((-c[0], -c[1], gi, -1, g.length))
        while heap:
            d, x, y = heapq.heappop(heap)
            if d > dist[x + R, y + R]:
                continue
            for dx, dy, gi, sg, cost in steps:
                u, v = x + dx, y + dy
                if -R <= u <= R and -R <= v <= R:
                    nd = d + cost
                    if nd < dist[u + R, v + R]:
                        dist[u + R, v + R] = nd
                        pred[u + R, v + R] = (gi, sg)
                        heapq.heappush(heap, (nd, u, v))
        self._dist = dist
        self._pred = pred

    @property
    def cost(self) -> int:
        """Operations to build the Dijkstra table (grid cells x steps)."""
        return (2 * DIJKSTRA_R + 1) ** 2 * max(1, 2 * len(self.gens))

    def _table_path(self, x: int, y: int) -> dict:
        R = DIJKSTRA_R
        coef = {}
        while (x, y) != (0, 0):
            gi, sg = self._pred[x + R, y + R]
            coef[int(gi)] = coef.get(int(gi), 0) + int(sg)
            c = self.ncoords[gi]
            x, y = x - sg * c[0], y - sg * c[1]
        return coef

    def decompose(self, k: tuple) -> Optional[tuple[dict, float]]:
        """Cheap integer counts ``c_i`` with ``sum c_i n_i = k`` (lattice
        coordinates ``k``): ``({loop index: count}, tumbles before purging)``,
        or None when neither the table nor a loop pair plus the table reaches
        ``k``."""
        R = DIJKSTRA_R
        best = None
        kx, ky = int(k[0]), int(k[1])
        if abs(kx) <= R and abs(ky) <= R and np.isfinite(self._dist[kx + R, ky + R]):
            best = (float(self._dist[kx + R, ky + R]), None)
        ns = self.ncoords
        for i in range(len(ns)):
            for j in range(i + 1, len(ns)):
                det = ns[i][0] * ns[j][1] - ns[i][1] * ns[j][0]
                if det == 0:
                    continue
                al = Fraction(kx * ns[j][1] - ky * ns[j][0], det)
                be = Fraction(ns[i][0] * ky - ns[i][1] * kx, det)
                a0, b0 = int(al), int(be)  # toward zero
                rx = kx - a0 * ns[i][0] - b0 * ns[j][0]
                ry = ky - a0 * ns[i][1] - b0 * ns[j][1]
                if abs(rx) > R or abs(ry) > R or not np.isfinite(self._dist[rx + R, ry + R]):
                    continue
                cost = abs(a0) * self.gens[i].length + abs(b0) * self.gens[j].length + float(
                    self._dist[rx + R, ry + R])
                if best is None or cost < best[0]:
                    best = (cost, (i, j, a0, b0, rx, ry))
        if best is None:
            return None
        cost, info = best
        if info is None:
            return self._table_path(kx, ky), cost
        i, j, a0, b0, rx, ry = info
        coef = self._table_path(rx, ry)
        coef[i] = coef.get(i, 0) + a0
        coef[j] = coef.get(j, 0) + b0
        return {a: b for a, b in coef.items() if b}, cost
