"""The dispatch table of plan kinds: what the evaluation does with each kind of plan.

A plan declares its kind (``plan.kind``, the plan interface of
:mod:`planning.kinds`); :data:`KINDS` maps that kind to a :class:`PlanKind`, a
declared row of functions and facts (as ``mujoco.mjx`` dispatches collisions by a
declared table of functions keyed by geometry-type pairs).  Code that differs by
kind reads the plan's ``kind`` and this table; it never rediscovers the kind
from a plan's attributes (``hasattr(plan, "pushes")``).  A new plan kind is a
new plan type with a ``kind`` (:data:`planning.kinds.PLAN_TYPES`) and one row
here; ``tests/test_plan_kinds.py`` fails while either is missing or a row lacks
a function.

Per kind:

* ``draw(plan, sampler, key, n, model)``: the sampler's ``n`` draws for the plan
  (:class:`robustness.Draws`; the shape from ``plan.draw_shape()``);
* ``rows(plan, draws, criterion, *, model, dtype, chunk, task, sampler,
  merge_factor, key)``: the kinematic replay's classified outcomes (``key``:
  the evaluation's, for what a kind draws beyond the sampler)
  (:class:`robustness.outcomes.SampleOutcomes`);
* ``physics_rows(plan, draws, sampler, criterion, merge_factor, run, common, key)``: the
  MuJoCo rollout (a :class:`robustness.physics.PushRollout` or
  :class:`~robustness.physics.TumbleRollout`) and the kind's own outcome columns
  (``key``: the evaluation's);
* ``nominal_final(plan)``: the plan's own prediction of the final pose;
* ``bound(plan, geometry, execution)``: the first-order analytic bound
  (:class:`robustness.Bound`);
* ``default_eps(plan)``: the kind's default tolerances of a
  :class:`~robustness.SuccessCriterion` (None: the class defaults);
* ``sources(sampler, model)``: what the kind's own execution errors perturb
  (names, after the part's and the start's);
* ``success_many(plans, sampler, n, key, *, model, dtype, criterion, chunk,
  merge_factor)``: the success ``(K, n)`` of a task's candidates on the same
  draws (robust synthesis); ``candidate_cost(plan, bound_position_m)``: a
  candidate's cost (``cost_needs_bound``: it is the analytic bound);

and the facts ``part_kind`` (the part file's kind a plan is made for),
``models`` (the models that apply: any other asked for is ``"exact"``),
``references`` (the kinematic models a physics row is compared with) and
``paper_bounds`` (the Marigo-Bicchi bounds, eqs. 5-6, are confronted with the
samples).
"""
from __future__ import annotations

import dataclasses
from typing import Callable

import jax.numpy as jnp
import numpy as np

from kernels import VARYING_SUPPORTS
from planning import PushPlan, SensorlessPlan, TumblePlan
from robustness.bounds import push_plan_bound, tumble_plan_bound
from robustness.outcomes import (push_physics_rows, push_rows, push_success_many,
                                 tumble_physics_rows, tumble_rows, tumble_success_many)

#: the evaluation models (:mod:`robustness.models`)
MODELS = ("quasistatic", "limit_surface", "exact", "mujoco")
#: the kinematic models of a push plan (no physics engine)
PUSH_KINEMATIC = ("quasistatic", "limit_surface", "exact")


@dataclasses.dataclass(frozen=True)
class PlanKind:
    """One row of the dispatch table (module docstring)."""

    kind: str
    plan_type: type
    part_kind: str
    models: tuple
    references: tuple
    paper_bounds: bool
    draw: Callable
    rows: Callable
    physics_rows: Callable
    nominal_final: Callable
    bound: Callable
    default_eps: Callable
    sources: Callable
    success_many: Callable
    candidate_cost: Callable
    cost_needs_bound: bool


#: the functions every row of the table must declare
FUNCTIONS = tuple(f.name for f in dataclasses.fields(PlanKind) if f.type == "Callable")


