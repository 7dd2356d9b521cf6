"""From a config's planner settings to a plan, and a plan to its ``plans`` row.

Shared by ``nudge certify`` and the study runner: the part (a
:class:`~sweeps.partfile.PartFile`), a start and a goal, and the config's
:class:`~sweeps.config.Planner` and :class:`~robustness.SuccessCriterion` give either a
verified plan or the planner's reason for none.
"""
from __future__ import annotations

import json
import math
import warnings
from typing import Optional

from robustness import SuccessCriterion
from sweeps.errors import UserError
from sweeps.config import Planner


class PlanInputError(UserError):
    """The planner rejected its input (a bad part or setting): a config error, not 'no plan'."""


#: The planners' argument names (a ValueError's first word) -> the config fields they come from.
CONFIG_FIELDS = {"margin_deg": "planner.margin_deg", "safety_factor": "planner.safety_factor",
                 "objective": "planner.objective", "strategy": "planner.strategy",
                 "support": "planner.support_c", "min_fence_mu": "planner.min_fence_mu",
                 "workspace": "planner.workspace", "max_reorients": "planner.max_reorients",
                 "extra_steps": "planner.extra_steps", "eps": "planner.tumble_eps",
                 "tau_v": "planner.tumble_tau_v", "tau_g": "planner.tau_g",
                 "vertices": "part.vertices", "com": "part.com"}


def _config_field(message: str) -> str:
    """A planner's one-line message with its argument named as the config field."""
    message = " ".join(str(message).split())
    head, sep, rest = message.partition(":")
    return f"{CONFIG_FIELDS[head]}:{rest}" if sep and head in CONFIG_FIELDS else message


def tumble_eps(planner: Planner, criterion: SuccessCriterion) -> float:
    """The tumble planner's accuracy: ``planner.tumble_eps``, default half the
    tighter success tolerance of ``criterion`` (so that the plan leaves room for
    the errors)."""
    if planner.tumble_eps is not None:
        return planner.tumble_eps
    return 0.5 * min(criterion.pos_eps_m, criterion.theta_eps_rad)


def plan_task(part, start, goal, planner: Planner, criterion: SuccessCriterion,
              caught: Optional[list] = None):
    """Plan one task.

    Args:
      part: the part file; start, goal: poses ``(x, y, theta)`` (polygon) or
        configurations ``(x, y, theta, face)`` (polyhedron), m and rad; a
        polygon's start may be a :class:`~sweeps.config.SensorlessStart` (then
        the plan is a :class:`~planning.SensorlessPlan`).
      planner, criterion: the config's settings (``planner``, ``eps``; a tumble
        plan's accuracy defaults from the criterion, :func:`tumble_eps`).
      caught: a list that receives the warnings the planner raised (e.g. a
        non-convex part replaced by its hull), for the caller to show.

    Returns:
      ``(plan, reason)``: a plan and ``""``, or ``None`` and the planner's reason
      (no feasible plan; a tumble plan's verdict first, ``not_solvable: ...`` or
      ``budget_exhausted: ...``).

    Raises:
      PlanInputError: the planner rejected the part or a setting (its message
        names the field).
    """
    from kernels import PartError
    from planning import PlanningError, plan_pose, plan_sensorless, plan_tumble
    from sweeps.config import SensorlessStart

    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        try:
            if isinstance(start, SensorlessStart):   # issue 40: orient, register, pose
                plan = plan_sensorless(part.vertices, goal, start.region, start.heading,
                                       com=part.com, options=planner.push_options())
            elif part.kind == "polygon":
                plan = plan_pose(part.vertices, start, goal, com=part.com,
                                 options=planner.push_options())
            else:
                # planned for the nominal part (tau_v = planner.tumble_tau_v, default 0): its
                # robustness to the config's tolerances is what the Monte Carlo measures
                plan = plan_tumble(part.vertices, goal, start=start, com=part.com,
                                   eps=tumble_eps(planner, criterion),
                                   tau_v=planner.tumble_tau_v,
                                   tau_g=planner.tau_g)
        except PlanningError as exc:
            return None, " ".join(str(exc).split())
        except (PartError, ValueError) as exc:
            raise PlanInputError(_config_field(exc)) from None
        finally:
            if caught is not None:
                caught.extend(got)
    if plan.verdict != "solved":   # a tumble plan may not reach its goal (the plan interface)
        return None, f"{plan.verdict}: {' '.join(str(plan.reason).split())}"
    return plan, ""


