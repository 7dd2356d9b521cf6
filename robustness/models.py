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


#: Measured throughput of a whole study, samples per second on 2 CPU cores after
#: compilation (sampling, replay or rollout, summaries and Parquet writes), by
#: (plan kind, model, support family); ``"*"`` stands for every family not listed.
#: For the commands' estimates (the line before a run, ``--dry-run``, the budget).
#: Push rows: ``bench/throughput.py`` (issue 41), the nice-stable pentagon, 4 random
#: tasks 5-15 cm away, two sample counts, the time of the extra samples:
#: ``RESULT quasistatic_any=821 exact_any=7.57e+03 limit_surface_rigid=7.87
#: limit_surface_any=0.856 mujoco_rigid=1.98 mujoco_any=1.05`` (the kernels alone are
#: faster: quasistatic 48,000-70,000/s in one process on one plan).  Families
#: not measured (tripod, uniform, ring) take the ``"*"`` row: for limit_surface
#: that is the mixture's, whose many-footed pads dominate it.  Tumble rows are
#: not re-measured yet: the exact replay's figure is the earlier table's, and a
#: MuJoCo tumble is taken to cost what a MuJoCo push does.
THROUGHPUT = {
    ("push", "exact", "*"): 7_500.0,
    ("push", "quasistatic", "*"): 800.0,
    ("push", "limit_surface", "rigid"): 8.0,
    ("push", "limit_surface", "*"): 0.85,
    ("push", "mujoco", "rigid"): 2.0,
    ("push", "mujoco", "*"): 1.0,
    ("tumble", "exact", "*"): 20_000.0,
    ("tumble", "mujoco", "*"): 1.0,
}


def samples_per_second(kind: str, model: str, support: object = "any") -> float:
    """Measured samples/s (2 CPU cores, compiled) of ``model`` on plans of
    ``kind`` for a part on ``support`` (a family name; anything else counts as
    ``"*"``): :data:`THROUGHPUT`."""
    model = model_for(model, kind)
    fam = support if isinstance(support, str) else "*"
    return THROUGHPUT.get((kind, model, fam), THROUGHPUT[(kind, model, "*")])


__all__ = ["MODELS", "PUSH_KINEMATIC", "THROUGHPUT", "model_for", "samples_per_second"]
