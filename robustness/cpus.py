"""The CPU threads one process runs its MuJoCo rollouts on (its compiled replays spread
over JAX's devices instead: :func:`robustness.replay.replay_devices`)."""
from __future__ import annotations

import os


def cpu_threads() -> int:
    """Threads for this process's parallel work: ``NUDGE_THREADS`` if set (a
    Dask worker sets it to its ``threads_per_worker``, so that workers sharing
    a machine do not oversubscribe it), else the CPU cores this process may
    run on."""
    env = os.environ.get("NUDGE_THREADS", "").strip()
    if env:
        if not env.isdigit() or int(env) < 1:
            raise ValueError(f"NUDGE_THREADS: expected a whole number >= 1, got {env!r}; "
                             "unset it to use every core")
        return int(env)
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)
