"""The push planner's options: one self-validating value, every default in one
place.

:class:`PushOptions` is what :func:`planning.plan_pose`,
:func:`planning.plan_pose_batch`, :func:`planning.plan_alternatives` and
:func:`planning.plan_sensorless` take as ``options=``, what a study's
``planner:`` section validates into (:meth:`sweeps.config.Planner.push_options`),
what a plan carries (:attr:`planning.PushPlan.options`) and what ``nudge
plan-push``'s flags build.  A bad field is refused when the value is made, with
one line naming the field.  Units: degrees for the margin, metres for the
workspace and the support's ``c`` range.

:class:`PlanSupport` is what the planner's reorient distances assume of the
support: ``any`` (Peshkin's bound), a support family of
:data:`kernels.PLANNED_FAMILIES`, or a range of the limit-surface ratio ``c``.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Optional

import numpy as np

from kernels import PLAN_SUPPORTS, PLANNED_FAMILIES

#: the planner's objectives, LP solvers and search strategies
OBJECTIVES = ("distance", "pushes")
SOLVERS = ("closed_form", "cvxpy")
STRATEGIES = ("search", "paper")


def check_number(value, field: str, lo=None, hi=None, lo_open=False, lo_hint="",
                 hi_hint="") -> float:
    """``value`` as a finite float in ``[lo, hi)`` (``(lo, hi)`` with
    ``lo_open``), else a ValueError naming ``field``, with ``lo_hint`` or
    ``hi_hint`` (why that bound; each starts with "; ") after the bound it
    breaks."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{field}: expected a number, got {value!r}") from None
    if not math.isfinite(v):
        raise ValueError(f"{field}: must be finite, got {v}")
    if lo is not None and (v < lo or (lo_open and v == lo)):
        raise ValueError(f"{field}: must be {'>' if lo_open else '>='} {lo:g}, got {v:g}{lo_hint}")
    if hi is not None and v >= hi:
        raise ValueError(f"{field}: must be < {hi:g}, got {v:g}{hi_hint}")
    return v


def check_margin_deg(value) -> float:
    """The margin angle (degrees), ``0 < margin_deg < 90``, else a ValueError
    that says why the bound it breaks is there."""
    return check_number(
        value, "margin_deg", 0.0, 90.0, lo_open=True,
        lo_hint="; at zero a reorient from the divergent orientation needs an infinite push "
                "(the paper uses 7 degrees)",
        hi_hint="; it is taken off reorient angles below 90 degrees, and 90 or more leaves "
                "none (the paper uses 7 degrees)")


def check_safety_factor(value) -> float:
    """The reorient distance rule's multiplier, ``>= 1``, else a ValueError
    that says why."""
    return check_number(value, "safety_factor", 1.0,
                        lo_hint="; below 1 the distance rule's guarantee is lost (paper: 1.15)")


def check_min_fence_mu(value) -> float:
    """The lowest fence friction coefficient a slip-aware plan must stick at, ``>= 0``."""
    return check_number(value, "min_fence_mu", 0.0,
                        lo_hint="; it is the lowest fence friction coefficient the plan must "
                                "stick at")


