"""Robust plan synthesis: many candidate plans for one task, scored on the same
Monte-Carlo draws, the best chosen by an explicit objective.

Akella & Mason's plans are sensitive to uncertainty ("To generate robust plans,
it is important to model uncertainty...").  The planner's choice is the
shortest plan of the nominal part; other valid plans (larger margins or safety
factors, the paper's sequences, the other sense, more reorient pushes,
model-based distances for the support family, slip-aware pushes) trade length
for robustness.  Here:

* :func:`push_candidates` enumerates them: for every planner setting of a grid
  (margins x safety factors x strategies x distance rules) the plans of
  :func:`planning.plan_alternatives`, distinct, the configured planner's own
  plan first (candidate 0: the default plan); :func:`tumble_candidates` the
  same for a tumble task (Marigo & Bicchi words of equal or near length:
  planned at tighter accuracies, at the part's tolerance, the paper's own
  construction when it is short, the other landing words of the search);
* :func:`score_candidates` replays every candidate on the SAME draws (common
  random numbers: a difference between two candidates is the plans', not the
  samples') in one compiled call (:func:`robustness.replay.run_push_many`),
  with the success rule of :func:`robustness.evaluate`;
* :func:`select` chooses by the objective: ``max_lower_bound`` (the highest
  one-sided Clopper-Pearson lower bound of success; ties, within one success,
  to the lower cost: the shorter push distance, or for tumbles the smaller
  first-order propagated error, :func:`robustness.bounds.tumble_plan_bound`;
  then fewer steps) or ``shortest_certifying`` (the cheapest plan whose bound
  reaches the requirement; the highest bound when none does).  Every
  candidate's first-order bound is reported beside its Monte Carlo (and, for
  tumbles, the certificate's summary carries the paper's eqs. 4-6).

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
import numpy as np

from kernels import float64
from planning import STRATEGIES, PlanningError, PushOptions, plan_alternatives, plan_pose
from robustness import stats
from robustness.kinds import kind_of
from robustness.models import DEFAULT_MODEL, Model, decision_model
from robustness.samplers import Sampler
from robustness.tolerances import Requirement, SuccessCriterion

OBJECTIVES = ("max_lower_bound", "shortest_certifying")
#: fold-in of the selection draws (certification blocks fold in 0, 1, 2...)
SELECTION_STREAM = 0x5E1EC7


@dataclasses.dataclass(frozen=True)
class Candidate:
    """A candidate plan and the planner setting that made it.

    Attributes:
      plan: the verified :class:`~planning.PushPlan`.
      options: the :class:`~planning.PushOptions` it was planned with (a
        :class:`TumbleSetting` for a tumble plan).
      rank: its place among that setting's alternatives (0: the planner's own choice).
    """

    plan: object
    options: PushOptions
    rank: int = 0

    @property
    def label(self) -> str:
        """One line: the setting and the plan (e.g. ``margin 12 deg, safety 1.5,
        search, peshkin, alternative 2: 6 pushes, 0.331 m``; ``eps 0.5 mm,
        shortest: 6 tumbles, error 2.1e-05``)."""
        o, p = self.options, self.plan
        if isinstance(o, TumbleSetting):
            how = ("the paper's construction" if not o.shorten
                   else "planner's choice" if self.rank == 0 else f"alternative {self.rank}")
            tv = f", planned at tau_v {o.tau_v * 1e3:g} mm" if o.tau_v else ""
            return (f"eps {o.eps * 1e3:g} mm{tv}, {how}: {p.n_tumbles} tumbles, exact error "
                    f"{p.error:.2g}")
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
      cost: (K,) what a tie is broken by: the total push distance (m), or for
        tumble plans the first-order propagated position error (m).
      steps: (K,) pushes or tumbles.
      confidence: of the bounds; n: draws per candidate.
      bound_position_m, bound_theta_rad: (K,) first-order bounds of the
        final error over the sampler's tolerance box (NaN: not computed).
    """

    success: np.ndarray
    ci_low: np.ndarray
    cost: np.ndarray
    steps: np.ndarray
    confidence: float
    bound_position_m: Optional[np.ndarray] = None
    bound_theta_rad: Optional[np.ndarray] = None

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
      model: the model the selection draws ran (``quasistatic``, ``exact``).
      physics: ``(indices, successes, n)`` when the tie was broken in MuJoCo
        (:func:`physics_tiebreak`), else None.
      screened: how many candidates the quasi-static model shortlisted these
        from (``model: limit_surface``, :data:`SHORTLIST`), else None.
      veto: ``(default successes, chosen successes, n, vetoed)`` of the
        MuJoCo check of the choice against the default plan
        (:func:`physics_veto`), else None; vetoed_from: the candidate physics
        vetoed (the default plan then chosen), else None.
    """

    candidates: list
    scores: Scores
    chosen: int
    objective: str
    why: str
    skipped: tuple = ()
    model: str = "quasistatic"
    physics: Optional[tuple] = None
    screened: Optional[int] = None
    veto: Optional[tuple] = None
    vetoed_from: Optional[int] = None

    @property
    def plan(self):
        return self.candidates[self.chosen].plan

    def describe(self) -> str:
        """The selection in one sentence (the certificate's ``selection`` column)."""
        s = self.scores
        if self.vetoed_from is not None:
            i = self.vetoed_from
            k0, kv = int(s.n_success[0]), int(s.n_success[i])
            return (f"default plan kept: the {self.model} model preferred "
                    f"{self.candidates[i].label} ({kv}/{s.n} selection draws against {k0}/{s.n}) "
                    f"but MuJoCo contradicted it" + self._veto_text())
        k0, kc = int(s.n_success[0]), int(s.n_success[self.chosen])
        among = (f"{len(self.candidates)} candidates" if self.screened is None else
                 f"the {len(self.candidates)} of {self.screened} candidates the quasistatic model "
                 "ranked best (the default plan always among them)")
        return (f"synthesized: {self.candidates[self.chosen].label}; chosen among "
                f"{among} by {self.objective} on {s.n} selection draws "
                f"of the {self.model} model "
                f"({kc}/{s.n} succeeded, against {k0}/{s.n} for the default plan; its bound "
                f"{s.ci_low[self.chosen]:.4f} on those draws is optimistic: the verdict is "
                "taken on fresh draws)" + self._physics_text() + self._veto_text())

    def _veto_text(self) -> str:
        if self.veto is None:
            return ""
        k0, kc, n, vetoed = self.veto
        if vetoed:
            return (f" (MuJoCo rollouts on {n} common draws: {kc}/{n} for it against {k0}/{n} "
                    "for the default plan, worse by more than two standard errors)")
        return (f"; confirmed against the default plan by MuJoCo rollouts on {n} common draws "
                f"({kc}/{n} against {k0}/{n})")

    def _physics_text(self) -> str:
        if self.physics is None:
            return ""
        idx, k, n = self.physics
        best = k[list(idx).index(self.chosen)]
        return (f"; the tie between {len(idx)} candidates broken by MuJoCo rollouts on {n} "
                f"common draws ({best}/{n} for the chosen one; "
                f"{', '.join(f'#{i}: {x}/{n}' for i, x in zip(idx, k))})")


def selection_key(key):
    """The selection draws' key of a task whose certification samples are drawn
    with ``key`` (blocks ``fold_in(key, b)``, b = 0, 1, ...): an independent
    stream."""
    return jax.random.fold_in(key, SELECTION_STREAM)


def tiebreak_key(key):
    """The draws of :func:`physics_tiebreak` for a task certified with ``key``:
    a stream apart from the selection's, the veto's and the certification's."""
    return jax.random.fold_in(selection_key(key), 1)


def veto_key(key):
    """The draws of :func:`physics_veto` for a task certified with ``key``: a
    stream apart from the selection's, the tie-break's (:func:`tiebreak_key`)
    and the certification's."""
    return jax.random.fold_in(selection_key(key), 2)


def _settings(base: PushOptions, margins_deg, safety_factors, strategies, supports,
              min_fence_mu) -> list:
    out = [base]
    for m, sf, st, sup in itertools.product(margins_deg, safety_factors, strategies, supports):
        out.append(dataclasses.replace(base, margin_deg=float(m), safety_factor=float(sf),
                                       strategy=st, support=sup, min_fence_mu=None))
        if min_fence_mu is not None and sup not in (None, "any"):
            out.append(dataclasses.replace(out[-1], min_fence_mu=float(min_fence_mu)))
    return list(dict.fromkeys(out))


#: The candidate grid of a push task (the study's ``synthesize:`` and certify's
#: ``margin_search:`` defaults): margins (deg) around the paper's 7, safety factors
#: from the paper's 1.15, both planner strategies.
GRID_MARGINS_DEG = (3.0, 7.0, 12.0, 20.0)
GRID_SAFETY_FACTORS = (1.15, 1.5, 2.0)
GRID_STRATEGIES = STRATEGIES


@float64
def push_candidates(vertices, start, goal, com=None, *, options: Optional[PushOptions] = None,
                    margins_deg: Sequence[float] = GRID_MARGINS_DEG,
                    safety_factors: Sequence[float] = GRID_SAFETY_FACTORS,
                    strategies: Sequence[str] = GRID_STRATEGIES,
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
def score_candidates(plans: Sequence, sampler: Sampler, n: int, key,
                     requirement: Optional[Requirement] = None, *,
                     model="quasistatic", bounds: bool = True) -> Scores:
    """Replay the plans of one task (push plans, or tumble plans) on the same
    ``n`` draws of ``sampler`` (drawn with ``key`` for the longest plan's push
    or tumble count) and score them, with the success rule of
    :func:`robustness.evaluate` (inside the model, final pose within the eps
    of the goal; tumbles: on the goal face, the perturbed hull's faces those of
    the nominal part).

    Args:
      requirement: the :class:`~robustness.Requirement`: its criterion judges
        each sample (None: the first plan's kind's,
        :meth:`~robustness.SuccessCriterion.for_plan`), its confidence is each
        candidate's one-sided lower bound's (default ``Requirement()``).
      model: a :class:`~robustness.Model` or a name; push plans:
        ``quasistatic``, ``limit_surface`` or ``exact`` (tumbles are exact).
      bounds: compute each candidate's first-order bound.

    Returns:
      :class:`Scores`.
    """
    plans = list(plans)
    if not plans:
        raise ValueError("plans: expected at least one candidate plan")
    ops = kind_of(plans[0])   # the candidates' row of the dispatch table (robustness.kinds)
    spec = Model.of(model)
    req = (Requirement() if requirement is None else requirement).for_plan(plans[0])
    criterion, confidence = req.criterion, req.confidence
    success = ops.success_many(plans, sampler, int(n), key, model=spec.name, dtype=spec.dtype,
                               criterion=criterion, chunk=spec.chunk,
                               merge_factor=spec.merge_factor)
    k = success.sum(axis=1)
    low = np.array([stats.one_sided_lower(int(x), int(n), confidence) for x in k])
    K = len(plans)
    bp, bt = np.full(K, np.nan), np.full(K, np.nan)
    if bounds or ops.cost_needs_bound:
        for i, pl in enumerate(plans):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                b = ops.bound(pl, sampler.geometry, sampler.execution)
            bp[i], bt[i] = b.position_m, b.theta_rad
    cost = np.array([ops.candidate_cost(pl, bp[i]) for i, pl in enumerate(plans)], np.float64)
    steps = np.array([p.n_steps for p in plans], np.int64)
    return Scores(success=success, ci_low=low, cost=cost, steps=steps,
                  confidence=float(confidence), bound_position_m=bp, bound_theta_rad=bt)


@dataclasses.dataclass(frozen=True)
class TumbleSetting:
    """The tumble planner's setting of a candidate: its accuracy ``eps`` (m /
    rad), the vertex tolerance it planned for ``tau_v`` (m), and whether its
    word was shortened (False: the paper's own construction)."""

    eps: float
    tau_v: float = 0.0
    shorten: bool = True


@float64
def tumble_candidates(vertices, start, goal, com=None, *, eps: float = 1e-3, tau_v: float = 0.0,
                      tau_g: Optional[float] = None,
                      eps_factors: Sequence[float] = (1.0, 0.5, 0.25), paper: bool = True,
                      slack: int = 2,
                      per_setting: int = 3, limit: int = 32) -> tuple[list, tuple]:
    """Candidate tumble plans for one task: :func:`planning.tumble_alternatives`
    at the configured ``eps`` and ``tau_v`` (its first: the default plan), at
    tighter accuracies ``eps * eps_factors`` (other words, often of the same
    length, that land closer), and the paper's own construction when it is
    short; distinct words, at most ``slack`` tumbles longer than the shortest,
    each replayed exactly and ``solved`` (all planned at the configured
    ``tau_v``: the faces are named as the task names them).

    Returns:
      ``(candidates, skipped)`` as :func:`push_candidates`.

    Raises:
      PlanningError: the configured planner has no solved plan (its reason).
    """
    from planning import plan_tumble, tumble_alternatives

    base = TumbleSetting(float(eps), float(tau_v), True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        first = plan_tumble(vertices, goal, start=start, com=com, eps=eps, tau_v=tau_v,
                            tau_g=tau_g)
    if first.verdict != "solved":
        raise PlanningError(f"{first.verdict}: {first.reason}")
    settings = [base] + [TumbleSetting(float(eps) * f, float(tau_v), True) for f in eps_factors]
    settings = list(dict.fromkeys(settings))
    per, skipped = [], []
    for st in settings:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                per.append((st, tumble_alternatives(vertices, goal, start=start, com=com,
                                                    eps=st.eps, tau_v=st.tau_v, tau_g=tau_g,
                                                    limit=per_setting, slack=slack)))
        except ValueError as exc:
            skipped.append(f"eps {st.eps:g}, tau_v {st.tau_v:g}: {str(exc).splitlines()[0][:160]}")
    if paper:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            pp = plan_tumble(vertices, goal, start=start, com=com, eps=eps, tau_v=tau_v,
                             tau_g=tau_g, shorten=False)
        if pp.verdict == "solved" and pp.n_tumbles <= first.n_tumbles + slack:
            per.append((TumbleSetting(float(eps), float(tau_v), False), [pp]))
        else:
            skipped.append(f"the paper's construction: {pp.n_tumbles} tumbles"
                           + ("" if pp.verdict == "solved" else f", {pp.verdict}"))
    shortest = first.n_tumbles
    out, seen = [Candidate(first, base, 0)], {first.faces}
    for rank in range(per_setting):
        for st, plans in per:
            if rank < len(plans) and len(out) < limit:
                pl = plans[rank]
                if pl.faces in seen or pl.n_tumbles > shortest + slack:
                    continue
                seen.add(pl.faces)
                out.append(Candidate(pl, st, rank))
    return out, tuple(skipped)


def select(scores: Scores, objective: str = "max_lower_bound",
           requirement: Optional[Requirement] = None) -> tuple[int, str]:
    """The chosen candidate's index and one line saying why.

    ``max_lower_bound``: the highest lower bound; candidates within one
    success of the best count as tied and the lowest cost (push distance;
    tumbles: propagated error), then the fewest steps, then the lowest index
    wins among them.  ``shortest_certifying``: the cheapest (cost, then
    steps) whose bound reaches the :class:`~robustness.Requirement`'s
    probability (the bounds are the scores', at their confidence); without
    one, ``max_lower_bound``.
    """
    if objective not in OBJECTIVES:
        raise ValueError(f"objective: expected one of {OBJECTIVES}, got {objective!r}")
    k = scores.n_success
    order = lambda idx: min(idx, key=lambda i: (scores.cost[i], scores.steps[i], i))  # noqa: E731
    if objective == "shortest_certifying":
        if requirement is None:
            raise ValueError("requirement: shortest_certifying needs the requirement")
        required_probability = requirement.probability
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


def physics_tiebreak(syn: Synthesis, sampler: Sampler, n: int, key,
                     criterion: Optional[SuccessCriterion] = None, *, physics=None,
                     top: int = 4) -> Synthesis:
    """Break the selection's tie in physics: the candidates within one success
    of the chosen one on the selection draws (the kinematic model cannot tell
    them apart; at most ``top`` of them, the lowest cost first, the chosen one
    always among them) are rolled out in MuJoCo (:func:`robustness.evaluate`,
    ``model="mujoco"``, ``physics`` a :class:`~robustness.physics.PhysicsRun`)
    on ``n`` draws of ``key`` (the same part and friction draws for all), judged
    by ``criterion`` (default: the plan kind's), and
    the one with the most successes is chosen (ties: the lower cost).  A check
    on tens of samples, not a certificate: the verdict is still taken on fresh
    draws.  Returns the :class:`Synthesis` with ``chosen`` and ``physics`` set."""
    s = syn.scores
    k = s.n_success
    tied = [i for i in range(len(k)) if k[i] >= k[syn.chosen] - 1]
    tied = sorted(tied, key=lambda i: (i != syn.chosen, s.cost[i], s.steps[i], i))[:max(1, top)]
    if len(tied) < 2:
        return syn
    got = [int(np.sum(_rollouts(syn.candidates[i].plan, sampler, n, key, criterion, physics)))
           for i in tied]
    best = max(range(len(tied)), key=lambda j: (got[j], -s.cost[tied[j]], -s.steps[tied[j]],
                                                 -tied[j]))
    return dataclasses.replace(syn, chosen=tied[best],
                               why=f"{syn.why}; of the {len(tied)} tied, the best in MuJoCo",
                               physics=(tuple(tied), tuple(got), int(n)))


def _rollouts(plan, sampler, n, key, criterion, physics) -> np.ndarray:
    """Per-draw successes (bool, (n,)) of ``plan`` rolled out in MuJoCo on ``n``
    draws of ``key`` (one block of the runner, :func:`robustness.sample_block`,
    ``model="mujoco"``)."""
    from robustness.blocks import sample_block

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        block = sample_block(plan, sampler, int(n), key, criterion,
                             Model("mujoco", physics=physics))
    return np.asarray(block.stats["success"], bool)


def contradicts(default, chosen) -> bool:
    """Whether rollouts contradict a choice: ``default`` and ``chosen`` are the
    successes (0/1) of the default and the chosen plan on the same draws, and
    the chosen plan does worse by more than two standard errors of the paired
    difference (all draws alike and the chosen plan worse: by any margin)."""
    d = np.asarray(chosen, float) - np.asarray(default, float)
    if d.size == 0:
        return False
    m = float(d.mean())
    se = float(d.std(ddof=1)) / np.sqrt(d.size) if d.size > 1 else 0.0
    return m < 0 and m + 2.0 * se < 0


def physics_veto(syn: Synthesis, sampler: Sampler, n: int, key,
                 criterion: Optional[SuccessCriterion] = None, *, physics=None) -> Synthesis:
    """Confirm the choice in physics before it replaces the default plan: the
    chosen candidate and the default plan (index 0) are rolled out in MuJoCo
    (:func:`robustness.evaluate`, ``model="mujoco"``, ``physics`` a
    :class:`~robustness.physics.PhysicsRun`) on the same ``n`` draws of ``key``,
    judged by ``criterion`` (default: the plan kind's); where the chosen plan
    does worse by more than two standard errors of the paired difference
    (:func:`contradicts`), physics contradicts the kinematic model's choice and
    the default plan is kept.  Either way ``veto`` records ``(default
    successes, chosen successes, n, vetoed)`` and :meth:`Synthesis.describe`
    says it.  A check on tens of samples, not a certificate: the verdict is
    still taken on fresh draws of the model.  Nothing to check (the default
    chosen, ``n`` 0): ``syn`` unchanged."""
    if syn.chosen == 0 or int(n) <= 0:
        return syn
    got = [_rollouts(syn.candidates[i].plan, sampler, n, key, criterion, physics)
           for i in (0, syn.chosen)]
    vetoed = contradicts(got[0], got[1])
    veto = (int(got[0].sum()), int(got[1].sum()), int(n), vetoed)
    if not vetoed:
        return dataclasses.replace(syn, veto=veto)
    return dataclasses.replace(syn, chosen=0, veto=veto, vetoed_from=syn.chosen,
                               why=f"{syn.why}; MuJoCo contradicted that choice, so the default "
                                   "plan is kept")


@dataclasses.dataclass(frozen=True)
class Selection:
    """How robust synthesis chooses: its candidates scored on ``n`` draws of
    ``sampler`` with ``key`` (pass :func:`selection_key` of the certification's
    key: the chosen plan is certified on other draws), chosen by ``objective``
    (:data:`OBJECTIVES`, :func:`select`)."""

    sampler: Sampler
    n: int
    key: object
    objective: str = "max_lower_bound"

    def __post_init__(self):
        if not isinstance(self.sampler, Sampler):
            raise ValueError(f"sampler: expected a robustness.Sampler, got {self.sampler!r}")
        if not (isinstance(self.n, (int, np.integer)) and not isinstance(self.n, bool)
                and self.n >= 1):
            raise ValueError(f"n: expected an integer >= 1, got {self.n!r}")
        if self.objective not in OBJECTIVES:
            raise ValueError(f"objective: expected one of {OBJECTIVES}, got {self.objective!r}")


@float64
def synthesize(vertices, start, goal, com=None, *, selection: Selection,
               requirement: Optional[Requirement] = None, model=DEFAULT_MODEL,
               **grid) -> Synthesis:
    """Candidates of a push task (2-d ``vertices``: :func:`push_candidates`,
    ``grid`` its keywords, ``options=`` the planner's :class:`~planning.PushOptions`
    among them) or a tumble task (3-d: :func:`tumble_candidates` and its
    keywords), scored on the draws of ``selection``
    (:func:`score_candidates`), chosen by its objective (:func:`select`).
    ``requirement``: the :class:`~robustness.Requirement` (its criterion judges
    each sample, default the first candidate's kind's; its probability is what
    ``shortest_certifying`` must reach; its confidence, the candidates' lower
    bounds).  Certify the chosen plan on other draws.  ``model`` (a
    :class:`~robustness.Model` or a name): push candidates are scored under the
    quasi-static, exact-limit-surface or exact kinematics (``limit_surface``: of
    more than :data:`SHORTLIST` candidates the quasi-static model shortlists the
    default plan and the best ``SHORTLIST - 1`` on the same draws, and the exact
    limit surface chooses among them; ``mujoco``:
    :func:`~robustness.models.decision_model`, the exact limit surface, chooses,
    physics certifies; default :data:`~robustness.models.DEFAULT_MODEL`)."""
    tumble = np.asarray(vertices).shape[-1] == 3
    if not isinstance(selection, Selection):
        raise ValueError(f"selection: expected a robustness.Selection, got {selection!r}")
    req = Requirement() if requirement is None else requirement
    if not isinstance(req, Requirement):
        raise ValueError(f"requirement: expected a robustness.Requirement, got {req!r}")
    spec = Model.of(model)
    spec = dataclasses.replace(spec, name=decision_model(spec.name, "tumble" if tumble else "push"),
                               physics=None)
    if tumble:
        cands, skipped = tumble_candidates(vertices, start, goal, com, **grid)
    else:
        cands, skipped = push_candidates(vertices, start, goal, com, **grid)
    sampler, n, key = selection.sampler, selection.n, selection.key
    screened = None
    if spec.name == "limit_surface" and len(cands) > SHORTLIST:
        # the fast model shortlists on the same draws; the faithful one chooses
        pre = score_candidates([c.plan for c in cands], sampler, n, key, req,
                               model=dataclasses.replace(spec, name="quasistatic"))
        rank = sorted(range(1, len(cands)),
                      key=lambda j: (-int(pre.n_success[j]), float(pre.cost[j]), j))
        screened, cands = len(cands), [cands[j] for j in [0] + rank[:SHORTLIST - 1]]
    scores = score_candidates([c.plan for c in cands], sampler, n, key, req, model=spec)
    i, why = select(scores, selection.objective, req)
    return Synthesis(cands, scores, i, selection.objective, why, skipped, spec.name,
                     screened=screened)


#: candidates the exact limit surface scores in a synthesis under ``model:
#: limit_surface`` (the default plan and those the quasi-static model ranks best
#: on the same draws): 64 candidates x 1,000 draws take 4 s under the quasi-static
#: model, some 6 min under the exact limit surface on ``support: any`` (165
#: samples/s, 2 cores); the shortlist's 8, 50 s
SHORTLIST = 8


__all__ = ["Candidate", "Scores", "Selection", "Synthesis", "TumbleSetting", "OBJECTIVES", "SHORTLIST",
           "physics_tiebreak", "physics_veto", "contradicts", "tiebreak_key", "veto_key",
           "push_candidates",
           "tumble_candidates", "score_candidates", "select", "selection_key", "synthesize"]
