"""The CPU threads one process runs its compiled replays and MuJoCo rollouts on."""
from __future__ import annotations

import os


def cpu_threads() -> int:
    """Threads for this process's parallel work: ``NUDGE_THREADS`` if set (a
    Dask worker sets it to its ``threads_per_worker``, so that workers sharing
    a machine do not oversubscribe it), else the CPU cores this process may
    run on."""
    env = os.environ.get("NUDGE_THREADS", "").strip()
    if env:
        return max(1, int(env))
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)