def synthesize_for(cfg, part, start, goal, key):
    """Robust synthesis of one task under a config (a study's configuration or a
    certification's: its ``synthesize`` section, planner, sampler, eps,
    requirement) on the selection draws of the task's ``key``
    (:func:`robustness.selection_key`), its tie broken in MuJoCo with
    ``synthesize.physics_samples`` and its choice confirmed in MuJoCo against
    the default plan with ``synthesize.veto_samples`` (push tasks on a support
    MuJoCo builds: :func:`robustness.physics_veto`, physics contradicting it
    keeps the default plan); returns the :class:`~robustness.Synthesis`."""
    from robustness import Selection, decision_model, selection_key, synthesize

    sy = cfg.synthesize
    push = part.kind == "polygon"
    model = decision_model(cfg.model, "push" if push else "tumble")
    grid = (dict(options=cfg.planner.push_options(), **sy.grid(cfg.friction)) if push
            else sy.tumble_grid(tumble_eps(cfg.planner, cfg.eps), cfg.planner.tumble_tau_v,
                                cfg.planner.tau_g))
    syn = synthesize(part.vertices, start, goal, part.com,
                     selection=Selection(cfg.sampler(), sy.n_samples, selection_key(key),
                                         sy.objective),
                     requirement=cfg.requirement(), model=cfg.model_spec(model), **grid)
    if push and sy.physics_samples:   # the kinematic model's tie broken in MuJoCo
        from robustness import physics_tiebreak, tiebreak_key

        syn = physics_tiebreak(syn, cfg.sampler(), sy.physics_samples, tiebreak_key(key), cfg.eps,
                               physics=cfg.physics.run(part, cfg.friction),
                               top=sy.physics_candidates)
    if push and sy.veto_samples and syn.chosen != 0 and realisable(cfg):
        from robustness import physics_veto, veto_key   # the choice confirmed in MuJoCo

        syn = physics_veto(syn, cfg.sampler(), sy.veto_samples, veto_key(key), cfg.eps,
                           physics=cfg.physics.run(part, cfg.friction))
    return syn


def realisable(cfg) -> bool:
    """Whether MuJoCo builds the config's support (not ``points``)."""
    from kernels import REALISABLE_SUPPORTS

    return cfg.friction.support in REALISABLE_SUPPORTS


def design_rows(cfg, part, plan, name: str, key) -> tuple[list, str]:
    """Tolerance design of one task's plan under a config (its ``design``
    section, sampler, eps, requirement; :mod:`robustness.tolerance_design`,
    under :func:`robustness.decision_model`) on the design draws of the task's
    ``key`` (:func:`robustness.tolerance_design.design_key`).

    Returns:
      ``(rows, drawing line)``: the ``design`` rows (without ``run_id``), one
      per axis.
    """
    import jax

    from robustness import (decision_model, design_axes_for, design_key, DesignJudge, drawing_line,
                            joint_design, loosest_tolerances, tolerance_sensitivity)

    kind = plan.kind
    model = decision_model(cfg.model, kind)
    d = cfg.design
    axes = tuple(a for a in (d.axes or design_axes_for(plan)) if a in design_axes_for(plan))
    p, conf = cfg.required.probability, cfg.required.confidence
    dkey = design_key(key)
    sampler = cfg.sampler()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        judge = DesignJudge(plan, d.n_samples, dkey, cfg.requirement(), cfg.model_spec(model))
        designs = [loosest_tolerances(judge, sampler, a, rel_tol=d.rel_tol) for a in axes]
        sens = {s.axis: s for s in tolerance_sensitivity(judge, sampler, axes)}
        joint = joint_design(judge, sampler, designs, jax.random.fold_in(dkey, 1))
    base = joint.failure_rate_perfect
    line = drawing_line(designs, joint, p, conf, model)
    if joint.none_certifies:
        from sweeps.remedies import beyond_tolerances

        syn = getattr(cfg, "synthesize", None)
        line += "; " + beyond_tolerances(kind, cfg.friction.support,
                                         syn is not None and bool(syn.enabled),
                                         more_draws=base < 1.0 - p)
    scale = {dz.axis: dz.scale if math.isfinite(dz.scale) else math.inf for dz in designs}
    # most failures removed first; then the axis closest to its limit (smallest headroom)
    order = sorted(axes, key=lambda a: (-sens[a].failures_removed, scale[a]))
    rows = []
    for dz in designs:
        s = sens[dz.axis]
        rows.append(dict(task=name, axis=dz.axis, fields=", ".join(dz.fields),
                         configured=list(dz.configured), loosest=list(dz.loosest), scale=dz.scale,
                         certified_at_configured=dz.certified_at_configured,
                         ci_low_at_loosest=dz.ci_low, limit=dz.limit, failure_rate=s.failure_rate,
                         failure_rate_without=s.failure_rate_without,
                         failure_rate_alone=s.failure_rate_alone,
                         failures_removed=s.failures_removed, failure_rate_all_perfect=base,
                         rank=order.index(dz.axis) + 1, joint=list(joint.values[dz.axis]),
                         joint_t=joint.t, joint_basis=joint.basis,
                         joint_ci_low_design=joint.ci_low_design, joint_n_fresh=joint.n_fresh,
                         joint_k_fresh=joint.k_fresh, joint_ci_low_fresh=joint.ci_low_fresh,
                         joint_certified=joint.certified, drawing=line, model=model,
                         n_samples=judge.n, evaluations=dz.evaluations, confidence=conf,
                         required_probability=p))
    return rows, line


