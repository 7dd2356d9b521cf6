"""Robust plan synthesis: many candidate plans for one push task, scored on the
same Monte-Carlo draws, the best chosen by an explicit objective.

Akella & Mason's plans are sensitive to uncertainty ("To generate robust plans,
it is important to model uncertainty...").  The planner's choice is the
shortest plan of the nominal part; other valid plans (larger margins or safety
factors, the paper's sequences, the other sense, more reorient pushes,
model-based distances for the support family, slip-aware pushes) trade length
for robustness.  Here:

* :func:`push_candidates` enumerates them: for every planner setting of a grid
  (margins x safety factors x strategies x distance rules) the plans of
  :func:`planning.plan_alternatives`, distinct, the configured planner's own
  plan first (candidate 0: the default plan);
* :func:`score_candidates` replays every candidate on the SAME draws (common
  random numbers: a difference between two candidates is the plans', not the
  samples') in one compiled call (:func:`robustness.replay.run_push_many`),
  with the success rule of :func:`robustness.evaluate`;
* :func:`select` chooses by the objective: ``max_lower_bound`` (the highest
  one-sided Clopper-Pearson lower bound of success; ties, within one success,
  to the shorter push distance, then fewer pushes) or ``shortest_certifying``
  (the shortest plan whose bound reaches the requirement; the highest bound
  when none does).

The chosen plan's bound on the draws it was chosen on is optimistic (the
maximum of K noisy estimates is biased upward: ``tests/test_synthesis.py``
shows it on a constructed case), so a certificate of a synthesized plan is
taken on FRESH draws: :func:`selection_key` derives the selection's key from
the certification's with a fold-in no certification block uses, so the two
sample sets are independent.

Units: metres, radians; frames those of :func:`planning.plan_pose`.
"""
from __future__ import annotations

import dataclasses
import itertools
import warnings
from typing import Optional, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from kernels import float64
from planning import PlanningError, PushOptions, plan_alternatives, plan_pose
from robustness import stats
from robustness.evaluation import goal_errors, kinematic_success
from robustness.replay import run_push_many
from robustness.samplers import Sampler
from robustness.tolerances import SuccessCriterion

OBJECTIVES = ("max_lower_bound", "shortest_certifying")
#: fold-in of the selection draws (certification blocks fold in 0, 1, 2...)
SELECTION_STREAM = 0x5E1EC7


@dataclasses.dataclass(frozen=True)
class Candidate:
    """A candidate plan and the planner setting that made it.

    Attributes:
      plan: the verified :class:`~planning.PushPlan`.
      options: the :class:`~planning.PushOptions` it was planned with.
      rank: its place among that setting's alternatives (0: the planner's own choice).
    """

    plan: object
    options: PushOptions
    rank: int = 0

    @property
    def label(self) -> str:
        """One line: the setting and the plan (e.g. ``margin 12 deg, safety 1.5,
        search, peshkin, alternative 2: 6 pushes, 0.331 m``)."""
        o, p = self.options, self.plan
        slip = f", slip-aware mu_f >= {o.min_fence_mu:g}" if o.min_fence_mu is not None else ""
        alt = "planner's choice" if self.rank == 0 else f"alternative {self.rank}"
        return (f"margin {o.margin_deg:g} deg, safety {o.safety_factor:g}, {o.strategy}, "
                f"{p.distance_rule} distances{slip}, {alt}: {p.n_pushes} pushes, "
                f"{p.total_distance:.3f} m")


@dataclasses.dataclass(frozen=True)
class Scores:
    """The candidates on one set of draws.

    Attributes:
      success: (K, n) bool, sample i of candidate k succeeded.
      ci_low: (K,) one-sided Clopper-Pearson lower bounds at ``confidence``.
      distance: (K,) total push distance (m); pushes: (K,) push counts.
      confidence: of the bounds; n: draws per candidate.
    """

    success: np.ndarray
    ci_low: np.ndarray
    distance: np.ndarray
    pushes: np.ndarray
    confidence: float

    @property
    def n(self) -> int:
        return int(self.success.shape[1])

    @property
    def n_success(self) -> np.ndarray:
        return self.success.sum(axis=1)


