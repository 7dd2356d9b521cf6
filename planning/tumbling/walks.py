"""Breadth-first enumeration of tumble walks from a face (numpy).

Used by :mod:`planning.tumbling.shorten` for its meet-in-the-middle cores and
to find loops: a walk is a word of landing faces from a root face; its end
configuration (face, heading, position of the face frame, in the root face's
frame at the start) is computed with a :class:`~planning.tumbling.motions.TumbleTable`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Optional

import numpy as np

from kernels import wrap_angle_np
from planning.tumbling.motions import TumbleTable

TWO_PI = 2.0 * math.pi
AKEY_BITS = 32
AKEY_MOD = 1 << AKEY_BITS
MAX_DEPTH = 64

__all__ = ["Walks", "enumerate_walks", "akey", "grid_key", "AKEY_MOD", "MAX_DEPTH"]

#: A heading key: ``key(headings, faces) -> int64 keys`` (equal keys = same heading).
HeadingKey = Callable[[np.ndarray, np.ndarray], np.ndarray]


def akey(a: np.ndarray) -> np.ndarray:
    """Integer key of headings (mod 2 pi) at 2 pi / 2^32 ~ 1.5e-9 rad."""
    x = np.mod(np.asarray(a, dtype=float), TWO_PI) / TWO_PI
    return np.round(x * AKEY_MOD).astype(np.int64) % AKEY_MOD


def grid_key(step: float, offsets: np.ndarray) -> HeadingKey:
    """Heading key on a rotation grid: face ``f``'s headings are taken to lie
    on ``offsets[f] + step Z`` (radians) and a heading is keyed by the grid
    point nearest to it (:func:`akey` of the snapped heading).  For a part
    whose defect angles are rational multiples of pi only to within a
    tolerance, the headings of walks that the rational model says are equal
    then get equal keys, whatever their accumulated rounding."""
    off = np.asarray(offsets, dtype=float)

    def key(a, faces):
        o = off[np.asarray(faces, dtype=np.int64)]
        return akey(o + step * np.round((np.asarray(a, dtype=float) - o) / step))

    return key


def _default_key(a, faces):
    return akey(a)


@dataclass
class Walks:
    """Walks from ``root`` (arrays indexed by state; state 0 is the empty walk).

    ``face``: face on the plane at the end; ``ang``: heading of its frame
    (wrapped, rad); ``z``: its origin (complex, metres), both in the root
    face's frame at the start; ``depth``: walk length; ``parent``: previous
    state (-1 for 0); ``cost``: operations spent enumerating them (one per
    candidate examined, see :mod:`planning.tumbling.effort`).
    """

    root: int
    face: np.ndarray
    ang: np.ndarray
    z: np.ndarray
    depth: np.ndarray
    parent: np.ndarray
    cost: int = 0

    def word(self, i: int) -> tuple:
        """The walk (landing faces) that reaches state ``i``."""
        w = []
        i = int(i)
        while i > 0:
            w.append(int(self.face[i]))
            i = int(self.parent[i])
        return tuple(reversed(w))

    def __len__(self) -> int:
        return len(self.face)


def _expand(table: TumbleTable, idx, f, a, z, prev):
    """Every non-backtracking tumble from the level's states (arrays): the
    children's ``(face, heading, position, parent index, previous face)``, or
    None when there are none."""
    nf, sa, sz = table.nf, table.step_angle, table.step_z
    cf, ca, cz, cpar, cprev = [], [], [], [], []
    for k in range(nf.shape[1]):
        g = nf[f, k]
        ok = (g >= 0) & (g != prev)
        if not np.any(ok):
            continue
        f0, a0 = f[ok], a[ok]
        cf.append(g[ok])
        cz.append(z[ok] + np.exp(1j * a0) * sz[f0, k])
        ca.append(wrap_angle_np(a0 + sa[f0, k]))
        cpar.append(idx[ok])
        cprev.append(f0)
    if not cf:
        return None
    return tuple(np.concatenate(c) for c in (cf, ca, cz, cpar, cprev))


def enumerate_walks(table: TumbleTable, root: int, budget: int, pos_tol: float,
                    max_depth: int = MAX_DEPTH, key: Optional[HeadingKey] = None,
                    effort=None) -> Walks:
    """Breadth-first non-backtracking walks from ``root``, at most ``budget``
    states, one per distinct configuration (face, heading key -- by default
    :func:`akey`, ~1.5e-9 rad -- and position to ``pos_tol`` metres), so each
    kept walk is a shortest one to its configuration among those enumerated.

    ``effort``: an :class:`~planning.tumbling.effort.Effort` consulted (not
    charged) before each level: enumeration stops with
    :class:`~planning.tumbling.effort.BudgetExhausted` when its cost so far
    would not fit; the caller charges ``Walks.cost``."""
    key = _default_key if key is None else key
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
    cost = 1
    while total < budget and d < max_depth and lvl_f.size:
        d += 1
        nxt = _expand(table, lvl_idx, lvl_f, lvl_a, lvl_z, lvl_p)
        if nxt is None:
            break
        cf, ca, cz, cpar, cprev = nxt
        cost += cf.size
        if effort is not None:
            effort.check(cost, "walk enumeration")
        ak = key(ca, cf)
        qx = np.round(cz.real / pos_tol).astype(np.int64)
        qy = np.round(cz.imag / pos_tol).astype(np.int64)
        keep = np.zeros(cf.size, dtype=bool)
        room = budget - total
        n_kept = 0
        for i, state in enumerate(zip(cf.tolist(), ak.tolist(), qx.tolist(), qy.tolist())):
            if state in visited:
                continue
            visited.add(state)
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
                 parent=np.concatenate(parents), cost=cost)
