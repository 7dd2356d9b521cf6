"""Some columns of a block of uniforms, computed without drawing the rest.

The samplers (:mod:`robustness.samplers`) draw each group's numbers as one
block ``jax.random.uniform(key, (n, width))`` whose layout is fixed (a column
per tolerance, per push, per tumble), so that a sample's numbers do not depend
on which tolerances are zero.  Most columns are often unused: the ``points``
support family's 64 columns under any other family, a zero tolerance's
columns, the per-tumble columns past the plan's length in its bucket.  With
JAX's partitionable threefry (``jax_threefry_partitionable``, the default) the
number at ``(i, j)`` of such a block is a function of the key and the flat
index ``i * width + j`` alone, so :func:`uniform_columns` computes exactly the
columns asked for (the same bits, the same floats) and the tables made from
them stay bit for bit those of the full block.

The hash itself (:func:`threefry2x32`) is written out here rather than bound
to JAX's ``threefry2x32`` primitive: on CPU JAX lowers that primitive as a
rolled loop of five steps, each writing two whole arrays to memory, while the
20 rounds written out fuse into one loop that keeps its state in registers
(the same integer arithmetic, so the same bits; 1.8x the numbers per second
on 2 cores).

Pure; unitless (uniforms in [0, 1)).
"""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

__all__ = ["threefry2x32", "uniform_columns"]

#: Threefry-2x32's rotation distances, alternating every four rounds.
_ROTATIONS = ((13, 15, 26, 6), (17, 29, 16, 24))


def _rotate_left(v, d: int):
    return (v << jnp.uint32(d)) | lax.shift_right_logical(v, jnp.uint32(32 - d))


def threefry2x32(k1, k2, x1, x2):
    """The Threefry-2x32 hash (20 rounds; Salmon et al. 2011) of the counters
    ``(x1, x2)`` under the key ``(k1, k2)``, as JAX's ``threefry2x32``
    primitive computes it (the same bits), written out round by round.

    Args:
      k1, k2: the key's two ``uint32`` words (scalars or broadcastable arrays).
      x1, x2: ``uint32`` counter arrays of one shape.

    Returns:
      ``(y1, y2)``, ``uint32`` arrays of that shape.
    """
    ks = (k1, k2, k1 ^ k2 ^ jnp.uint32(0x1BD11BDA))
    y1, y2 = x1 + ks[0], x2 + ks[1]
    for i in range(5):
        for r in _ROTATIONS[i % 2]:
            y1 = y1 + y2
            y2 = y1 ^ _rotate_left(y2, r)
        y1 = y1 + ks[(i + 1) % 3]
        y2 = y2 + ks[(i + 2) % 3] + jnp.uint32(i + 1)
    return y1, y2


def _typed(key) -> bool:
    return jnp.issubdtype(getattr(key, "dtype", None), jax.dtypes.prng_key)


def _exact_path(key, n: int, width: int, dtype) -> bool:
    """The per-element threefry bits can be computed here (else: full block)."""
    impl = str(jax.random.key_impl(key)) if _typed(key) else jax.config.jax_default_prng_impl
    return (jax.config.jax_threefry_partitionable and impl == "threefry2x32"
            and n * width < 2 ** 32
            and jnp.dtype(dtype) in (jnp.dtype(jnp.float32), jnp.dtype(jnp.float64)))


def uniform_columns(key, n: int, width: int, columns, dtype=jnp.float64):
    """``jax.random.uniform(key, (n, width), dtype)[:, columns]``, bit for bit,
    computing only the asked-for columns.

    Args:
      key: a threefry ``jax.random`` key (typed or raw ``uint32[2]``).
      n: rows (samples); width: the block's columns (static ints).
      columns: the wanted column indices, a static sequence of ints in
        ``[0, width)`` (order kept, repeats allowed); empty gives ``(n, 0)``.
      dtype: ``float32`` or ``float64`` (float64 needs ``jax_enable_x64``).

    Returns:
      ``(n, len(columns))`` uniforms in [0, 1).  Where the per-element path
      does not apply (``jax_threefry_partitionable`` off, another PRNG, a block
      of 2**32 numbers or more) the full block is drawn and sliced: the same
      numbers either way.
    """
    cols = np.asarray(tuple(int(c) for c in columns), np.int64)
    if cols.size and (cols.min() < 0 or cols.max() >= width):
        raise ValueError(f"columns: expected indices in [0, {width}), got {cols.tolist()}")
    if n == 0 or cols.size == 0:
        return jnp.zeros((n, cols.size), dtype)
    if not _exact_path(key, n, width, dtype):
        return jax.random.uniform(key, (n, width), dtype)[:, cols]
    k1, k2 = jax.random.key_data(key) if _typed(key) else jnp.asarray(key, jnp.uint32)
    rows = lax.broadcasted_iota(jnp.uint32, (n, cols.size), 0)
    lo = rows * jnp.uint32(width) + jnp.asarray(cols.astype(np.uint32))[None, :]
    hi = jnp.zeros_like(lo)          # the flat index is below 2**32
    b1, b2 = threefry2x32(k1, k2, hi, lo)
    if jnp.dtype(dtype) == jnp.dtype(jnp.float64):
        bits = (lax.convert_element_type(b1, jnp.uint64) << jnp.uint64(32)) \
            | lax.convert_element_type(b2, jnp.uint64)
        one = np.array(1.0, np.float64).view(np.uint64)
        fb = lax.shift_right_logical(bits, jnp.uint64(64 - 52)) | jnp.uint64(one)
        return lax.bitcast_convert_type(fb, jnp.float64) - jnp.float64(1.0)
    bits = b1 ^ b2
    one = np.array(1.0, np.float32).view(np.uint32)
    fb = lax.shift_right_logical(bits, jnp.uint32(32 - 23)) | jnp.uint32(one)
    return lax.bitcast_convert_type(fb, jnp.float32) - jnp.float32(1.0)
