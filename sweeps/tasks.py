"""From a config's planner settings to a plan, and a plan to its ``plans`` row.

Shared by ``nudge certify`` and the study runner: the part (a
:class:`~sweeps.partfile.PartFile`), a start and a goal, and the config's
:class:`~sweeps.config.Planner` and :class:`~sweeps.config.Eps` give either a
verified plan or the planner's reason for none.
"""
from __future__ import annotations

import json
import math
import warnings
from typing import Optional

from sweeps.errors import UserError
from sweeps.config import Eps, Planner


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


def tumble_eps(planner: Planner, eps: Eps) -> float:
    """The tumble planner's accuracy: ``planner.tumble_eps``, default half the
    tighter success tolerance (so that the plan leaves room for the errors)."""
    if planner.tumble_eps is not None:
        return planner.tumble_eps
    return 0.5 * min(eps.pos_eps_m, eps.theta_eps_rad)


def plan_task(part, start, goal, planner: Planner, eps: Eps, caught: Optional[list] = None):
    """Plan one task.

    Args:
      part: the part file; start, goal: poses ``(x, y, theta)`` (polygon) or
        configurations ``(x, y, theta, face)`` (polyhedron), m and rad.
      planner, eps: the config's settings.
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
    from planning import PlanningError, plan_pose, plan_tumble

    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        try:
            if part.kind == "polygon":
                plan = plan_pose(part.vertices, start, goal, com=part.com,
                                 options=planner.push_options())
            else:
                # planned for the nominal part (tau_v = planner.tumble_tau_v, default 0): its
                # robustness to the config's tolerances is what the Monte Carlo measures
                plan = plan_tumble(part.vertices, goal, start=start, com=part.com,
                                   eps=tumble_eps(planner, eps), tau_v=planner.tumble_tau_v,
                                   tau_g=planner.tau_g)
        except PlanningError as exc:
            return None, " ".join(str(exc).split())
        except (PartError, ValueError) as exc:
            raise PlanInputError(_config_field(exc)) from None
        finally:
            if caught is not None:
                caught.extend(got)
    if part.kind == "polyhedron" and plan.verdict != "solved":
        return None, f"{plan.verdict}: {' '.join(str(plan.reason).split())}"
    return plan, ""


def plan_row(part, name: str, start, goal, plan, reason: str, verdict: Optional[str] = None) -> dict:
    """The ``plans`` table's row of one task (``robustness.tables.PLANS_SCHEMA``)."""
    tumble = part.kind == "polyhedron"
    straight = math.hypot(goal[0] - start[0], goal[1] - start[1])
    row = dict(task=name, kind="tumble" if tumble else "push", part=part.name,
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
    if tumble:
        row.update(verdict=plan.verdict, n_steps=plan.n_tumbles,
                   n_tumbles_paper=int(min(plan.n_tumbles_paper, 2 ** 62)),
                   plan_error=float(plan.error))
    else:
        total = float(plan.total_distance)
        row.update(verdict="solved", plan_class=plan.plan_class, distance_rule=plan.distance_rule,
                   support=plan.support,
                   n_steps=plan.n_pushes,
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
