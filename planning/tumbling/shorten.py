"""Short tumble plans (beyond the paper): meet-in-the-middle cores, short
rotation loops and short translation loops.

A plan from face ``F`` to face ``G`` is built as ``T . R . A . B^-1``:

* the **core** ``A B^-1``: ``A`` a walk from ``F`` and ``B`` a walk from ``G``
  ending on the same face ``X`` (``F -> X -> G``).  Walks are enumerated
  breadth-first from both ends (:func:`enumerate_walks`: non-backtracking, one
  walk per distinct configuration, so each kept walk is a shortest one among
  those enumerated) and matched on the heading: the core must turn the part by
  the goal heading -- exactly the nearest reachable heading when every defect
  angle is a rational multiple of pi (reachable headings are then a coset of
  the rotation step), within ``eps/2`` otherwise;
* for irrational defect angles also cheap cores of any heading, whose heading
  is then fixed by ``R``, a product of short **rotation loops** at ``F``
  (loops with distinct turning angles): a Dial/Dijkstra search over heading
  bins (bins of ``tol/8`` or finer, exact angles tracked) gives the cheapest
  product for every heading (:meth:`ShortPlanner.rotation_table`);
* ``T``, a product of **translation loops** at ``F``: loops ``s a^-1`` of two
  enumerated walks that end on the same face with the same heading, hence move
  the part by a pure translation ``z_s - z_a`` (for any defect angles: equal
  heading means equal net winding about the vertices).  They commute, so ``T``
  only needs integer counts ``c_i`` with ``sum c_i t_i ~= t`` (the goal
  translation left by ``R . core``):

  - **discrete** reachable set: the loops' integer coordinates in a
    Lagrange-Gauss reduced basis of the exact translation lattice (the
    analysis's HNF lattice; every loop is checked to lie on it); the set is
    completed until it spans the lattice (the paper's ``t_jk`` words guarantee
    that); the exact closest lattice point is decomposed by a pair of loops
    plus a Dijkstra table of the cheapest representation of every small
    lattice vector;
  - **dense** translations: Babai rounding over an LLL-reduced embedding that
    weighs tumbles against error (:mod:`planning.tumbling.cvp`, a few weights),
    and a real pair decomposition, each remainder refined by a sumset
    meet-in-the-middle (two groups of loops with counts in ``-2..2``, a
    KD-tree on the larger) and then by near-zero combinations of those.

Several cores are tried; each candidate word is purged and its effect is
computed exactly with :class:`~planning.tumbling.motions.TumbleTable`; the
shortest one within ``eps`` wins (the planner then verifies it with the JAX
kernel).  :class:`ShortPlanner` holds the per-analysis tables (walks from the
start face, loops, lattice / LLL / sumset structures, heading tables, walks
from each goal face) and is cached by the planner with the analysis.
"""
from __future__ import annotations

import heapq
import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Optional

import numpy as np
from scipy.spatial import cKDTree

from planning.lattice import closest_lattice_point, lagrange_gauss_reduce
from planning.tumbling.cvp import CVPSolver, Sumset
from planning.tumbling.generators import TumbleAnalysis
from planning.tumbling.motions import Motion
from kernels.planar import wrap_angle_np
from planning.tumbling.walks import Walks, akey as _akey, enumerate_walks
from planning.tumbling.words import concat, inverse, power, purge

TWO_PI = 2.0 * math.pi

FWD_BUDGET = 20_000
BWD_BUDGET = 10_000
N_SHORT = 10
N_DIR_BINS = 16
N_CORES = 24
DIJKSTRA_R = 24

__all__ = ["ShortPlanner", "ShortResult", "Gen"]


@dataclass
class Gen:
    """A translation loop at the start face."""

    word: tuple
    t: complex
    length: int
    cancel: int  # |p| for w = p c p^-1 (purge of w^n)


@dataclass
class ShortResult:
    word: tuple
    motion: Motion
    error: float
    orientation_residual: float
    position_residual: float
    core_length: int
    translation_length: int


def _loop_len(g: Gen, n: int) -> int:
    if n == 0:
        return 0
    return abs(n) * (g.length - 2 * g.cancel) + 2 * g.cancel


