"""The margin recommendation: the first planner margin and safety factor of a
grid whose plan certifies, searched on some draws and certified on others.

A push task that did not certify is re-planned at each ``(margin_deg,
safety_factor)`` of the grid in order (margins ascending, then safety
factors), and each plan is judged on ``n`` *search* draws (the same draws for
every setting: :func:`robustness.selection_key` of the task's key, in blocks
of the one runner, :class:`robustness.BlockRun`): the first whose one-sided
lower bound reaches the requirement's probability is chosen.  Choosing the
first of many on the same draws favours the setting those draws happen to
suit, so the choice proves nothing by itself: the chosen plan is then
certified by :func:`robustness.certify` on the task's own draws (the key
the configured plan was certified with, blocks as the command line draws
them), and that certificate, not the search, is the recommendation's
claim.  Re-running the certification with the recommended setting draws
the same samples and gives the same verdict.
"""
from __future__ import annotations

import dataclasses
from typing import Callable, Optional, Sequence

from robustness import stats
from robustness.blocks import BlockRun
from robustness.certificates import Certificate, certify
from robustness.synthesis import selection_key
from robustness.tolerances import Requirement


@dataclasses.dataclass(frozen=True)
class MarginTrial:
    """One setting of the search: its margin (deg), safety factor, and the
    successes ``k`` of ``n`` search draws (``n = 0``: the planner gave no plan)."""

    margin_deg: float
    safety_factor: float
    k: int
    n: int


@dataclasses.dataclass(frozen=True)
class MarginRecommendation:
    """The setting the search chose and its certificate on the task's draws.

    Attributes:
      margin_deg, safety_factor: the chosen setting (deg, >= 1).
      plan: its plan.
      trials: every setting judged, in order, up to the chosen one.
      certificate: the chosen plan's :class:`~robustness.Certificate` on the
        task's own draws (the recommendation holds only if it is certified).
    """

    margin_deg: float
    safety_factor: float
    plan: object
    trials: tuple
    certificate: Certificate

    @property
    def certified(self) -> bool:
        return self.certificate.verdict == "certified"

    def sentence(self) -> str:
        """One line: the setting, what the search saw, and the certificate."""
        t = self.trials[-1]
        head = (f"margin {self.margin_deg:g} deg, safety factor {self.safety_factor:g}: "
                f"{t.k}/{t.n} on the search draws")
        c = self.certificate
        if self.certified:
            return f"{head}; on the task's own draws, not the search's: {c.claim}"
        return (f"{head}, but {c.verdict} on the task's own draws ({c.n_success}/"
                f"{c.n_samples}): no setting of the grid is recommended")


def recommend_margins(replan: Callable[[float, float], Optional[object]],
                      grid: Sequence[tuple[float, float]], sampler, n: int, key,
                      requirement: Optional[Requirement] = None, *, samples="auto",
                      model=None) -> tuple[Optional[MarginRecommendation], tuple]:
    """Search ``grid`` for the first setting whose plan certifies (module docstring).

    Args:
      replan: ``replan(margin_deg, safety_factor)`` -> the task's plan at that
        setting, or None where the planner has none.
      grid: ``(margin_deg, safety_factor)`` pairs in the order to try them.
      sampler: the :class:`~robustness.Sampler` of the tolerances.
      n: search draws per setting.
      key: the task's ``jax.random`` key (its certification's); the search
        draws are :func:`robustness.selection_key` of it.
      requirement: the :class:`~robustness.Requirement` (default
        ``Requirement()``).
      samples, model: the certification's (:func:`robustness.certify`).

    Returns:
      ``(recommendation, trials)``: the :class:`MarginRecommendation` (None if
      no setting passed the search) and every :class:`MarginTrial` judged.
    """
    from robustness.models import DEFAULT_MODEL

    if not (isinstance(n, int) and not isinstance(n, bool) and n >= 1):
        raise ValueError(f"n: expected an integer >= 1, got {n!r}")
    req = Requirement() if requirement is None else requirement
    if not isinstance(req, Requirement):
        raise ValueError(f"requirement: expected a robustness.Requirement, got {req!r}")
    model = DEFAULT_MODEL if model is None else model
    search, trials = selection_key(key), []
    for margin_deg, safety_factor in grid:
        plan = replan(float(margin_deg), float(safety_factor))
        if plan is None:
            trials.append(MarginTrial(float(margin_deg), float(safety_factor), 0, 0))
            continue
        r = req.for_plan(plan)
        run = BlockRun(plan, sampler, search, n, r.criterion, model)
        got, k = run.extend(n)
        trials.append(MarginTrial(float(margin_deg), float(safety_factor), k, got))
        if stats.one_sided_lower(k, got, r.confidence) >= r.probability:
            cert, _, _ = certify(plan, sampler, key, r, samples=samples, model=model)
            return (MarginRecommendation(float(margin_deg), float(safety_factor), plan,
                                         tuple(trials), cert), tuple(trials))
    return None, tuple(trials)


__all__ = ["MarginRecommendation", "MarginTrial", "recommend_margins"]
