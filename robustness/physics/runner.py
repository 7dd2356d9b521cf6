"""Driving an engine through a schedule, chunk by chunk (both backends).

:func:`make_engine` picks the backend (``"auto"``: MJX when JAX's default
device is an accelerator, else the C engine) and :func:`run_schedule` feeds
it the schedule's controls in chunks of ``PhysicsSettings.chunk_steps``,
hands every chunk's states and sensors to the monitors, and calls the hooks
(host-side changes between phases) at their phases' ends.
"""
from __future__ import annotations

from typing import Callable, Optional

import numpy as np

from robustness.physics.settings import BACKENDS


def default_backend() -> str:
    """``"mjx"`` when JAX's default backend is an accelerator (gpu, tpu) and
    ``mujoco.mjx`` imports, else ``"c"``."""
    import jax

    if jax.default_backend() in ("gpu", "cuda", "rocm", "tpu"):
        try:
            from robustness.physics.mjx_engine import mjx

            mjx()
            return "mjx"
        except ImportError:  # pragma: no cover - mjx is a dependency
            return "c"
    return "c"


def check_contact_model(backend: str, settings) -> None:
    """Raise ValueError when ``backend`` cannot run the contact model of
    ``settings``: MJX has no noslip solver."""
    if backend == "mjx" and settings is not None and settings.noslip_iterations > 0:
        raise ValueError(f"backend: MJX has no noslip solver, and the cell's contact model uses "
                         f"it (physics.cell.noslip_iterations {settings.noslip_iterations}); set "
                         f"physics.cell.noslip_iterations: 0 and impratio: 30 (the soft model, "
                         f"run by both engines) or backend: c")


def resolve_backend(backend: str, settings=None) -> str:
    """Validate ``backend`` (one of ``BACKENDS``) against the contact model of
    ``settings`` and resolve ``"auto"``: MJX only on an accelerator and only for
    the soft contact model (``noslip_iterations == 0``; MJX has no noslip
    solver), so that the contact model never changes with the hardware."""
    if backend not in BACKENDS:
        raise ValueError(f"backend: expected one of {BACKENDS}, got {backend!r}")
    check_contact_model(backend, settings)
    noslip = settings is not None and settings.noslip_iterations > 0
    if backend == "auto":
        return "c" if noslip else default_backend()
    return backend


def make_engine(backend: str, models, settings):
    """An engine (:class:`~robustness.physics.c_engine.CEngine` or
    :class:`~robustness.physics.mjx_engine.MJXEngine`) for the models."""
    if backend == "mjx":
        from robustness.physics.mjx_engine import MJXEngine

        return MJXEngine(models, settings.chunk_steps)
    from robustness.physics.c_engine import CEngine

    return CEngine(models, settings.threads)


def check_batch(draws) -> None:
    """Raise ValueError unless ``draws`` is a :class:`robustness.samplers.Draws`
    of at least one sample whose every sampled field holds ``draws.n`` samples
    (its axis 0, where ``in_axes`` says 0)."""
    import jax

    from robustness import Draws

    if not isinstance(draws, Draws):
        raise ValueError(f"draws: expected the Draws of Sampler.sample, got {type(draws).__name__}")
    n = draws.n
    if not (isinstance(n, (int, np.integer)) and not isinstance(n, bool) and n >= 1):
        raise ValueError(f"draws: expected at least one sample, got n={n!r}")
    sizes = {int(np.shape(x)[0]) for x, a in zip(jax.tree_util.tree_leaves(draws.params),
                                                 jax.tree_util.tree_leaves(
                                                     draws.in_axes, is_leaf=lambda v: v is None))
             if a == 0}
    if sizes and sizes != {int(n)}:
        raise ValueError(f"draws: the sampled params hold {sorted(sizes)} samples, not n={n}; "
                         "take them from Sampler.sample (or Draws.slice)")


def run_schedule(engine, schedule, state0: np.ndarray, consumers, chunk: int,
                 hooks: Optional[dict] = None) -> np.ndarray:
    """Run every sample through the whole schedule.

    Args:
      engine: from :func:`make_engine`.
      schedule: the :class:`~robustness.physics.schedule.Schedule`.
      state0: (n, nstate) initial states.
      consumers: objects with ``update(i0, states, sensordata)``, called with
        every chunk in order.
      chunk: steps per engine call.
      hooks: phase index -> ``f(state, i_phase) -> state``, called after that
        phase (which must have ``hook=True``).

    Returns:
      (n, nstate) final states.
    """
    hooks = hooks or {}
    ends = schedule.hook_ends()
    cuts = sorted(ends)
    state = np.array(state0, np.float64)
    n = state.shape[0]
    i = 0
    while i < schedule.total:
        nxt = next((c for c in cuts if c > i), schedule.total)
        i1 = min(i + chunk, nxt, schedule.total)
        states, sens = engine.run(state, schedule.controls(i, i1, n))
        for c in consumers:
            c.update(i, states, sens)
        state = states[:, -1].copy()
        i = i1
        if i in ends and ends[i] in hooks:
            fn: Callable = hooks[ends[i]]
            state = fn(state, ends[i])
    return state
