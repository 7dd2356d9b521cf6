"""Translations by loops on a dense reachable set: approximate decomposition.

When the translations are dense, a goal translation ``t`` is approximated by
integer counts ``c_i`` of translation loops ``t_i`` (:mod:`planning.tumbling.loops`)
with ``|sum c_i t_i - t| <= tol`` and few tumbles.  :meth:`DenseLoops.decompose`
tries, as starting points:

* Babai rounding over an LLL-reduced embedding that weighs tumbles against
  error, at a few weights (:class:`planning.tumbling.cvp.CVPSolver`);
* the cheapest real pair decomposition (two loops, counts rounded toward 0);
* the empty combination when ``t`` is small;

and refines each remainder by a sumset meet-in-the-middle
(:class:`planning.tumbling.cvp.Sumset`: two groups of loops with counts in
``-2..2``, a KD-tree on the larger), then by near-zero combinations of those
(further sumset levels).  The cheapest result within ``tol`` wins, else the
most accurate.  Lengths are counted in tumbles after purging loop powers
(:func:`planning.tumbling.words.loop_power_length`).  Metres.
"""
from __future__ import annotations

import math
from typing import Optional

from planning.tumbling.cvp import CVPSolver, Sumset
from planning.tumbling.words import loop_power_length

__all__ = ["DenseLoops", "CVP_WEIGHTS", "SUMSET_LEVELS"]

#: Error weights (tumbles per tolerance) of the CVP embeddings tried.
CVP_WEIGHTS = (4.0, 16.0, 64.0, 256.0, 1024.0)
#: Refinement levels of sumsets.
SUMSET_LEVELS = 4


