"""A chosen plan confirmed in physics: the plan a kinematic model chose (robust
synthesis) rolled out in MuJoCo on fresh draws of the same tolerances, and
whether physics and the model agree on it.

Tens of rollouts, not a certificate: the verdict stays the model's, on its own
samples.  The two are said to disagree when their two-sided Clopper-Pearson
intervals of the success probability, each at the certificate's confidence,
do not overlap (the model's from its certification samples, physics's from
the rollouts): a difference the samples show, not one a few rollouts could
make by chance.
"""
from __future__ import annotations

import dataclasses
import warnings

from robustness import stats


@dataclasses.dataclass(frozen=True)
class PhysicsCheck:
    """``k`` of ``n`` MuJoCo rollouts of a plan succeeded, beside the model's
    ``model_k`` of ``model_n`` on its certification samples.

    Attributes:
      n, k: rollouts and their successes (fresh draws).
      model: the kinematic model that chose and certified the plan.
      model_n, model_k: its samples and successes.
      confidence: of both two-sided intervals (the certificate's).
    """

    n: int
    k: int
    model: str
    model_n: int
    model_k: int
    confidence: float

    @property
    def interval(self) -> tuple[float, float]:
        """Physics's two-sided Clopper-Pearson interval of P(success)."""
        return stats.clopper_pearson(self.k, self.n, self.confidence)

    @property
    def model_interval(self) -> tuple[float, float]:
        """The model's, on its certification samples."""
        return stats.clopper_pearson(self.model_k, self.model_n, self.confidence)

    @property
    def agrees(self) -> bool:
        """The two intervals overlap."""
        (a, b), (c, d) = self.interval, self.model_interval
        return a <= d and c <= b

    def sentence(self) -> str:
        """One line for the certificate's note and the report."""
        (a, b), (c, d) = self.interval, self.model_interval
        pct = f"{self.confidence * 100:.4g}%"
        head = (f"MuJoCo on {self.n} fresh draws: {self.k}/{self.n} succeed "
                f"(P in [{a:.2f}, {b:.2f}] at {pct})")
        if self.agrees:
            return f"{head}, consistent with the {self.model} model ({self.model_k}/{self.model_n})"
        side = "more" if c > b else "less"
        return (f"{head}: physics and the {self.model} model DISAGREE on this plan (the model "
                f"predicts {side} success: {self.model_k}/{self.model_n}, P in [{c:.2f}, {d:.2f}])")

    def to_row(self) -> dict:
        """The ``certificates`` table's physics columns."""
        return dict(physics_n_samples=self.n, physics_n_success=self.k,
                    physics_ci_low=stats.one_sided_lower(self.k, self.n, self.confidence),
                    physics_agrees=self.agrees)


#: the certificates table's physics columns when no plan was rolled out
NO_PHYSICS = dict(physics_n_samples=0, physics_n_success=0, physics_ci_low=float("nan"),
                  physics_agrees=None)


def confirmation_key(key):
    """The rollouts' draws of a task certified with ``key``: a stream of their
    own (like :func:`robustness.synthesis.selection_key`)."""
    import jax

    return jax.random.fold_in(key, 0xC0F1)


def confirm_in_physics(plan, sampler, n: int, key, requirement, *, model: str, model_k: int,
                       model_n: int, physics=None) -> PhysicsCheck:
    """Roll ``plan`` out in MuJoCo (:func:`robustness.evaluate`, ``model="mujoco"``,
    ``physics`` a :class:`~robustness.physics.PhysicsRun`) on ``n`` draws of
    ``sampler`` with ``key`` (pass :func:`confirmation_key` of the task's key),
    each judged by the :class:`~robustness.Requirement`'s criterion, and set
    the result beside the ``model``'s ``model_k`` / ``model_n`` (both bounds at
    the requirement's confidence)."""
    from robustness.blocks import sample_block
    from robustness.models import Model

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        k = sample_block(plan, sampler, int(n), key, requirement.criterion,
                         Model("mujoco", physics=physics)).n_success
    return PhysicsCheck(int(n), k, model, int(model_n), int(model_k),
                        float(requirement.confidence))


__all__ = ["PhysicsCheck", "NO_PHYSICS", "confirm_in_physics", "confirmation_key"]
