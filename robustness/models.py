"""The evaluation models and which one applies to a plan.

* ``"quasistatic"``: push plans under the quasi-static pushing model
  (:mod:`kernels.quasistatic`: sticking / sliding fence contact, limit surface).
* ``"exact"``: the papers' kinematics (push: :mod:`kernels.push`; tumble:
  :mod:`kernels.tumble`, the only non-physical model of a tumble).
* ``"mujoco"``: the plan rolled out in MuJoCo (:mod:`robustness.physics`).

No JAX here: the command lines import it to validate configs quickly.
"""
from __future__ import annotations

MODELS = ("quasistatic", "exact", "mujoco")


def model_for(model: str, kind: str) -> str:
    """The model a plan of ``kind`` (``"push"`` / ``"tumble"``) is evaluated under
    when ``model`` is asked for: tumbles have no quasi-static model, so anything but
    ``"mujoco"`` is ``"exact"`` for them."""
    return model if kind == "push" or model == "mujoco" else "exact"


__all__ = ["MODELS", "model_for"]