def _count(value, field: str, lo: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < lo:
        raise ValueError(f"{field}: expected an integer >= {lo}, got {value!r}")
    return int(value)


@dataclasses.dataclass(frozen=True)
class PlanSupport:
    """What the reorient distances assume of the support (a small value).

    Attributes:
      family: ``"any"`` (Peshkin's distances, valid for every support), a family
        of :data:`kernels.PLANNED_FAMILIES` (``"rigid"``, ``"uniform"``,
        ``"ring"``: distances valid for every ``c`` that family gives the part,
        :func:`kernels.family_c_range`) or ``"c"`` (the range below).
      c: ``(lo, hi)``, m: the range of the limit-surface ratio
        ``c = m_max / f_max`` (:func:`kernels.quasistatic.limit_surface_ratio`)
        when ``family`` is ``"c"``, else None.
    """

    family: str = "any"
    c: Optional[tuple[float, float]] = None

    def __post_init__(self):
        if self.family == "c":
            try:
                lo, hi = (float(x) for x in self.c)
            except (TypeError, ValueError):
                raise ValueError(f"support: expected {{'c': [lo, hi]}} (limit-surface ratio range, "
                                 f"m), got {self.c!r}") from None
            if not (math.isfinite(lo) and math.isfinite(hi)) or not 0.0 < lo <= hi:
                raise ValueError(f"support: c range must satisfy 0 < lo <= hi (m), got [{lo}, {hi}]")
            object.__setattr__(self, "c", (lo, hi))
        elif self.family not in PLAN_SUPPORTS:
            raise ValueError(f"support: expected one of {', '.join(PLAN_SUPPORTS)} or "
                             f"{{'c': [lo, hi]}} (m), got {self.family!r}")
        elif self.c is not None:
            raise ValueError(f"support: a family ({self.family}) or a c range, not both")

    @classmethod
    def of(cls, value) -> "PlanSupport":
        """The support of ``None`` / ``"any"``, a family name, ``{"c": [lo, hi]}``
        or ``(lo, hi)`` (m), or a PlanSupport (returned as is)."""
        if isinstance(value, PlanSupport):
            return value
        if value is None:
            return cls()
        if isinstance(value, str):
            if value == "c":
                raise ValueError("support: 'c' needs its range: give {'c': [lo, hi]} (m)")
            return cls(value)
        if isinstance(value, dict) and set(value) - {"c"}:
            raise ValueError(f"support: unknown keys {sorted(set(value) - {'c'})}; expected "
                             "{'c': [lo, hi]} (limit-surface ratio range, m)")
        rng = value.get("c") if isinstance(value, dict) else value
        try:
            lo, hi = (float(x) for x in rng)
        except (TypeError, ValueError):
            raise ValueError(f"support: expected {{'c': [lo, hi]}} (limit-surface ratio range, m), "
                             f"got {value!r}") from None
        return cls("c", (lo, hi))

    @property
    def planned(self) -> bool:
        """Whether the distances follow a model (a family or a ``c`` range), not Peshkin's bound."""
        return self.family != "any"

    def config(self):
        """The form configs and JSON hold: ``"any"``, a family name or ``{"c": [lo, hi]}``."""
        return {"c": list(self.c)} if self.family == "c" else self.family

    def __str__(self) -> str:
        return f"c [{self.c[0]:g}, {self.c[1]:g}] m" if self.family == "c" else self.family


@dataclasses.dataclass(frozen=True)
class PushOptions:
    """Options of the fence-push planner (a static, hashable value that checks
    itself; see :func:`planning.plan_pose` for what each does).

    Attributes:
      margin_deg: margin angle taken off each maximum reorient angle, degrees,
        ``0 < margin_deg < 90`` (the paper's 7).
      safety_factor: multiplier of the reorient distance rule, ``>= 1`` (the
        paper's 1.15).
      objective: ``"distance"`` or ``"pushes"``.
      solver: ``"closed_form"`` or ``"cvxpy"`` (reference), for each LP.
      strategy: ``"search"`` or ``"paper"``.
      support: a :class:`PlanSupport`; given as ``None`` / ``"any"``, a family
        name or ``{"c": [lo, hi]}`` (m) it is made one.
      min_fence_mu: lowest fence friction the plan must stick at (slip-aware;
        needs a support other than ``any``), ``>= 0``, or None.
      workspace: ``(xmin, xmax, ymin, ymax)``, m, world frame, or None.
      max_reorients (``>= 1``), extra_steps (``>= 0``): the search's effort budget.

    Each field's metadata says what it is for a user (``doc``; ``choices``, and
    ``symbol``: the name of its value or of each of its numbers): ``nudge
    plan-push`` makes its flags from them.
    """

    margin_deg: float = dataclasses.field(default=7.0, metadata=dict(
        symbol="DEG", doc="margin angle taken off each maximum reorient angle, degrees"))
    safety_factor: float = dataclasses.field(default=1.15, metadata=dict(
        symbol="F", doc="multiplier of the reorient push distance rule, >= 1"))
    objective: str = dataclasses.field(default="distance", metadata=dict(
        choices=OBJECTIVES, doc="minimise the total push distance or the number of pushes"))
    solver: str = dataclasses.field(default="closed_form", metadata=dict(
        choices=SOLVERS, doc="each LP's solver (cvxpy is the reference)"))
    strategy: str = dataclasses.field(default="search", metadata=dict(
        choices=STRATEGIES, doc="reorientation sequences: 'search' (step counts, edges, both "
                                "senses, an extra turn) or 'paper' (Akella & Mason's angle-eating)"))
    support: PlanSupport = dataclasses.field(default=PlanSupport(), metadata=dict(
        choices=PLAN_SUPPORTS, symbol=("LO", "HI"),
        doc="the support the reorient distances must be valid for: any (Peshkin's bound), a "
            "family (rigid: the part rests on its corners; uniform: a compliant pad; ring: its "
            "rim) or a range of the limit-surface ratio c = m_max / f_max, m (0 < LO <= HI: the "
            "shortest distance that completes each reorient push for every c in the range, "
            "quasi-static model)"))
    min_fence_mu: Optional[float] = dataclasses.field(default=None, metadata=dict(
        symbol="MU", doc="lower bound of the fence friction coefficient (>= 0; needs a support "
                         "other than any): only reorient pushes whose fence contact sticks "
                         "throughout are used"))
    workspace: Optional[tuple[float, float, float, float]] = dataclasses.field(
        default=None, metadata=dict(
            symbol=("XMIN", "XMAX", "YMIN", "YMAX"),
            doc="rectangle, m, world frame, that every pose of the plan and the part swept by "
                "every push stay inside"))
    max_reorients: int = dataclasses.field(default=24, metadata=dict(
        symbol="N", doc="the search's effort budget: no plan has more than N reorient pushes"))
    extra_steps: int = dataclasses.field(default=3, metadata=dict(
        symbol="N", doc="each reorientation run tries the fewest steps up to N more (uni-stable "
                        "parts also 2, 3 and 4 times N more)"))

    def __post_init__(self):
        put = lambda name, value: object.__setattr__(self, name, value)  # noqa: E731
        put("margin_deg", check_margin_deg(self.margin_deg))
        put("safety_factor", check_safety_factor(self.safety_factor))
        for name, choices in (("objective", OBJECTIVES), ("solver", SOLVERS),
                              ("strategy", STRATEGIES)):
            if getattr(self, name) not in choices:
                raise ValueError(f"{name}: expected one of {choices}, got {getattr(self, name)!r}")
        put("support", PlanSupport.of(self.support))
        if self.min_fence_mu is not None:
            put("min_fence_mu", check_min_fence_mu(self.min_fence_mu))
            if not self.support.planned:
                raise ValueError(
                    "min_fence_mu: slip-aware plans need the support's limit-surface ratio range: "
                    f"give support={{'c': [lo, hi]}} (m) or a family ({', '.join(PLANNED_FAMILIES)}) "
                    "too (whether the fence contact sticks depends on it)")
        put("workspace", check_workspace(self.workspace))
        put("max_reorients", _count(self.max_reorients, "max_reorients", 1))
        put("extra_steps", _count(self.extra_steps, "extra_steps", 0))


def check_workspace(workspace) -> Optional[tuple[float, float, float, float]]:
    """Validate ``workspace = (xmin, xmax, ymin, ymax)`` (m); returns floats or None."""
    if workspace is None:
        return None
    try:
        vals = tuple(float(x) for x in workspace)
    except (TypeError, ValueError):
        raise ValueError(f"workspace: expected (xmin, xmax, ymin, ymax) in metres, got {workspace!r}") from None
    if len(vals) != 4 or not all(math.isfinite(v) for v in vals):
        raise ValueError(f"workspace: expected four finite numbers (xmin, xmax, ymin, ymax) in metres, "
                         f"got {workspace!r}")
    if not (vals[0] < vals[1] and vals[2] < vals[3]):
        raise ValueError(f"workspace: expected [xmin, xmax, ymin, ymax] (m) with xmin < xmax and "
                         f"ymin < ymax, got {list(vals)}")
    return vals


#: The defaults (every signature and the config schema read them from here).
DEFAULTS = PushOptions()


def options_of(options) -> PushOptions:
    """``options`` (None: :data:`DEFAULTS`), checked to be a PushOptions."""
    if options is None:
        return DEFAULTS
    if not isinstance(options, PushOptions):
        raise ValueError(f"options: expected a planning.PushOptions, got {type(options).__name__}")
    return options


__all__ = ["PushOptions", "PlanSupport", "DEFAULTS", "OBJECTIVES", "SOLVERS", "STRATEGIES",
           "check_margin_deg", "check_min_fence_mu", "check_number", "check_safety_factor", "check_workspace",
           "options_of"]