@dataclasses.dataclass(frozen=True)
class Synthesis:
    """What :func:`synthesize` chose and from what.

    Attributes:
      candidates: the :class:`Candidate` list (index 0: the default plan).
      scores: their :class:`Scores` on the selection draws.
      chosen: index of the chosen candidate; objective: the objective used.
      why: one line saying why it was chosen.
      skipped: planner settings that gave no plan, one line each.
    """

    candidates: list
    scores: Scores
    chosen: int
    objective: str
    why: str
    skipped: tuple = ()

    @property
    def plan(self):
        return self.candidates[self.chosen].plan

    def describe(self) -> str:
        """The selection in one sentence (the certificate's ``selection`` column)."""
        s = self.scores
        k0, kc = int(s.n_success[0]), int(s.n_success[self.chosen])
        return (f"synthesized: {self.candidates[self.chosen].label}; chosen among "
                f"{len(self.candidates)} candidates by {self.objective} on {s.n} selection draws "
                f"({kc}/{s.n} succeeded, against {k0}/{s.n} for the default plan; its bound "
                f"{s.ci_low[self.chosen]:.4f} on those draws is optimistic: the verdict is "
                "taken on fresh draws)")


def selection_key(key):
    """The selection draws' key of a task whose certification samples are drawn
    with ``key`` (blocks ``fold_in(key, b)``, b = 0, 1, ...): an independent
    stream."""
    return jax.random.fold_in(key, SELECTION_STREAM)


def _settings(base: PushOptions, margins_deg, safety_factors, strategies, supports,
              min_fence_mu) -> list:
    out = [base]
    for m, sf, st, sup in itertools.product(margins_deg, safety_factors, strategies, supports):
        out.append(dataclasses.replace(base, margin_deg=float(m), safety_factor=float(sf),
                                       strategy=st, support=sup, min_fence_mu=None))
        if min_fence_mu is not None and sup not in (None, "any"):
            out.append(dataclasses.replace(out[-1], min_fence_mu=float(min_fence_mu)))
    return list(dict.fromkeys(out))


@float64
def push_candidates(vertices, start, goal, com=None, *, options: Optional[PushOptions] = None,
                    margins_deg: Sequence[float] = (3.0, 7.0, 12.0, 20.0),
                    safety_factors: Sequence[float] = (1.15, 1.5, 2.0),
                    strategies: Sequence[str] = ("search", "paper"),
                    supports: Sequence = (None,), min_fence_mu: Optional[float] = None,
                    per_setting: int = 3, limit: int = 64) -> tuple[list, tuple]:
    """Candidate plans for one push task.

    Args:
      vertices, com: the part (m, part frame); start, goal: poses (m, m, rad; world).
      options: the configured planner (its plan is candidate 0; the grid
        varies its margin, safety factor, strategy and distance rule and keeps
        the rest).
      margins_deg, safety_factors, strategies: the grid.
      supports: distance rules: ``None`` / ``"any"`` (Peshkin's distances) or a
        support family / ``{"c": [lo, hi]}`` (distances valid for every ``c``
        of it: :func:`planning.plan_pose`'s ``support``).
      min_fence_mu: with a support other than ``any``, each setting also gets
        its slip-aware variant (reorient pushes that stick for fence friction
        >= this).
      per_setting: plans per setting (:func:`planning.plan_alternatives`).
      limit: the most candidates (the settings taken in turn: every setting's
        own plan before any setting's alternatives).

    Returns:
      ``(candidates, skipped)``: the distinct :class:`Candidate` list (index 0
      the default plan) and one line per setting that gave no plan.

    Raises:
      PlanningError: the configured planner has no plan (its message).
    """
    base = options or PushOptions()
    first = plan_pose(vertices, start, goal, com, options=base)
    per_opts, skipped = [], []
    for o in _settings(base, margins_deg, safety_factors, strategies, supports, min_fence_mu):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                per_opts.append((o, plan_alternatives(vertices, start, goal, com, options=o,
                                                      limit=per_setting)))
        except (PlanningError, ValueError) as exc:
            skipped.append(f"margin {o.margin_deg:g} deg, safety {o.safety_factor:g}, "
                           f"{o.strategy}, support {o.support}: {str(exc).splitlines()[0][:160]}")
    out, seen = [Candidate(first, base, 0)], {_signature(first)}
    for rank in range(per_setting):   # every setting's own plan first, then their alternatives
        for o, plans in per_opts:
            if rank < len(plans) and len(out) < limit:
                sig = _signature(plans[rank])
                if sig not in seen:
                    seen.add(sig)
                    out.append(Candidate(plans[rank], o, rank))
    return out, tuple(skipped)


def _signature(plan) -> tuple:
    return tuple((p.kind, p.edge, round(p.direction[0], 9), round(p.direction[1], 9),
                  round(p.distance, 9)) for p in plan.pushes)


