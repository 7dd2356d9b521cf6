"""Breadth-first enumeration of tumble walks from a face (numpy).

Used by :mod:`planning.tumbling.shorten` for its meet-in-the-middle cores and
to find loops: a walk is a word of landing faces from a root face; its end
configuration (face, heading, position of the face frame, in the root face's
frame at the start) is computed with a :class:`~planning.tumbling.motions.TumbleTable`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from planning.tumbling.motions import TumbleTable
from kernels.planar import wrap_angle_np

TWO_PI = 2.0 * math.pi
AKEY_BITS = 32
AKEY_MOD = 1 << AKEY_BITS
MAX_DEPTH = 64

__all__ = ["Walks", "enumerate_walks", "akey", "AKEY_MOD", "MAX_DEPTH"]


def akey(a: np.ndarray) -> np.ndarray:
    """Integer key of headings (mod 2 pi) at 2 pi / 2^32 ~ 1.5e-9 rad."""
    x = np.mod(np.asarray(a, dtype=float), TWO_PI) / TWO_PI
    return np.round(x * AKEY_MOD).astype(np.int64) % AKEY_MOD


@dataclass
class Walks:
    """Walks from ``root`` (arrays indexed by state; state 0 is the empty walk).

    ``face``: face on the plane at the end; ``ang``: heading of its frame
    (wrapped); ``z``: its origin (complex), both in the root face's frame at
    the start; ``depth``: walk length; ``parent``: previous state (-1 for 0).
    """

    root: int
    face: np.ndarray
    ang: np.ndarray
    z: np.ndarray
    depth: np.ndarray
    parent: np.ndarray

    def word(self, i: int) -> tuple:
        w = []
        i = int(i)
        while i > 0:
            w.append(int(self.face[i]))
            i = int(self.parent[i])
        return tuple(reversed(w))

    def __len__(self) -> int:
        return len(self.face)


def enumerate_walks(table: TumbleTable, root: int, budget: int, pos_tol: float,
                    max_depth: int = MAX_DEPTH) -> Walks:
    """Breadth-first non-backtracking walks from ``root``, at most ``budget``
    states, one per distinct configuration (face, heading to ~1.5e-9 rad,
    position to ``pos_tol``), so each kept walk is a shortest one to its
    configuration among those enumerated."""
    nf, sa, sz = table.nf, table.step_angle, table.step_z
    K = nf.shape[1]
    faces = [np.array([root])]
    angs = [np.array([0.0])]
    zs = [np.array([0j])]
    depths = [np.array([0])]
    parents = [np.array([-1])]
    prevs = [np.array([-1])]
    visited = {(root, 0, 0, 0)}
    total = 1
    lvl_idx = np.array([0])
    lvl_f, lvl_a, lvl_z, lvl_p = faces[0], angs[0], zs[0], prevs[0]
    d = 0
    while total < budget and d < max_depth and lvl_f.size:
        d += 1
        cf, ca, cz, cpar, cprev = [], [], [], [], []
        for k in range(K):
            g = nf[lvl_f, k]
            ok = (g >= 0) & (g != lvl_p)
            if not np.any(ok):
                continue
            f0 = lvl_f[ok]
            a0 = lvl_a[ok]
            cf.append(g[ok])
            cz.append(lvl_z[ok] + np.exp(1j * a0) * sz[f0, k])
            ca.append(wrap_angle_np(a0 + sa[f0, k]))
            cpar.append(lvl_idx[ok])
            cprev.append(f0)
        if not cf:
            break
        cf = np.concatenate(cf)
        ca = np.concatenate(ca)
        cz = np.concatenate(cz)
        cpar = np.concatenate(cpar)
        cprev = np.concatenate(cprev)
        ak = akey(ca)
        qx = np.round(cz.real / pos_tol).astype(np.int64)
        qy = np.round(cz.imag / pos_tol).astype(np.int64)
        keep = np.zeros(cf.size, dtype=bool)
        room = budget - total
        n_kept = 0
        for i, key in enumerate(zip(cf.tolist(), ak.tolist(), qx.tolist(), qy.tolist())):
            if key in visited:
                continue
            visited.add(key)
            keep[i] = True
            n_kept += 1
            if n_kept >= room:
                break
        if n_kept == 0:
            break
        idx = np.flatnonzero(keep)
        new_idx = np.arange(total, total + idx.size)
        faces.append(cf[idx])
        angs.append(ca[idx])
        zs.append(cz[idx])
        depths.append(np.full(idx.size, d))
        parents.append(cpar[idx])
        prevs.append(cprev[idx])
        total += idx.size
        lvl_idx, lvl_f, lvl_a, lvl_z, lvl_p = new_idx, cf[idx], ca[idx], cz[idx], cprev[idx]
    return Walks(root=root, face=np.concatenate(faces), ang=np.concatenate(angs),
                 z=np.concatenate(zs), depth=np.concatenate(depths),
                 parent=np.concatenate(parents))
