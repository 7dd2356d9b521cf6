"""Closed-form solves of small linear systems (2 x 2 and 3 x 3), batched by
broadcasting over leading axes.

The kernels' replacement for ``jnp.linalg.solve`` and ``jnp.linalg.det``: on
the CPU those lower to LAPACK custom calls (``lapack_dgetrf_ffi``) whose batched
form splits its work over XLA's intra-op thread pool and blocks a pool thread
until the pieces are done.  When two compiled replays execute at once (two
devices, or two threads), each can hold a pool thread waiting for pieces queued
behind the other: ``nudge certify examples/certify_plate.yaml`` deadlocked that
way (December 2026, jaxlib 0.10.2; the stacks showed every XLA worker in
``jax::ParallelBatchMap`` under ``LuDecomposition``).  These are plain XLA
arithmetic, and for systems this small cheaper too.  Dimensionless: the units
are the caller's.
"""
from __future__ import annotations

import jax.numpy as jnp


def det2(A):
    """Determinants of (..., 2, 2) matrices."""
    return A[..., 0, 0] * A[..., 1, 1] - A[..., 0, 1] * A[..., 1, 0]


def solve2(A, b):
    """``A^-1 b`` for (..., 2, 2) ``A`` and (..., 2) ``b`` (Cramer's rule; a
    singular ``A`` gives inf / nan, as a caller that guards it expects)."""
    det = det2(A)
    x0 = A[..., 1, 1] * b[..., 0] - A[..., 0, 1] * b[..., 1]
    x1 = A[..., 0, 0] * b[..., 1] - A[..., 1, 0] * b[..., 0]
    return jnp.stack([x0, x1], -1) / det[..., None]


def det3(A):
    """Determinants of (..., 3, 3) matrices (cofactor expansion along the first row)."""
    return (A[..., 0, 0] * (A[..., 1, 1] * A[..., 2, 2] - A[..., 1, 2] * A[..., 2, 1])
            - A[..., 0, 1] * (A[..., 1, 0] * A[..., 2, 2] - A[..., 1, 2] * A[..., 2, 0])
            + A[..., 0, 2] * (A[..., 1, 0] * A[..., 2, 1] - A[..., 1, 1] * A[..., 2, 0]))


def solve3(A, b):
    """``A^-1 b`` for (..., 3, 3) ``A`` and (..., 3) ``b``: Gaussian elimination
    with partial pivoting, unrolled (backward stable, as LAPACK's ``getrf`` /
    ``getrs``; a singular ``A`` gives inf / nan)."""
    M = jnp.concatenate([A, b[..., None]], axis=-1)                  # (..., 3, 4)
    rows = jnp.arange(3)
    for k in range(3):
        col = jnp.where(rows >= k, jnp.abs(M[..., :, k]), -1.0)     # candidates k..2
        p = jnp.argmax(col, axis=-1)                                 # (...,)
        onehot = (rows == p[..., None]).astype(M.dtype)              # (..., 3)
        pivot = jnp.sum(onehot[..., :, None] * M, axis=-2)           # row p
        rk = M[..., k, :]
        ek = (rows == k).astype(M.dtype)
        M = M + ek[:, None] * (pivot - rk)[..., None, :] + onehot[..., :, None] * (
            rk - pivot)[..., None, :]                                # rows k and p swapped
        f = jnp.where(rows > k, M[..., :, k] / M[..., k:k + 1, k], 0.0)
        M = M - f[..., :, None] * M[..., k:k + 1, :]
    x2 = M[..., 2, 3] / M[..., 2, 2]
    x1 = (M[..., 1, 3] - M[..., 1, 2] * x2) / M[..., 1, 1]
    x0 = (M[..., 0, 3] - M[..., 0, 1] * x1 - M[..., 0, 2] * x2) / M[..., 0, 0]
    return jnp.stack([x0, x1, x2], axis=-1)
