"""The push planner's options, with every default in one place.

:class:`PushOptions` is what :func:`planning.plan_pose` and
:func:`planning.plan_pose_batch` take as ``options=`` (or as the same-named
keywords), what a study's ``planner:`` section validates into
(:class:`sweeps.config.Planner`), and what ``nudge plan-push``'s flags
default to.  Units: degrees for the margin, metres for the workspace.
"""
from __future__ import annotations

import dataclasses
from typing import Any, Optional


@dataclasses.dataclass(frozen=True)
class PushOptions:
    """Options of the fence-push planner (static values; see
    :func:`planning.plan_pose` for what each does).

    Attributes:
      margin_deg: margin angle taken off each maximum reorient angle, degrees
        (the paper's 7).
      safety_factor: multiplier of the reorient distance rule (the paper's 1.15).
      objective: ``"distance"`` or ``"pushes"``.
      solver: ``"closed_form"`` or ``"cvxpy"`` (reference), for each LP.
      strategy: ``"search"`` or ``"paper"``.
      support: ``None`` / ``"any"`` (Peshkin's distances), a family name
        (``"rigid"``, ``"uniform"``, ``"ring"``) or ``{"c": [lo, hi]}`` (m).
      min_fence_mu: lowest fence friction the plan must stick at (slip-aware).
      workspace: ``(xmin, xmax, ymin, ymax)``, m, world frame.
      max_reorients, extra_steps: the search's effort budget.
    """

    margin_deg: float = 7.0
    safety_factor: float = 1.15
    objective: str = "distance"
    solver: str = "closed_form"
    strategy: str = "search"
    support: Any = None
    min_fence_mu: Optional[float] = None
    workspace: Optional[tuple] = None
    max_reorients: int = 24
    extra_steps: int = 3


#: The defaults (every signature and the config schema read them from here).
DEFAULTS = PushOptions()


def resolve(options: Optional[PushOptions], **keywords) -> PushOptions:
    """The options of a call given either as ``options`` or as keywords
    (whose defaults are :data:`DEFAULTS`); both at once is an error."""
    if options is None:
        return PushOptions(**keywords)
    if not isinstance(options, PushOptions):
        raise ValueError(f"options: expected a planning.PushOptions, got {type(options).__name__}")
    given = sorted(k for k, v in keywords.items() if v != getattr(DEFAULTS, k))
    if given:
        raise ValueError(f"options: give the planner's options as PushOptions or as keywords, not "
                         f"both ({', '.join(given)} given beside options=)")
    return options


__all__ = ["PushOptions", "DEFAULTS", "resolve"]
