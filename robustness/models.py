"""The evaluation models and which one applies to a plan.

* ``"quasistatic"``: push plans under the quasi-static pushing model
  (:mod:`kernels.quasistatic`: sticking / sliding fence contact, limit surface).
* ``"limit_surface"``: push plans under the same quasi-static model on the
  exact limit surface of the sample's support points (its family's corners or
  feet and their loads, :mod:`kernels.quasistatic_points`): some 800 times
  slower (41 samples/s of an 8-push plan on rigid corners, 2 CPU cores), and it predicts the slip a part on 3-4 corners shows in
  MuJoCo where the ellipsoid of the same ``c`` predicts none.
* ``"exact"``: the papers' kinematics (push: :mod:`kernels.push`; tumble:
  :mod:`kernels.tumble`, the only non-physical model of a tumble).
* ``"mujoco"``: the plan rolled out in MuJoCo (:mod:`robustness.physics`).

No JAX here: the command lines import it to validate configs quickly.
"""
from __future__ import annotations

MODELS = ("quasistatic", "limit_surface", "exact", "mujoco")
#: the kinematic models of a push plan (no physics engine)
PUSH_KINEMATIC = ("quasistatic", "limit_surface", "exact")


def model_for(model: str, kind: str) -> str:
    """The model a plan of ``kind`` (``"push"`` / ``"tumble"``) is evaluated under
    when ``model`` is asked for: tumbles have no quasi-static model, so anything but
    ``"mujoco"`` is ``"exact"`` for them."""
    return model if kind == "push" or model == "mujoco" else "exact"


__all__ = ["MODELS", "PUSH_KINEMATIC", "model_for"]
