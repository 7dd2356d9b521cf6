"""Physics rollouts of push and tumble plans in MuJoCo (the independent judge).

* :func:`rollout_push_plan`, :func:`rollout_tumble_plan`: one plan, ``n``
  sampled parts and executions (the samplers of :mod:`robustness.samplers`),
  per-sample outcomes as numpy arrays, comparable row by row with
  :func:`robustness.evaluation.evaluate`'s quasi-static and exact rows.
* Two backends behind the ``backend`` argument: ``"c"`` (the C engine through
  ``mujoco.rollout``, threads) and ``"mjx"`` (MJX, float32, vmapped); ``"auto"``
  picks MJX on an accelerator and the C engine on a CPU machine.
* :class:`PhysicsSettings`: the cell and engine settings, each with the
  number that justifies it.

Scenes are built in code (``mujoco.MjSpec``): :mod:`robustness.physics.scene`.
Nothing here reads or writes files.
"""
from robustness.physics.push import PUSH_FAILURE_MODES, rollout_push_plan
from robustness.physics.runner import default_backend
from robustness.physics.tumble import TUMBLE_FAILURE_MODES, rollout_tumble_plan
from robustness.physics.settings import BACKENDS, STROKES, PhysicsRun, PhysicsSettings

__all__ = ["rollout_push_plan", "rollout_tumble_plan", "PUSH_FAILURE_MODES",
           "TUMBLE_FAILURE_MODES", "PhysicsSettings", "PhysicsRun", "BACKENDS", "STROKES",
           "default_backend"]
