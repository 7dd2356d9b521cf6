"""Physics rollouts of push and tumble plans in MuJoCo (the independent judge).

* :func:`rollout_push_plan`, :func:`rollout_tumble_plan`: one plan, ``n``
  sampled parts and executions (the samplers of :mod:`robustness.samplers`),
  per-sample outcomes as numpy arrays, comparable row by row with
  :func:`robustness.evaluation.evaluate`'s quasi-static and exact rows.
* :class:`PushRollout`, :class:`TumbleRollout` (each a :class:`RolloutVerdict`):
  what they return (frozen records, one field per outcome, each with its unit
  and frame).
* Two backends behind the ``backend`` argument: ``"c"`` (the C engine through
  ``mujoco.rollout``, threads) and ``"mjx"`` (MJX, float32, vmapped); ``"auto"``
  picks the C engine for the default contact model (noslip, which MJX cannot
  run) and MJX on an accelerator for the soft one (``check_contact_model``).
* :class:`PhysicsSettings`: the cell and engine settings, each with the
  number that justifies it.

Scenes are built in code (``mujoco.MjSpec``): :mod:`robustness.physics.scene`.
Nothing here reads or writes files.
"""
from robustness.physics.push import PUSH_FAILURE_MODES, rollout_push_plan
from robustness.physics.rollouts import PushRollout, RolloutVerdict, TumbleRollout
from robustness.physics.runner import default_backend
from robustness.physics.tumble import TUMBLE_FAILURE_MODES, rollout_tumble_plan
from robustness.physics.settings import BACKENDS, STROKES, PhysicsRun, PhysicsSettings

# used by the layers above (the one boundary: tests/test_layers.py)
from robustness.physics.geometry import POINTS_NOT_REALISABLE
from robustness.physics.runner import check_contact_model
from robustness.physics.settings import check_pad_friction

__all__ = ["rollout_push_plan", "rollout_tumble_plan", "PushRollout", "TumbleRollout",
           "RolloutVerdict", "PUSH_FAILURE_MODES", "TUMBLE_FAILURE_MODES", "PhysicsSettings", "PhysicsRun",
           "BACKENDS", "STROKES", "default_backend", "POINTS_NOT_REALISABLE",
           "check_contact_model", "check_pad_friction"]
