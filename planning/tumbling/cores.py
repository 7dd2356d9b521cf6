"""Meet-in-the-middle cores of short tumble plans.

A plan from face ``F`` to face ``G`` has a **core** ``A B^-1``: ``A`` a walk
from ``F`` and ``B`` a walk from ``G`` (both enumerated breadth-first,
:mod:`planning.tumbling.walks`) ending on the same face ``X``
(``F -> X -> G``).  :class:`CoreIndex` indexes the forward walks by (face,
heading key) and, per group, a KD-tree on their positions, and matches the
backward walks of a goal:

* :meth:`CoreIndex.exact_heading`: cores turning the part by exactly a given
  heading (rational defect angles: reachable headings are a coset of the
  rotation step), ranked by tumbles plus ``rho`` x the translation still
  needed (``rho``: tumbles per metre of the most efficient translation loop);
* :meth:`CoreIndex.dense`: cores whose heading is within ``eta`` of the goal's;
* :meth:`CoreIndex.short`: every core of two walks of length <= 2 (any heading).

Positions in metres, headings in radians, in the start face's frame.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from kernels import wrap_angle_np
from planning.tumbling.effort import VECTOR_OPS
from planning.tumbling.motions import Motion
from planning.tumbling.walks import Walks
from planning.tumbling.words import concat, inverse, purge

__all__ = ["CoreIndex", "N_CORES", "PAIR_CHUNK", "PAIR_OPS", "PAIR_CAP", "ETA_MAX",
           "RANK_DECIMALS"]

TWO_PI = 2.0 * math.pi
#: Cores returned per goal.
N_CORES = 24
#: Dense matching: walk pairs per chunk, and pairs per charged operation.
PAIR_CHUNK = 1 << 20
PAIR_OPS = 8
#: Dense matching: at most this many walk pairs per meeting face.
PAIR_CAP = 1 << 21
#: Dense matching: heading window half-width cap (rad).
ETA_MAX = 0.999 * math.pi


#: Core estimates (tumbles) are ranked at this many decimals, then by walk
#: index: estimates equal but for rounding (a near-tame part's noise) tie, and
#: ties are broken the same way whatever the noise.
RANK_DECIMALS = 6


def _rank(core: tuple) -> tuple:
    """Sort key of an ``(estimate, a, b)`` core triple (see ``RANK_DECIMALS``)."""
    return (round(core[0], RANK_DECIMALS), core[1], core[2])


class CoreIndex:
    """Forward walks ``W`` from the start face, indexed for core matching.

    ``key``: the heading key of the walks (``key(headings, faces)``).
    ``rho``: tumbles per metre of translation still needed (set by the planner).
    """

    def __init__(self, W: Walks, key, rho: float = 0.0):
        self.W = W
        self.key = key
        self.rho = rho
        ak = key(W.ang, W.face)
        order = np.lexsort((ak, W.face))
        fo, ako = W.face[order], ak[order]
        bounds = np.flatnonzero(np.r_[True, (fo[1:] != fo[:-1]) | (ako[1:] != ako[:-1]), True])
        self._groups = {(int(fo[s]), int(ako[s])): order[s:e] for s, e in zip(bounds[:-1], bounds[1:])}
        self._trees: dict = {}
        # per face, walk indices sorted by heading (dense matching)
        self._by_face = {}
        for f in np.unique(W.face):
            idx = np.flatnonzero(W.face == f)
            self._by_face[int(f)] = idx[np.argsort(W.ang[idx])]

    def _group_tree(self, key):
        idx = self._groups.get(key)
        if idx is None:
            return None
        tree = self._trees.get(key)
        if tree is None:
            z = self.W.z[idx]
            tree = self._trees[key] = cKDTree(np.stack([z.real, z.imag], 1))
        return idx, tree

    def exact_heading(self, B: Walks, M: Motion, h: float, n_cores: int = N_CORES,
                      effort=None) -> list:
        """Cores ``A B^-1`` (``B`` walks from the goal face) turning by exactly
        ``h`` rad, for target motion ``M``: ``(estimate, a, b)`` index triples,
        best first, at most ``n_cores``."""
        if effort is not None:
            effort.charge(len(B) + len(self.W) // VECTOR_OPS, "cores")
        a_req = wrap_angle_np(h + B.ang)
        z_req = M.z + np.exp(1j * h) * B.z
        keys = self.key(a_req, B.face)
        out = []
        order = np.lexsort((keys, B.face))
        fo, ko = B.face[order], keys[order]
        bnd = np.flatnonzero(np.r_[True, (fo[1:] != fo[:-1]) | (ko[1:] != ko[:-1]), True])
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
            est = (self.W.depth[aidx[ii]] + B.depth[bidx][:, None] + self.rho * dist)
            for r in range(len(bidx)):
                for c in range(kk):
                    out.append((float(est[r, c]), int(aidx[ii[r, c]]), int(bidx[r])))
        out.sort(key=_rank)
        return out[:n_cores]

    def dense(self, B: Walks, M: Motion, eta: float, n_cores: int = N_CORES, effort=None) -> list:
        """Cores whose heading is within ``eta`` rad of the target motion
        ``M``'s: ``(estimate, a, b)`` triples, best first, at most ``n_cores``.
        ``eta`` is capped below pi (a wider window only repeats walks).  Walk
        pairs are matched in chunks of at most ``PAIR_CHUNK`` (memory stays
        bounded when headings cluster, as for a near-tame part or a huge eps),
        at most ``PAIR_CAP`` per meeting face (backward walks shallowest
        first); each pair is charged ``1/PAIR_OPS`` operation."""
        eta = min(eta, ETA_MAX)
        if effort is not None:
            effort.charge(len(B) + len(self.W) // VECTOR_OPS, "cores")
        W = self.W
        out = []
        for X in np.unique(B.face):
            fidx = self._by_face.get(int(X))
            if fidx is None:
                continue
            fa = W.ang[fidx]
            fa_ext = np.concatenate([fa - TWO_PI, fa, fa + TWO_PI])
            fidx_ext = np.concatenate([fidx, fidx, fidx])
            bidx = np.flatnonzero(B.face == X)
            a_req = wrap_angle_np(M.angle + B.ang[bidx])
            lo = np.searchsorted(fa_ext, a_req - eta, side="left")
            cnt = np.searchsorted(fa_ext, a_req + eta, side="right") - lo
            csum = np.cumsum(cnt)
            n_b = max(1, int(np.searchsorted(csum, PAIR_CAP, side="right")))  # shallowest first
            first = 0
            while first < n_b:
                last = int(np.searchsorted(csum, (csum[first] - cnt[first]) + PAIR_CHUNK, side="right"))
                last = min(max(last, first + 1), n_b)
                sl = slice(first, last)
                first = last
                if not np.any(cnt[sl]):
                    continue
                if effort is not None:
                    effort.charge(int(cnt[sl].sum()) // PAIR_OPS, "cores")
                out.extend(self._dense_pairs(B, M, bidx[sl], lo[sl], cnt[sl], fidx_ext, n_cores))
        out.sort(key=_rank)
        return out[:n_cores]

    def _dense_pairs(self, B, M, bidx, lo, cnt, fidx_ext, n_cores) -> list:
        """The ``4 n_cores`` best pairs of backward walks ``bidx`` with the
        forward walks ``fidx_ext[lo[i]:lo[i] + cnt[i]]``."""
        W = self.W
        rep_b = np.repeat(bidx, cnt)
        offs = np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt)
        ia = fidx_ext[np.repeat(lo, cnt) + offs]
        core_ang = W.ang[ia] - B.ang[rep_b]
        z_core = W.z[ia] - np.exp(1j * core_ang) * B.z[rep_b]
        t = M.z - z_core
        est = W.depth[ia] + B.depth[rep_b] + self.rho * np.abs(t)
        if est.size > 4 * n_cores:
            sel = np.argpartition(est, 4 * n_cores)[: 4 * n_cores]
        else:
            sel = np.arange(est.size)
        return [(float(est[i]), int(ia[i]), int(rep_b[i])) for i in sel]

    def short(self, B: Walks, F: int, G: int, depth: int = 2) -> list:
        """Every core ``purge(A B^-1)`` of a forward and a backward walk of
        length <= ``depth`` ending on the same face (any heading)."""
        W = self.W
        fa = np.flatnonzero(W.depth <= depth)
        fb = np.flatnonzero(B.depth <= depth)
        out = []
        for i in fa:
            for j in fb:
                if W.face[i] == B.face[j]:
                    out.append(purge(concat(W.word(int(i)), inverse(B.word(int(j)), G)), F))
        return out