def plan_row(part, name: str, start, goal, plan, reason: str, verdict: Optional[str] = None) -> dict:
    """The ``plans`` table's row of one task (``robustness.tables.PLANS_SCHEMA``;
    a sensorless task's start columns hold its reference start,
    :func:`sweeps.config.reference_start`, its ``plan_class`` is ``sensorless``)."""
    from sweeps.config import reference_start

    start = reference_start(start)
    tumble = part.kind == "polyhedron"
    straight = math.hypot(goal[0] - start[0], goal[1] - start[1])
    row = dict(task=name, kind="tumble" if tumble else "push", part=part.name,
               part_source=part.source.name, part_units=part.units,
               start_x_m=start[0], start_y_m=start[1], start_theta_rad=start[2],
               start_face=start[3] if tumble else -1, goal_x_m=goal[0], goal_y_m=goal[1],
               goal_theta_rad=goal[2], goal_face=goal[3] if tumble else -1,
               planned=plan is not None, reason=reason or None, straight_distance_m=straight,
               n_steps=0, total_distance_m=math.nan, length_ratio=math.nan, plan_class=None,
               n_tumbles_paper=-1, plan_error=math.nan, plan_json=None)
    if plan is None:
        head = reason.split(":", 1)[0] if reason else ""
        row["verdict"] = verdict or (head if head in ("not_solvable", "budget_exhausted")
                                     else "no_plan")
        return row
    row["plan_json"] = plan_json(plan)
    if plan.kind == "sensorless":   # fence-line pushes in three phases
        total = float(plan.total_travel)
        row.update(verdict="solved", plan_class="sensorless",
                   distance_rule=plan.pose_plan.distance_rule,
                   support=plan.options.support.family,
                   n_steps=len(plan.pushes), total_distance_m=total,
                   plan_error=float(max(plan.pose_plan.final_error)),
                   length_ratio=total / straight if straight > 0 else math.nan)
    elif tumble:
        row.update(verdict=plan.verdict, n_steps=plan.n_steps,
                   n_tumbles_paper=int(min(plan.n_tumbles_paper, 2 ** 62)),
                   plan_error=float(plan.error))
    else:
        total = float(plan.total_distance)
        row.update(verdict=plan.verdict, plan_class=plan.plan_class, distance_rule=plan.distance_rule,
                   support=plan.options.support.family, n_steps=plan.n_steps,
                   total_distance_m=total, plan_error=float(max(plan.final_error)),
                   length_ratio=total / straight if straight > 0 else math.nan)
    return row


def plan_json(plan) -> str:
    """A plan as the tables store it: ``plan.to_dict()`` as sorted JSON."""
    return json.dumps(plan.to_dict(), default=_json_default, sort_keys=True)


def _json_default(o):
    from fractions import Fraction

    if isinstance(o, Fraction):
        return str(o)
    if hasattr(o, "tolist"):
        return o.tolist()
    return str(o)