# --------------------------------------------------------------------------
class ShortPlanner:
    """Short plans for one :class:`TumbleAnalysis` (start face ``F``)."""

    def __init__(self, A: TumbleAnalysis, fwd_budget: int = FWD_BUDGET, bwd_budget: int = BWD_BUDGET):
        self.A = A
        self.table = A.table
        self.F = A.start_face
        P = A.polyhedron
        hv = P.vertices[list(P.hull_vertices)]
        self.scale = float(np.max(np.linalg.norm(hv - hv.mean(0), axis=1))) * 2.0
        self.pos_tol = 1e-9 * self.scale
        if A.all_rational:
            self.regime = "exact_lattice" if A.reachable_class == "discrete" else "exact_heading"
        else:
            self.regime = "dense"
        self.fwd_budget = fwd_budget
        self.bwd_budget = bwd_budget
        self.fwd = enumerate_walks(self.table, self.F, fwd_budget, self.pos_tol)
        self._bwd = {}
        self._fgroups = None
        self._rot_tables = {}
        self._cvps = {}
        self._rot_loops = None
        self.lattice_issues = 0
        self._build_generators()

    # ---------------------------------------------------------------- walks
    def bwd(self, G: int) -> Walks:
        if G not in self._bwd:
            self._bwd[G] = (self.fwd if G == self.F else
                            enumerate_walks(self.table, G, self.bwd_budget, self.pos_tol))
        return self._bwd[G]

    # ------------------------------------------------------------ generators
    def _candidate_pool(self):
        W = self.fwd
        ak = _akey(W.ang)
        order = np.lexsort((np.arange(len(W)), ak, W.face))
        fo, ako = W.face[order], ak[order]
        start = np.ones(len(order), dtype=bool)
        start[1:] = (fo[1:] != fo[:-1]) | (ako[1:] != ako[:-1])
        grp = np.cumsum(start) - 1
        anchor_of_group = order[start]
        anchors = anchor_of_group[grp]
        mask = order != anchors
        s_idx = order[mask]
        a_idx = anchors[mask]
        t = W.z[s_idx] - W.z[a_idx]
        lenb = W.depth[s_idx] + W.depth[a_idx]
        nz = np.abs(t) > 1e-9 * self.scale
        s_idx, a_idx, t, lenb = s_idx[nz], a_idx[nz], t[nz], lenb[nz]
        # canonical sign (t and -t are the same loop reversed), dedupe
        flip = (t.real < -1e-12 * self.scale) | ((np.abs(t.real) <= 1e-12 * self.scale) & (t.imag < 0))
        tc = np.where(flip, -t, t)
        q = np.round(np.stack([tc.real, tc.imag], 1) / (1e-7 * self.scale)).astype(np.int64)
        o = np.lexsort((lenb, q[:, 1], q[:, 0]))
        qo = q[o]
        first = np.ones(len(o), dtype=bool)
        first[1:] = np.any(qo[1:] != qo[:-1], axis=1)
        o = o[first]
        o = o[np.argsort(lenb[o], kind="stable")]
        return s_idx[o], a_idx[o], tc[o], lenb[o]

    def _make_gen(self, s: int, a: int) -> Optional[Gen]:
        F = self.F
        w = purge(concat(self.fwd.word(s), inverse(self.fwd.word(a), F)), F)
        return self._gen_from_word(w)

    def _gen_from_word(self, w: tuple) -> Optional[Gen]:
        F = self.F
        if not w:
            return None
        m = self.table.word_motion(F, w)
        if abs(float(wrap_angle_np(m.angle))) > 1e-9:
            return None
        if abs(m.z) <= 1e-9 * self.scale:
            return None
        canc = (2 * len(w) - len(purge(w + w, F))) // 2
        return Gen(word=w, t=m.z, length=len(w), cancel=canc)

    def _build_generators(self):
        s_idx, a_idx, tc, lenb = self._candidate_pool()
        chosen = []
        # shortest
        for i in range(min(N_SHORT, len(s_idx))):
            chosen.append(i)
        # most efficient per direction bin
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
            g = self._make_gen(int(s_idx[i]), int(a_idx[i]))
            if g is not None and not any(abs(g.t - h.t) < 1e-9 * self.scale or
                                         abs(g.t + h.t) < 1e-9 * self.scale for h in gens):
                gens.append(g)
        self._pool = (s_idx, a_idx, tc, lenb)
        self.gens = gens
        if self.regime == "exact_lattice":
            self._setup_lattice()
        elif self.gens:
            self._setup_sumset()
        eff = [g.length / abs(g.t) for g in self.gens]
        self.rho = min(eff) if eff else 0.0

    # -------------------------------------------------- exact lattice (discrete)
    def _setup_lattice(self):
        A = self.A
        X1, X2 = A.lattice_basis
        r1, r2, _ = lagrange_gauss_reduce(X1, X2)
        self.B = np.array([[float(r1[0]), float(r2[0])], [float(r1[1]), float(r2[1])]])
        self.Binv = np.linalg.inv(self.B)
        self.Bvecs = ((float(r1[0]), float(r1[1])), (float(r2[0]), float(r2[1])))

        def coords(t: complex):
            c = self.Binv @ np.array([t.real, t.imag])
            rc = np.round(c)
            if np.max(np.abs(c - rc)) > 1e-6:
                return None
            return (int(rc[0]), int(rc[1]))

        good, ncoords = [], []
        for g in self.gens:
            c = coords(g.t)
            if c is None:
                self.lattice_issues += 1
                continue
            good.append(g)
            ncoords.append(c)

        def index(ns):
            gg = 0
            for i in range(len(ns)):
                for j in range(i + 1, len(ns)):
                    gg = math.gcd(gg, ns[i][0] * ns[j][1] - ns[i][1] * ns[j][0])
            return gg

        # complete to a spanning set: more pool loops, then the paper's t_jk
        s_idx, a_idx, tc, lenb = self._pool
        i = 0
        extra = [g["word"] for g in A.translation_generators if g["word"] is not None]
        while index(ncoords) != 1:
            g = None
            if i < len(s_idx) and i < 4000:
                g = self._make_gen(int(s_idx[i]), int(a_idx[i]))
                i += 1
            elif extra:
                g = self._gen_from_word(extra.pop(0))
            else:
                break
            if g is None:
                continue
            c = coords(g.t)
            if c is None:
                self.lattice_issues += 1
                continue
            if c in ncoords or (-c[0], -c[1]) in ncoords:
                continue
            good.append(g)
            ncoords.append(c)
        self.gens = good
        self.ncoords = ncoords
        self.lattice_spanned = index(ncoords) == 1
        self._dijkstra()

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
        self._steps_by_gen = {gi: c for gi, c in enumerate(self.ncoords)}

    def _table_path(self, x: int, y: int) -> dict:
        R = DIJKSTRA_R
        coef = {}
        while (x, y) != (0, 0):
            gi, sg = self._pred[x + R, y + R]
            coef[int(gi)] = coef.get(int(gi), 0) + int(sg)
            c = self.ncoords[gi]
            x, y = x - sg * c[0], y - sg * c[1]
        return coef

    def decompose_lattice(self, k: tuple) -> Optional[tuple[dict, float]]:
        """Cheap integer counts ``c_i`` with ``sum c_i n_i = k`` (lattice coords)."""
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

    # ------------------------------------------------------ dense: sumset
    def _setup_sumset(self):
        gens = self.gens
        # level 0 must cover the remainder of the coarse pair stage (the
        # parallelogram of two efficient loops) and resolve it finely: the 6
        # most efficient loops (distinct directions) plus the 6 shortest.
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
                                [{i: 1} for i in fine], r=2)]

    def _level(self, n: int):
        while len(self._levels) <= n:
            small = self._levels[-1].smallest_nonzero(10)
            if len(small) < 2:
                return None
            self._levels.append(Sumset([s[0] for s in small], [s[1] for s in small],
                                        [s[2] for s in small], r=2))
        return self._levels[n]

    def _cvp(self, weight: float) -> CVPSolver:
        key = round(math.log2(weight) * 4)
        if key not in self._cvps:
            self._cvps[key] = CVPSolver([g.t for g in self.gens], [g.length for g in self.gens],
                                        2.0 ** (key / 4))
        return self._cvps[key]

    def _refine(self, coef: dict, rem: complex, tol: float) -> tuple[dict, complex]:
        for lvl in range(4):
            if abs(rem) <= tol:
                break
            S = self._level(lvl)
            if S is None:
                break
            c2, vec, cost, err = S.query(rem, tol)
            if abs(rem - vec) < abs(rem):
                for b, m in c2.items():
                    coef[b] = coef.get(b, 0) + m
                rem = rem - vec
        return {b: c for b, c in coef.items() if c}, rem

    def decompose_dense(self, t: complex, tol: float) -> tuple[dict, float, float]:
        """Counts over the loops with ``|sum c_i t_i - t| <= tol`` if possible:
        ``(coef, cost, error)``.  Candidates: Babai rounding over an
        LLL-reduced embedding at a few error weights (:mod:`planning.tumbling.cvp`),
        and a real pair decomposition; each remainder refined by the sumset
        levels; the cheapest within ``tol`` wins (else the most accurate)."""
        gens = self.gens
        starts = []
        for kappa in (4.0, 16.0, 64.0, 256.0, 1024.0):
            c = self._cvp(kappa / max(tol, 1e-12)).solve(t)
            coef = {i: v for i, v in enumerate(c) if v}
            rem = t - sum(v * gens[i].t for i, v in coef.items())
            starts.append((coef, rem))
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
        for _, i, j, al, be in best_pair[:1]:
            a0, b0 = int(al), int(be)
            coef = {i: a0, j: b0}
            starts.append((coef, t - a0 * gens[i].t - b0 * gens[j].t))
        if abs(t) < 2.0 * max(abs(g.t) for g in gens):
            starts.append(({}, t))
        best = None
        for coef, rem in starts:
            coef, rem = self._refine(dict(coef), rem, tol)
            cst = sum(_loop_len(gens[b], c) for b, c in coef.items())
            key = (abs(rem) > tol, cst if abs(rem) <= tol else abs(rem))
            if best is None or key < best[0]:
                best = (key, coef, float(cst), abs(rem))
        return best[1], best[2], best[3]

    # ------------------------------------------------ dense: rotation loops
    def _rotation_loops(self, n: int = 16) -> list:
        """Short loops at F with distinct non-zero turning angles (``s a^-1`` of
        a walk ``s`` and the shortest walk ``a`` to the same face, and the
        analysis's ``R_j``), as ``(word, angle, length)``."""
        W = self.fwd
        F = self.F
        first = {}
        for i, f in enumerate(W.face.tolist()):
            if f not in first:
                first[f] = i
        anc = np.array([first[f] for f in W.face.tolist()])
        d = wrap_angle_np(W.ang - W.ang[anc])
        lenb = W.depth + W.depth[anc]
        ok = np.abs(d) > 1e-9
        idx = np.flatnonzero(ok)
        key = np.minimum(_akey(d[idx]), _akey(-d[idx]))
        o = np.lexsort((lenb[idx], key))
        ko = key[o]
        firstk = np.ones(len(o), dtype=bool)
        firstk[1:] = ko[1:] != ko[:-1]
        cand = idx[o[firstk]]
        cand = cand[np.argsort(lenb[cand], kind="stable")][: 4 * n]
        loops = []
        words = [purge(concat(W.word(int(s)), inverse(W.word(int(anc[s])), F)), F) for s in cand]
        words += [r["word"] for r in self.A.rotation_generators]
        seen = set()
        for w in sorted(words, key=len):
            if not w:
                continue
            m = self.table.word_motion(F, w)
            a = float(wrap_angle_np(m.angle))
            if abs(a) <= 1e-9:
                continue
            k = min(int(_akey(np.array([a]))[0]), int(_akey(np.array([-a]))[0]))
            if k in seen:
                continue
            seen.add(k)
            loops.append((w, a, len(w)))
            if len(loops) >= n:
                break
        return loops

    def rotation_table(self, width: float):
        """Dial/Dijkstra over heading bins of ``width`` rad: the cheapest product
        of rotation loops reaching each heading (exact angles tracked)."""
        nb = int(min(1 << 17, max(64, math.ceil(TWO_PI / width))))
        key = nb
        if key in self._rot_tables:
            return self._rot_tables[key]
        if self._rot_loops is None:
            self._rot_loops = self._rotation_loops()
        loops = self._rot_loops
        w = TWO_PI / nb
        INF = np.iinfo(np.int64).max
        dist = np.full(nb, INF, dtype=np.int64)
        ang = np.zeros(nb)
        pbin = np.full(nb, -1, dtype=np.int64)
        pcode = np.zeros(nb, dtype=np.int64)

        def binof(a):
            return (np.floor(np.mod(a, TWO_PI) / w).astype(np.int64)) % nb

        b0 = int(binof(np.array([0.0]))[0])
        dist[b0] = 0
        A_ = np.array([a for _, a, _ in loops] + [-a for _, a, _ in loops])
        L_ = np.array([L for _, _, L in loops] * 2, dtype=np.int64)
        C_ = np.array([i + 1 for i in range(len(loops))] + [-(i + 1) for i in range(len(loops))])
        lmin = int(L_.min()) if L_.size else 1
        # Dial's algorithm, a window of lmin cost levels at a time: children of
        # a node settled in [c, c + lmin) cost >= c + lmin, so the window is final.
        pending = {0: [np.array([b0])]}
        cmax = 50_000
        while pending:
            c = min(pending)
            if c > cmax:
                break
            keys = [k for k in pending if k < c + lmin]
            fr = np.unique(np.concatenate([a for k in keys for a in pending.pop(k)]))
            fr = fr[(dist[fr] >= c) & (dist[fr] < c + lmin)]
            if not fr.size:
                continue
            na = (ang[fr][:, None] + A_[None, :]).ravel()
            nc = (dist[fr][:, None] + L_[None, :]).ravel()
            src = np.repeat(fr, A_.size)
            code = np.tile(C_, fr.size)
            nbn = binof(na)
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
        reached = np.sort(ang[dist < INF])
        if reached.size:
            gaps = np.diff(np.r_[reached, reached[0] + TWO_PI])
            gap = float(gaps.max()) / 2.0  # worst distance of a heading to a reached one
        else:
            gap = math.inf
        tab = (nb, w, dist, ang, pbin, pcode, binof, gap)
        self._rot_tables[key] = tab
        return tab

    def rotation_word(self, target: float, tol: float):
        """Product of rotation loops turning by ``target`` within ``tol`` (or as
        close as the table gets): ``(word, angle)``; ``((), 0.0)`` if none needed."""
        if abs(float(wrap_angle_np(target))) <= tol:
            return (), 0.0
        tab = None
        for div in (8, 32, 128):
            tab = self.rotation_table(max(tol / div, 1e-12))
            if tab[7] <= tol or tab[0] >= (1 << 17):
                break
        nb, w, dist, ang, pbin, pcode, binof, gap = tab
        b = int(binof(np.array([target]))[0])
        cands = [(b + d) % nb for d in (-1, 0, 1)]
        best = None
        for cb in cands:
            if dist[cb] == np.iinfo(np.int64).max:
                continue
            res = abs(float(wrap_angle_np(ang[cb] - target)))
            key = (res > tol, int(dist[cb]) if res <= tol else res)
            if best is None or key < best[0]:
                best = (key, cb)
        if best is None:
            return None
        cb = best[1]
        codes = []
        while pbin[cb] >= 0:
            codes.append(int(pcode[cb]))
            cb = int(pbin[cb])
        codes.reverse()
        F = self.F
        parts = []
        for code in codes:
            wd = self._rot_loops[abs(code) - 1][0]
            parts.extend(wd if code > 0 else inverse(wd, F))
        word = purge(tuple(parts), F)
        return word, float(ang[best[1]])

    # ------------------------------------------------------------ cores
    def _short_cores(self, G: int, depth: int = 2) -> list:
        """Cores ``A B^-1`` of two walks of length <= ``depth`` (any heading)."""
        W, B = self.fwd, self.bwd(G)
        F = self.F
        fa = np.flatnonzero(W.depth <= depth)
        fb = np.flatnonzero(B.depth <= depth)
        out = []
        for i in fa:
            for j in fb:
                if W.face[i] == B.face[j]:
                    out.append(purge(concat(W.word(int(i)), inverse(B.word(int(j)), G)), F))
        return out

    def _forward_groups(self):
        if self._fgroups is None:
            W = self.fwd
            ak = _akey(W.ang)
            groups = {}
            for key in set(zip(W.face.tolist(), ak.tolist())):
                groups[key] = None
            order = np.lexsort((ak, W.face))
            fo, ako = W.face[order], ak[order]
            bounds = np.flatnonzero(np.r_[True, (fo[1:] != fo[:-1]) | (ako[1:] != ako[:-1]), True])
            for s, e in zip(bounds[:-1], bounds[1:]):
                idx = order[s:e]
                groups[(int(fo[s]), int(ako[s]))] = (idx, None)
            self._fgroups = groups
            # per face, sorted by angle (dense regime)
            self._fface = {}
            for f in np.unique(W.face):
                idx = np.flatnonzero(W.face == f)
                o = idx[np.argsort(W.ang[idx])]
                self._fface[int(f)] = o
        return self._fgroups

    def _group_tree(self, key):
        g = self._fgroups.get(key)
        if g is None:
            return None
        idx, tree = g
        if tree is None:
            z = self.fwd.z[idx]
            tree = cKDTree(np.stack([z.real, z.imag], 1))
            self._fgroups[key] = (idx, tree)
        return idx, tree

    def cores_exact_heading(self, M: Motion, G: int, h: float, n_cores: int = N_CORES):
        """Cores ``A B^-1`` turning by exactly ``h`` (rational headings)."""
        self._forward_groups()
        B = self.bwd(G)
        a_req = wrap_angle_np(h + B.ang)
        z_req = M.z + np.exp(1j * h) * B.z
        keys = _akey(a_req)
        out = []
        order = np.lexsort((keys, B.face))
        fo, ko = B.face[order], keys[order]
        bnd = np.flatnonzero(np.r_[True, (fo[1:] != fo[:-1]) | (ko[1:] != ko[:-1]), True])
        rho = self.rho
        for s, e in zip(bnd[:-1], bnd[1:]):
            bidx = order[s:e]
            gt = self._group_tree((int(fo[s]), int(ko[s])))
            if gt is None:
                continue
            aidx, tree = gt
            kk = min(3, len(aidx))
            dist, ii = tree.query(np.stack([z_req[bidx].real, z_req[bidx].imag], 1), k=kk)
            if kk == 1:
                dist, ii = dist[:, None], ii[:, None]
            est = (self.fwd.depth[aidx[ii]] + B.depth[bidx][:, None] + rho * dist)
            for r in range(len(bidx)):
                for c in range(kk):
                    out.append((float(est[r, c]), int(aidx[ii[r, c]]), int(bidx[r])))
        out.sort()
        return out[:n_cores]

    def cores_dense(self, M: Motion, G: int, eta: float, n_cores: int = N_CORES):
        """Cores whose heading is within ``eta`` of the goal's."""
        self._forward_groups()
        B = self.bwd(G)
        W = self.fwd
        gamma = M.angle
        rho = self.rho
        out = []
        for X in np.unique(B.face):
            X = int(X)
            fidx = self._fface.get(X)
            if fidx is None:
                continue
            fa = W.ang[fidx]
            fa_ext = np.concatenate([fa - TWO_PI, fa, fa + TWO_PI])
            fidx_ext = np.concatenate([fidx, fidx, fidx])
            bidx = np.flatnonzero(B.face == X)
            a_req = wrap_angle_np(gamma + B.ang[bidx])
            lo = np.searchsorted(fa_ext, a_req - eta, side="left")
            hi = np.searchsorted(fa_ext, a_req + eta, side="right")
            cnt = hi - lo
            if not np.any(cnt):
                continue
            rep_b = np.repeat(bidx, cnt)
            offs = np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt)
            ia = fidx_ext[np.repeat(lo, cnt) + offs]
            core_ang = W.ang[ia] - B.ang[rep_b]
            z_core = W.z[ia] - np.exp(1j * core_ang) * B.z[rep_b]
            t = M.z - z_core
            est = W.depth[ia] + B.depth[rep_b] + rho * np.abs(t)
            if est.size > 4 * n_cores:
                sel = np.argpartition(est, 4 * n_cores)[: 4 * n_cores]
            else:
                sel = np.arange(est.size)
            for i in sel:
                out.append((float(est[i]), int(ia[i]), int(rep_b[i])))
        out.sort()
        return out[:n_cores]

    # ------------------------------------------------------------- plan
    def _assemble(self, coef: dict, core: tuple) -> tuple:
        F = self.F
        parts = []
        for b in sorted(coef):
            parts.extend(power(self.gens[b].word, coef[b], F))
        parts.extend(core)
        return purge(tuple(parts), F)

    def _evaluate(self, word: tuple, M: Motion):
        m = self.table.word_motion(self.F, word)
        dth = abs(float(wrap_angle_np(m.angle - M.angle)))
        dz = abs(m.z - M.z)
        return m, dth, dz

    def plan(self, M: Motion, G: int, eps: float, paper_core: Optional[tuple] = None) -> Optional[ShortResult]:
        """Shortest plan found for target motion ``M`` (start frame) ending on
        ``G``; ``None`` if no core could be matched."""
        A = self.A
        F = self.F
        results = []
        if self.regime in ("exact_lattice", "exact_heading"):
            step = float(A.smallest_rotation) * math.pi
            aL = float(A.table.word_motion(F, A.transit_paths[G]).angle)
            nstep = round((M.angle - aL) / step)
            h = aL + nstep * step
            cores = self.cores_exact_heading(M, G, h)
        else:
            cores = self.cores_dense(M, G, 0.5 * eps)
        core_words = []
        for est, ia, ib in cores:
            core_words.append(purge(concat(self.fwd.word(ia), inverse(self.bwd(G).word(ib), G)), F))
        if paper_core is not None:
            core_words.append(paper_core)
        if self.regime == "dense":
            # cheap cores of any heading, the heading fixed by rotation loops
            core_words.append(A.transit_paths[G])
            core_words.extend(self._short_cores(G))
        seen = set()
        scored = []
        for cw in core_words:
            if cw in seen:
                continue
            seen.add(cw)
            mc = self.table.word_motion(F, cw)
            if self.regime == "dense":
                need = float(wrap_angle_np(M.angle - mc.angle))
                rw = self.rotation_word(need, 0.45 * eps)
                if rw is None:
                    continue
                if rw[0]:
                    cw = purge(concat(rw[0], cw), F)
                    mc = self.table.word_motion(F, cw)
            # translation needed before the core: E_T o E_core = M (E_T a translation)
            t = M.z - mc.z
            scored.append((cw, mc, t))
        if not scored:
            return None
        if self.regime == "exact_lattice":
            for cw, mc, t in scored:
                k = closest_lattice_point(self.Bvecs, (t.real, t.imag))
                dec = self.decompose_lattice(k)
                if dec is None:
                    continue
                coef, cost = dec
                results.append((cost + len(cw), coef, cw))
        else:
            if not self.gens:
                for cw, mc, t in scored:
                    results.append((len(cw), {}, cw))
            else:
                # cheap ranking by the coarse estimate, fine stage for the best few
                prelim = sorted(scored, key=lambda s: len(s[0]) + self.rho * abs(s[2]))[:4]
                for cw, mc, t in prelim:
                    ang_res = abs(float(wrap_angle_np(M.angle - mc.angle)))
                    tol = max(0.0, 0.9 * eps - 0.0) if ang_res <= eps else 0.9 * eps
                    coef, cost, err = self.decompose_dense(t, tol)
                    results.append((cost + len(cw) + (0 if err <= tol else 1e9 * err), coef, cw))
        results.sort(key=lambda r: r[0])
        best = None
        for _, coef, cw in results[:8]:
            word = self._assemble(coef, cw)
            m, dth, dz = self._evaluate(word, M)
            err = max(dth, dz)
            key = (err > eps, len(word) if err <= eps else err)
            if best is None or key < best[0]:
                core_len = len(cw)
                best = (key, ShortResult(word=word, motion=m, error=err, orientation_residual=dth,
                                         position_residual=dz, core_length=core_len,
                                         translation_length=len(word) - core_len))
        return None if best is None else best[1]
