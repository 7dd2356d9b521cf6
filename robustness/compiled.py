"""The compiled executables a long process holds, and their release.

Every XLA:CPU executable holds memory maps of its own.  A process that
compiles many (a study over many plan shapes, a test suite) reaches the
kernel's limit (``vm.max_map_count``, 65,530 by default); the next
compilation's mmap then fails ("LLVM compilation error: Cannot allocate
memory") and XLA dies by a segmentation fault.  :func:`release_executables`
clears JAX's compilation caches once the process holds more than
:data:`MAX_MAPS` maps: what is needed again compiles again (or loads from the
persistent cache).  Here, not in ``kernels/``: it reads ``/proc`` and clears
JAX's process-wide caches, which the kernels never do.
"""
from __future__ import annotations

import gc

import jax

#: memory maps above which the compiled executables are released (the kernel's
#: default limit is 65,530)
MAX_MAPS = 30_000


def n_maps() -> int:
    """Memory maps this process holds (0 where ``/proc/self/maps`` does not
    exist: not Linux, no such limit to watch)."""
    try:
        with open("/proc/self/maps", "rb") as f:
            return sum(1 for _ in f)
    except OSError:
        return 0


def release_executables(limit: int = MAX_MAPS) -> bool:
    """Clear JAX's compilation caches when the process holds more than
    ``limit`` memory maps; True when it did."""
    if n_maps() <= limit:
        return False
    jax.clear_caches()
    gc.collect()
    return True


__all__ = ["MAX_MAPS", "n_maps", "release_executables"]