# --------------------------------------------------------------------------
# push plans
# --------------------------------------------------------------------------
def _push_draw(plan, sampler, key, n, model):
    """The draws of a push plan: the nominal body (the support families' ``c``
    and points) and, for the models that realise the support, its family."""
    poly0 = plan.nominal_part()
    return sampler.sample(key, n, body=poly0.body, dtype=jnp.float64,
                          keep_support=model in ("mujoco", "limit_surface"), **plan.draw_shape())


def _push_final(plan) -> np.ndarray:
    """The exact replay's pose after the last push (the start without pushes)."""
    return np.asarray(plan.pushes[-1].pose_after if plan.pushes else plan.start, np.float64)


def _push_eps(plan) -> None:
    """A push plan takes the criterion's class defaults (1 mm, 1 degree)."""
    return None


def _push_success_many(plans, sampler, n, key, *, model, **kw):
    """Push candidates are scored under a kinematic model (ValueError otherwise)."""
    if model not in PUSH_KINEMATIC:
        raise ValueError(f"model: robust synthesis scores push candidates under the "
                         f"quasistatic, limit_surface or exact kinematics, got {model!r}")
    return push_success_many(plans, sampler, n, key, model=model, **kw)


def _push_cost(plan, bound_position_m) -> float:
    """A push candidate's cost: its total push distance (m)."""
    return plan.total_distance


def _push_sources(sampler, model) -> list:
    f, e = sampler.friction, sampler.execution
    out = []
    if e.fence_angle > 0:
        out.append("fence angle")
    if e.distance_abs > 0 or e.distance_rel > 0:
        out.append("push distance")
    if model in ("quasistatic", "limit_surface", "mujoco"):  # the exact replay does not depend on friction
        if f.mu_f[1] > f.mu_f[0]:
            out.append("fence friction")
        if f.support in VARYING_SUPPORTS or (f.c is not None and f.c[1] > f.c[0]):
            out.append(f"support ({f.support})")   # uniform, ring: one c, nothing drawn
    return out


# --------------------------------------------------------------------------
# tumble plans
# --------------------------------------------------------------------------
def _tumble_draw(plan, sampler, key, n, model):
    """The draws of a tumble plan (the replay and the columns read the plan's
    tumbles of the drawn ones, no copy; MuJoCo: exactly the plan's)."""
    return sampler.sample(key, n, dtype=jnp.float64, exact_steps=model == "mujoco",
                          **plan.draw_shape())


def _tumble_final(plan) -> np.ndarray:
    """The plan's predicted final configuration (up to eps from the goal)."""
    return np.asarray(plan.predicted_final[:3], np.float64)


def _tumble_eps(plan) -> tuple:
    """A tumble plan's own accuracy ``eps`` (m and rad) for both tolerances."""
    return float(plan.eps), float(plan.eps)


def _tumble_cost(plan, bound_position_m) -> float:
    """A tumble candidate's cost: its analytic position bound (m)."""
    return bound_position_m


def _tumble_sources(sampler, model) -> list:
    e = sampler.execution
    return ["slip after tumbles"] if e.tumble_slip_xy > 0 or e.tumble_slip_theta > 0 else []


# --------------------------------------------------------------------------
# sensorless plans (robustness.sensorless): pushes from a start drawn over a region
# --------------------------------------------------------------------------
def _sensorless_rows(plan, draws, criterion, *, model, dtype, chunk, key, **_):
    """Each sample's start drawn uniformly over the plan's start set (in place of
    the start error), then its fence-line pushes replayed."""
    from robustness.sensorless import draw_starts, sensorless_rows

    return sensorless_rows(plan, draws, draw_starts(plan, key, draws.n), criterion, model,
                           dtype, chunk)


def _sensorless_physics(plan, draws, sampler, criterion, merge_factor, run, common, key=None):
    """MuJoCo from the starts the kinematic rows draw (the evaluation's ``key``)."""
    from robustness.sensorless import sensorless_physics_rows

    return sensorless_physics_rows(plan, draws, sampler, criterion, merge_factor, run, common,
                                   key)


def _sensorless_final(plan) -> np.ndarray:
    """The pose the plan's exact replay reaches (the goal, up to symmetry)."""
    return np.asarray(plan.reached_goal, np.float64)