@float64
def score_candidates(plans: Sequence, sampler: Sampler, n: int, key, *,
                     model: str = "quasistatic", dtype=jnp.float64,
                     pos_eps_m: float = SuccessCriterion.pos_eps_m,
                     theta_eps_rad: float = SuccessCriterion.theta_eps_rad,
                     confidence: float = 0.95, chunk: int = 4096) -> Scores:
    """Replay push plans of one task on the same ``n`` draws of ``sampler``
    (drawn with ``key`` for the longest plan's push count) under ``model``
    (``quasistatic`` or ``exact``) and score them.

    Returns:
      :class:`Scores` (success as :func:`robustness.evaluate` decides it:
      inside the model, final pose within the eps of the goal).
    """
    if model not in ("quasistatic", "exact"):
        raise ValueError(f"model: robust synthesis scores candidates under the quasistatic or "
                         f"exact kinematics, got {model!r}")
    plans = list(plans)
    from kernels import polygon as pg

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", pg.PartWarning)
        poly0 = pg.make_polygon(np.asarray(plans[0].vertices), np.asarray(plans[0].com))
    P = max(len(p.pushes) for p in plans)
    draws = sampler.sample(key, int(n), body=poly0.body, dtype=jnp.float64,
                           n_vertices=len(plans[0].vertices), dim=2, n_pushes=P)
    r = run_push_many(plans, draws.astype(jnp.dtype(dtype)), model, jnp.dtype(dtype), chunk)
    _, _, _, ep, et = goal_errors(r.x, r.y, r.theta, plans[0].goal)
    valid = ~np.asarray(r.changed, bool) & ~np.asarray(r.truncated, bool)
    success = kinematic_success(valid, ep, et, pos_eps_m, theta_eps_rad)
    k = success.sum(axis=1)
    low = np.array([stats.one_sided_lower(int(x), int(n), confidence) for x in k])
    return Scores(success=success, ci_low=low,
                  distance=np.array([p.total_distance for p in plans], np.float64),
                  pushes=np.array([p.n_pushes for p in plans], np.int64),
                  confidence=float(confidence))


def select(scores: Scores, objective: str = "max_lower_bound",
           required_probability: Optional[float] = None) -> tuple[int, str]:
    """The chosen candidate's index and one line saying why.

    ``max_lower_bound``: the highest lower bound; candidates within one
    success of the best count as tied and the shortest push distance, then
    the fewest pushes, then the lowest index wins among them.
    ``shortest_certifying``: the shortest (distance, then pushes) whose bound
    reaches ``required_probability``; without one, ``max_lower_bound``.
    """
    if objective not in OBJECTIVES:
        raise ValueError(f"objective: expected one of {OBJECTIVES}, got {objective!r}")
    k = scores.n_success
    order = lambda idx: min(idx, key=lambda i: (scores.distance[i], scores.pushes[i], i))  # noqa: E731
    if objective == "shortest_certifying":
        if required_probability is None:
            raise ValueError("required_probability: shortest_certifying needs the requirement")
        ok = [i for i in range(len(k)) if scores.ci_low[i] >= required_probability]
        if ok:
            i = order(ok)
            return i, (f"the shortest of {len(ok)} candidates whose lower bound reaches "
                       f"{required_probability:g}")
        i, why = select(scores, "max_lower_bound")
        return i, f"no candidate's lower bound reaches {required_probability:g}; {why}"
    best = int(k.max())
    tied = [i for i in range(len(k)) if k[i] >= best - 1]
    i = order(tied)
    return i, (f"the highest lower bound ({best}/{scores.n} successes; {len(tied)} candidate(s) "
               "within one success of it, the shortest of them)")


@float64
def synthesize(vertices, start, goal, com=None, *, sampler: Sampler, n: int, key,
               options: Optional[PushOptions] = None, objective: str = "max_lower_bound",
               required_probability: Optional[float] = None, model: str = "quasistatic",
               dtype=jnp.float64, pos_eps_m: float = SuccessCriterion.pos_eps_m,
               theta_eps_rad: float = SuccessCriterion.theta_eps_rad,
               confidence: float = 0.95, **grid) -> Synthesis:
    """Candidates (:func:`push_candidates`, ``grid`` its keywords), scored on
    ``n`` draws with ``key`` (:func:`score_candidates`; pass
    :func:`selection_key` of the certification's key), chosen by ``objective``
    (:func:`select`).  Certify the chosen plan on other draws."""
    if model not in ("quasistatic", "exact"):
        model = "quasistatic"   # physics certifies; the kinematics choose
    cands, skipped = push_candidates(vertices, start, goal, com, options=options, **grid)
    scores = score_candidates([c.plan for c in cands], sampler, n, key, model=model, dtype=dtype,
                              pos_eps_m=pos_eps_m, theta_eps_rad=theta_eps_rad,
                              confidence=confidence)
    i, why = select(scores, objective, required_probability)
    return Synthesis(cands, scores, i, objective, why, skipped)


__all__ = ["Candidate", "Scores", "Synthesis", "OBJECTIVES", "push_candidates",
           "score_candidates", "select", "selection_key", "synthesize"]
