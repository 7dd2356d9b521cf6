"""The C engine backend: ``mujoco.rollout`` over per-sample models, threaded.

Every sample has its own :class:`mujoco.MjModel` (same structure, different
part); ``mujoco.rollout`` steps them all from a batch of
``mjSTATE_FULLPHYSICS`` states under open-loop controls, on a pool of threads
(one ``MjData`` per thread), and returns every step's state and sensor data.
The engine is stateless between calls (the solver's warm start is not carried
over from one call to the next, as in MJX here).
"""
from __future__ import annotations

import mujoco
import numpy as np
from mujoco import rollout as mj_rollout

from robustness.cpus import cpu_threads


class CEngine:
    """Runs chunks of steps for a batch of per-sample models.

    Args:
      models: the per-sample models (same sizes).
      threads: worker threads (0: :func:`robustness.cpus.cpu_threads`; never
        more than the number of models).
    """

    name = "c"

    def __init__(self, models, threads: int = 0):
        self.models = list(models)
        if not self.models:
            raise ValueError("models: expected at least one model")
        nthread = min(threads or cpu_threads(), len(self.models))
        self.datas = [mujoco.MjData(self.models[0]) for _ in range(nthread)]
        self._pool = mj_rollout.Rollout(nthread=nthread if nthread > 1 else 0)

    def run(self, state: np.ndarray, controls: np.ndarray):
        """Step every sample ``controls.shape[1]`` times.

        Args:
          state: (n, nstate) ``mjSTATE_FULLPHYSICS`` states.
          controls: (n, K, nu) controls.

        Returns:
          ``(states (n, K, nstate), sensordata (n, K, nsensordata))``: the
          state after each step and the sensors computed during it.
        """
        st, sd = self._pool.rollout(self.models, self.datas, np.ascontiguousarray(state),
                                    np.ascontiguousarray(controls), nstep=controls.shape[1])
        return st, sd

    def set_pair_friction(self, pair_ids, mu: np.ndarray) -> None:
        """Set the sliding friction of contact pairs ``pair_ids`` (k of them),
        per sample: ``mu`` (n, k) for both tangents or (n, k, 2) for the
        contact frame's first and second tangent."""
        ids = np.asarray(pair_ids, np.int64)
        mu = np.asarray(mu, np.float64)
        if mu.ndim == 2:
            mu = np.stack([mu, mu], axis=-1)
        for m, row in zip(self.models, mu):
            m.pair_friction[ids, :2] = row

    def close(self) -> None:
        """Stop the thread pool."""
        if self._pool is not None:
            self._pool.close()
            self._pool = None