class DenseLoops:
    """Approximate integer decompositions over translation loops ``gens``.

    ``scale``: the part's size (metres), the unit of the relative floors.
    The first sumset level covers the remainder of the coarse pair stage
    (the parallelogram of two efficient loops) and resolves it finely: the 6
    most efficient loops (distinct directions) plus the 6 shortest.
    """

    def __init__(self, gens, scale: float):
        self.gens = gens
        self.scale = scale
        by_eff = sorted(range(len(gens)), key=lambda i: -abs(gens[i].t) / gens[i].length)
        fine = []
        for i in by_eff:
            d = gens[i].t / abs(gens[i].t)
            if all(abs((d / (gens[j].t / abs(gens[j].t))).imag) > 0.2 for j in fine):
                fine.append(i)
            if len(fine) >= 6:
                break
        for i in sorted(range(len(gens)), key=lambda i: (gens[i].length, -abs(gens[i].t))):
            if len(fine) >= 12:
                break
            if i not in fine:
                fine.append(i)
        self._levels = [Sumset([gens[i].t for i in fine], [float(gens[i].length) for i in fine],
                               [{i: 1} for i in fine], r=2, scale=scale)]
        self._cvps: dict = {}

    @property
    def cost(self) -> int:
        """Operations to build the first sumset level."""
        return self._levels[0].cost

    def _level(self, n: int, effort=None) -> Optional[Sumset]:
        while len(self._levels) <= n:
            prev = self._levels[-1]
            small = prev.smallest_nonzero(10)
            if len(small) < 2:
                return None
            nxt = Sumset([s[0] for s in small], [s[1] for s in small], [s[2] for s in small], r=2,
                         scale=self.scale)
            nxt.cost += prev.smallest_cost
            self._levels.append(nxt)
        if effort is not None:
            effort.charge_once(self._levels[n], self._levels[n].cost, "dense translations (sumset)")
        return self._levels[n]

    def _cvp(self, weight: float, effort=None) -> Optional[CVPSolver]:
        key = round(math.log2(weight) * 4)
        if key not in self._cvps:
            self._cvps[key] = CVPSolver([g.t for g in self.gens], [g.length for g in self.gens],
                                        2.0 ** (key / 4), effort=effort)
        solver = self._cvps[key]
        if effort is not None:
            effort.charge_once(solver, solver.cost, "dense translations (LLL)")
        return solver

    def _refine(self, coef: dict, rem: complex, tol: float, effort=None) -> tuple[dict, complex]:
        for lvl in range(SUMSET_LEVELS):
            if abs(rem) <= tol:
                break
            S = self._level(lvl, effort)
            if S is None:
                break
            c2, vec, cost, err = S.query(rem, tol)
            if abs(rem - vec) < abs(rem):
                for b, m in c2.items():
                    coef[b] = coef.get(b, 0) + m
                rem = rem - vec
        return {b: c for b, c in coef.items() if c}, rem

    def _pairs(self, t: complex) -> list:
        """Real decompositions ``t = al t_i + be t_j`` over loop pairs, cheapest
        (``|al| len_i + |be| len_j``) first: ``(cost, i, j, al, be)``."""
        gens = self.gens
        best_pair = []
        n = len(gens)
        for i in range(n):
            for j in range(i + 1, n):
                ti, tj = gens[i].t, gens[j].t
                det = ti.real * tj.imag - ti.imag * tj.real
                if abs(det) < 1e-12 * abs(ti) * abs(tj):
                    continue
                al = (t.real * tj.imag - t.imag * tj.real) / det
                be = (ti.real * t.imag - ti.imag * t.real) / det
                cost = abs(al) * gens[i].length + abs(be) * gens[j].length
                best_pair.append((cost, i, j, al, be))
        best_pair.sort()
        return best_pair

    def coarse(self, t: complex, max_len: float, effort=None) -> dict:
        """A cheap approximation of ``t`` for a plan whose accurate translation
        is too long to build: Babai rounding at low error weights (one metre of
        error worth 4, 16 or 64 times the tumbles the most efficient loop needs
        per metre) and the cheapest pair rounded toward 0; the most accurate
        one with at most ``max_len`` tumbles (``{}`` if none)."""
        gens = self.gens
        rho = min(g.length / abs(g.t) for g in gens)
        cands = []
        for c in (4.0, 16.0, 64.0):
            sol = self._cvp(c * rho, effort).solve(t)
            cands.append({i: v for i, v in enumerate(sol) if v})
        for _, i, j, al, be in self._pairs(t)[:1]:
            cands.append({k: v for k, v in ((i, int(al)), (j, int(be))) if v})
        best = ({}, abs(t))
        for coef in cands:
            n = sum(loop_power_length(gens[b].length, gens[b].cancel, c) for b, c in coef.items())
            err = abs(t - sum(v * gens[b].t for b, v in coef.items()))
            if n <= max_len and err < best[1]:
                best = (coef, err)
        return best[0]

    def _starts(self, t: complex, tol: float, effort=None) -> list:
        gens = self.gens
        starts = []
        for kappa in CVP_WEIGHTS:
            c = self._cvp(kappa / max(tol, 1e-12 * self.scale), effort).solve(t)
            coef = {i: v for i, v in enumerate(c) if v}
            rem = t - sum(v * gens[i].t for i, v in coef.items())
            starts.append((coef, rem))
        for _, i, j, al, be in self._pairs(t)[:1]:
            a0, b0 = int(al), int(be)
            starts.append(({i: a0, j: b0}, t - a0 * gens[i].t - b0 * gens[j].t))
        if abs(t) < 2.0 * max(abs(g.t) for g in gens):
            starts.append(({}, t))
        return starts

    def decompose(self, t: complex, tol: float, effort=None) -> tuple[dict, float, float]:
        """Counts over the loops with ``|sum c_i t_i - t| <= tol`` if possible
        (``t`` complex metres, ``tol`` metres): ``(coef, tumbles, error m)`` --
        the cheapest combination within ``tol``, else the most accurate one."""
        gens = self.gens
        best = None
        for coef, rem in self._starts(t, tol, effort):
            coef, rem = self._refine(dict(coef), rem, tol, effort)
            cst = sum(loop_power_length(gens[b].length, gens[b].cancel, c) for b, c in coef.items())
            key = (abs(rem) > tol, cst if abs(rem) <= tol else abs(rem))
            if best is None or key < best[0]:
                best = (key, coef, float(cst), abs(rem))
        return best[1], best[2], best[3]
