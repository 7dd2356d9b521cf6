"""Short integer combinations of planar translations (float LLL + Babai, and
a meet-in-the-middle sumset for small remainders).

Given translation vectors ``t_i`` (complex, metres) with costs ``len_i``
(tumbles of the loop word), find integers ``c_i`` with ``sum c_i t_i ~= t`` and
small ``sum |c_i| len_i``.  This is a closest-vector problem in the lattice of
``R^{N+2}`` spanned by the rows ``b_i = (len_i e_i, W Re t_i, W Im t_i)``:
``|sum c_i b_i - (0, W t)|^2 = sum (len_i c_i)^2 + W^2 |sum c_i t_i - t|^2``,
so ``W`` trades one metre of error against ``W`` tumbles.  The basis is
LLL-reduced once per ``W`` (textbook LLL, delta = 0.99, Gram-Schmidt by QR in
float64; the unimodular transform is tracked in exact Python ints) and each
target is solved by Babai's nearest-plane rounding -- which handles every
scale at once (big efficient loops for the bulk, combinations of them and of
tiny loops for the remainder).  Results are exact integer combinations; the
caller recomputes the achieved translation.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["lll_reduce", "CVPSolver", "Sumset"]


def _gso(B: np.ndarray):
    """Gram-Schmidt of the rows of B: (mu, |b*|^2) via QR."""
    R = np.linalg.qr(B.T, mode="r")
    d = np.diag(R).copy()
    d[d == 0] = 1e-300
    mu = (R / d[:, None]).T  # mu[i, j] = R[j, i] / R[j, j]
    return mu, d * d


def lll_reduce(B: np.ndarray, delta: float = 0.99, max_swaps: int = 200_000, effort=None,
               stats: dict | None = None):
    """LLL-reduce the rows of ``B`` (float64, linearly independent).

    Returns ``(Bred, T)`` with ``Bred = T @ B`` (up to float rounding) and
    ``T`` an integer unimodular matrix (numpy object array of Python ints).
    ``effort`` (an :class:`~planning.tumbling.effort.Effort`) is consulted
    every few swaps (a swap re-orthogonalises: ``n^2`` operations); ``stats``
    receives the operations spent (``stats["cost"]``).
    """
    B = np.array(B, dtype=float)
    n = B.shape[0]
    T = np.eye(n, dtype=object)
    for i in range(n):
        for j in range(n):
            T[i, j] = int(T[i, j])
    mu, bs = _gso(B)
    k = 1
    swaps = 0
    cost = n * n
    while k < n and swaps < max_swaps:
        for j in range(k - 1, -1, -1):
            q = round(mu[k, j])
            if q:
                B[k] -= q * B[j]
                T[k] = T[k] - int(q) * T[j]
                mu[k, : j + 1] -= q * mu[j, : j + 1]
                mu[k, j] = mu[k, j]  # mu[j, j] == 1
        if bs[k] >= (delta - mu[k, k - 1] ** 2) * bs[k - 1]:
            k += 1
        else:
            B[[k - 1, k]] = B[[k, k - 1]]
            T[[k - 1, k]] = T[[k, k - 1]]
            mu, bs = _gso(B)
            swaps += 1
            cost += n * n
            if effort is not None and swaps % 64 == 0:
                effort.check(cost, "LLL reduction")
            k = max(k - 1, 1)
    if effort is not None:
        effort.check(cost, "LLL reduction")
    if stats is not None:
        stats["cost"] = cost
    return B, T


class CVPSolver:
    """Babai rounding over an LLL-reduced embedding (see module doc).

    ``cost``: operations spent building it (LLL swaps x n^2), charged by the
    caller on every use (:mod:`planning.tumbling.effort`)."""

    def __init__(self, vecs, costs, weight: float, effort=None):
        t = np.asarray(vecs, dtype=complex)
        L = np.asarray(costs, dtype=float)
        n = t.size
        B = np.zeros((n, n + 2))
        B[np.arange(n), np.arange(n)] = L
        B[:, n] = weight * t.real
        B[:, n + 1] = weight * t.imag
        self.n = n
        self.weight = weight
        stats: dict = {}
        self.Bred, self.T = lll_reduce(B, effort=effort, stats=stats)
        self.cost = stats["cost"]
        Q, R = np.linalg.qr(self.Bred.T)
        self.Q = Q  # columns: normalised Gram-Schmidt directions
        self.R = R

    def solve(self, target: complex) -> list:
        """Integer coefficients (over the original vectors) for ``target``."""
        n = self.n
        y = np.zeros(n + 2)
        y[n] = self.weight * target.real
        y[n + 1] = self.weight * target.imag
        # Babai nearest plane: coordinates of y in the GSO basis
        z = self.Q.T @ y  # = R c for the real solution of Bred^T c = y (projected)
        c = np.zeros(n)
        R = self.R
        for i in range(n - 1, -1, -1):
            s = z[i] - R[i, i + 1:] @ c[i + 1:]
            c[i] = round(s / R[i, i])
        ci = [int(v) for v in c]
        coef = [0] * n
        for i, v in enumerate(ci):
            if v:
                row = self.T[i]
                for j in range(n):
                    if row[j]:
                        coef[j] += v * row[j]
        return coef


class Sumset:
    """All sums ``sum c_i t_i``, ``c_i in -r..r``, of a few generators, split in
    two halves (meet in the middle, KD-tree on the first half).

    ``scale`` (metres, the part's size): vectors closer than ``1e-12 scale``
    are one vector.  ``cost``: operations to build it (one per combination)."""

    def __init__(self, vecs: list, costs: list, combos: list, r: int = 2, scale: float = 1.0):
        # vecs: complex; costs: per unit count; combos: per generator a dict
        # {base index: count} (what one unit means in base generators)
        n = len(vecs)
        h = (3 * n + 4) // 5  # the KD-tree half is the larger one: fewer queries
        self.halves = []
        self.scale = float(scale)
        self.quantum = 1e-12 * self.scale
        self.cost = 0
        for part in (range(0, h), range(h, n)):
            part = list(part)
            coefs = np.array(np.meshgrid(*[np.arange(-r, r + 1)] * len(part), indexing="ij")).reshape(
                len(part), -1).T if part else np.zeros((1, 0), dtype=int)
            v = coefs @ np.array([vecs[i] for i in part], dtype=complex) if part else np.zeros(1, complex)
            c = np.abs(coefs) @ np.array([costs[i] for i in part], dtype=float) if part else np.zeros(1)
            # keep the cheapest combination per distinct vector
            q = np.round(np.stack([v.real, v.imag], 1) / self.quantum).astype(np.int64)
            self.cost += len(v)
            order = np.lexsort((c, q[:, 1], q[:, 0]))
            qo = q[order]
            first = np.ones(len(order), dtype=bool)
            first[1:] = np.any(qo[1:] != qo[:-1], axis=1)
            sel = order[first]
            self.halves.append((part, coefs[sel], v[sel], c[sel]))
        p1, c1, v1, k1 = self.halves[0]
        self.tree = cKDTree(np.stack([v1.real, v1.imag], 1))
        self.vecs = vecs
        self.costs = costs
        self.combos = combos
        self.smallest_cost = 8 * len(self.halves[1][2])

    def query(self, r: complex, tol: float, k: int = 4):
        """Cheapest combination within ``tol`` of ``r`` (or the nearest one):
        returns ``(coef dict over base generators, vector, cost, error)``."""
        p1, c1, v1, k1 = self.halves[0]
        p2, c2, v2, k2 = self.halves[1]
        targets = r - v2
        kk = min(k, len(v1))
        dist, idx = self.tree.query(np.stack([targets.real, targets.imag], 1), k=kk)
        if kk == 1:
            dist, idx = dist[:, None], idx[:, None]
        total = k1[idx] + k2[:, None]
        within = dist <= tol
        if np.any(within):
            tc = np.where(within, total, np.inf)
            flat = int(np.argmin(tc))
        else:
            flat = int(np.argmin(dist))
        i2, j = divmod(flat, kk)
        i1 = int(idx[i2, j])
        coef = {}
        for gi, c in zip(p1, c1[i1]):
            if c:
                for b, m in self.combos[gi].items():
                    coef[b] = coef.get(b, 0) + int(c) * m
        for gi, c in zip(p2, c2[i2]):
            if c:
                for b, m in self.combos[gi].items():
                    coef[b] = coef.get(b, 0) + int(c) * m
        vec = v1[i1] + v2[i2]
        return {b: c for b, c in coef.items() if c}, vec, float(total[i2, j]), float(dist[i2, j])

    def smallest_nonzero(self, count: int):
        """``count`` short non-zero vectors ``sum c_i t_i`` (cheap refinements),
        as ``(vector, cost, coef)``.  About ``8 len(second half)`` operations
        (:attr:`smallest_cost`)."""
        p1, c1, v1, k1 = self.halves[0]
        p2, c2, v2, k2 = self.halves[1]
        kk = min(4, len(v1))
        dist, idx = self.tree.query(np.stack([-v2.real, -v2.imag], 1), k=kk)
        if kk == 1:
            dist, idx = dist[:, None], idx[:, None]
        cands = []
        floor = 1e-12 * max(self.scale, float(np.max(np.abs(v1))))
        for i2 in range(len(v2)):
            for j in range(kk):
                i1 = int(idx[i2, j])
                vec = v1[i1] + v2[i2]
                if abs(vec) <= floor:
                    continue
                cands.append((abs(vec), float(k1[i1] + k2[i2]), i1, i2, vec))
        cands.sort()
        out = []
        seen = []
        for nrm, cost, i1, i2, vec in cands:
            if any(abs(vec - s) < self.quantum or abs(vec + s) < self.quantum for s in seen):
                continue
            coef = {}
            for gi, c in list(zip(p1, c1[i1])) + list(zip(p2, c2[i2])):
                if c:
                    for b, m in self.combos[gi].items():
                        coef[b] = coef.get(b, 0) + int(c) * m
            coef = {b: c for b, c in coef.items() if c}
            if not coef:
                continue
            seen.append(vec)
            out.append((vec, cost, coef))
            if len(out) >= count:
                break
        return out