def _no_bound(plan, geometry, execution) -> None:
    """No first-order bound: it is linearised about one start, a sensorless plan has a set."""
    return None


def _sensorless_success_many(plans, *_, **__):
    raise ValueError("plans: robust synthesis needs a known start; a sensorless plan has none")


# --------------------------------------------------------------------------
# the table
# --------------------------------------------------------------------------
#: the dispatch table: every plan kind the evaluation knows, by ``plan.kind``
KINDS = {k.kind: k for k in (
    PlanKind(kind="push", plan_type=PushPlan, part_kind="polygon",
             models=MODELS,
             references=("quasistatic", "exact"), paper_bounds=False,
             draw=_push_draw, rows=push_rows, physics_rows=push_physics_rows,
             nominal_final=_push_final, bound=push_plan_bound, default_eps=_push_eps,
             sources=_push_sources, success_many=_push_success_many, candidate_cost=_push_cost,
             cost_needs_bound=False),
    PlanKind(kind="tumble", plan_type=TumblePlan, part_kind="polyhedron",
             models=("exact", "mujoco"), references=("exact",), paper_bounds=True,
             draw=_tumble_draw, rows=tumble_rows, physics_rows=tumble_physics_rows,
             nominal_final=_tumble_final, bound=tumble_plan_bound, default_eps=_tumble_eps,
             sources=_tumble_sources, success_many=tumble_success_many,
             candidate_cost=_tumble_cost, cost_needs_bound=True),
    PlanKind(kind="sensorless", plan_type=SensorlessPlan, part_kind="polygon",
             models=MODELS, references=("quasistatic", "exact"), paper_bounds=False,
             draw=_push_draw, rows=_sensorless_rows, physics_rows=_sensorless_physics,
             nominal_final=_sensorless_final, bound=_no_bound, default_eps=_push_eps,
             sources=_push_sources, success_many=_sensorless_success_many,
             candidate_cost=_push_cost, cost_needs_bound=False),
)}

#: plan kinds of :data:`planning.kinds.PLAN_TYPES` that have no row (yet), and why
NOT_EVALUATED: dict = {}


def kind_of(plan) -> PlanKind:
    """The table's row of a plan (by ``plan.kind``).

    Raises:
      TypeError: not a plan of a kind in the table (a plan kind the evaluation
        does not know, or not a plan).
    """
    k = getattr(plan, "kind", None)
    if isinstance(k, str) and k in KINDS:
        return KINDS[k]
    if isinstance(k, str) and k in NOT_EVALUATED:
        raise TypeError(f"plan: a {k} plan cannot be evaluated: {NOT_EVALUATED[k]}")
    raise TypeError(f"plan: expected a PushPlan or a TumblePlan, got {type(plan).__name__}")


def plan_kind(plan) -> str:
    """A plan's kind, ``plan.kind``, checked against the table (:func:`kind_of`)."""
    return kind_of(plan).kind


def model_for(model: str, kind: str) -> str:
    """The model a plan of ``kind`` is evaluated under when ``model`` is asked for:
    ``model`` where it applies to the kind, else ``"exact"`` (tumbles have no
    quasi-static model: anything but ``"mujoco"`` is ``"exact"`` for them)."""
    return model if model in KINDS[kind].models else "exact"


def kind_for_part(part_kind: str) -> str:
    """The plan kind made for a part of ``part_kind`` (``"polygon"``: ``"push"``,
    ``"polyhedron"``: ``"tumble"``), from the table's ``part_kind``."""
    for k in KINDS.values():   # the first row of the part's kind: its known-start plans
        if k.part_kind == part_kind:
            return k.kind
    raise ValueError(f"part kind: expected one of {[k.part_kind for k in KINDS.values()]}, "
                     f"got {part_kind!r}")


__all__ = ["MODELS", "PUSH_KINEMATIC", "PlanKind", "KINDS", "NOT_EVALUATED", "FUNCTIONS", "kind_of", "plan_kind", "model_for",
           "kind_for_part"]
