"""Plan types of the pushing planner: plain frozen dataclasses that serialise
to JSON-ready dicts (and from them back).

Frames and units: world frame, metres, radians (CCW positive, wrapped to
(-pi, pi]).  A pose ``(x, y, theta)`` places the part so that
``p_world = R(theta) (p - com) + (x, y)`` for a point ``p`` given in the
caller's part frame; ``(x, y)`` is the world position of the centre of mass.
Edges and vertices are indices into the caller's own vertex list.
"""
from __future__ import annotations

import dataclasses
import warnings
from typing import ClassVar, Optional

import numpy as np

from kernels import PartWarning, make_polygon
from planning.pushing.options import DEFAULTS, PlanSupport, PushOptions

PLAN_CLASSES = ("translation", "cw", "ccw", "singular-cw", "singular-ccw")
PUSH_KINDS = ("translate", "reorient")
DISTANCE_RULES = ("peshkin", "quasi-static")


def _tuple(x, n=None):
    t = tuple(float(v) for v in x)
    if n is not None and len(t) != n:
        raise ValueError(f"expected {n} numbers, got {len(t)}")
    return t


@dataclasses.dataclass(frozen=True)
class Push:
    """One normal linear push of the fence.

    Attributes:
      kind: ``"translate"`` (a stable edge is flush all along) or
        ``"reorient"`` (the part turns about ``contact_vertex`` until ``edge``
        lies flush, then translates).
      direction: unit vector of the fence's motion, world frame.
      distance: fence travel in contact with the part, m (any approach offset
        before contact is extra).
      edge: the stable edge that is flush with the fence at the end, as a
        pair of caller vertex indices in CCW order.
      contact_vertex: reorient pushes: the caller index of the vertex the
        part pivots about; ``None`` for translations.
      min_distance: reorient pushes: the Peshkin distance times the safety
        factor, the least distance that guarantees completion (m); ``None``
        for translations.
      pose_after: the part's pose after the push, ``(x, y, theta)``, as
        replayed by the exact kinematics.
      rotation: reorient pushes: the planned rotation of the part (rad, CCW
        positive: its sign is the push's sense); ``None`` for translations.
    """

    kind: str
    direction: tuple[float, float]
    distance: float
    edge: tuple[int, int]
    contact_vertex: Optional[int]
    min_distance: Optional[float]
    pose_after: tuple[float, float, float]
    rotation: Optional[float] = None

    def to_dict(self) -> dict:
        """JSON-ready dict."""
        return {"kind": self.kind, "direction": list(self.direction), "distance": self.distance,
                "edge": list(self.edge), "contact_vertex": self.contact_vertex,
                "min_distance": self.min_distance, "pose_after": list(self.pose_after),
                "rotation": self.rotation}

    @classmethod
    def from_dict(cls, d: dict) -> "Push":
        """Inverse of :meth:`to_dict`."""
        if d["kind"] not in PUSH_KINDS:
            raise ValueError(f"kind: expected one of {PUSH_KINDS}, got {d['kind']!r}")
        return cls(kind=d["kind"], direction=_tuple(d["direction"], 2), distance=float(d["distance"]),
                   edge=(int(d["edge"][0]), int(d["edge"][1])),
                   contact_vertex=None if d.get("contact_vertex") is None else int(d["contact_vertex"]),
                   min_distance=None if d.get("min_distance") is None else float(d["min_distance"]),
                   pose_after=_tuple(d["pose_after"], 3),
                   rotation=None if d.get("rotation") is None else float(d["rotation"]))


@dataclasses.dataclass(frozen=True)
class PushPlan:
    """A verified pose plan of the pose planner.

    Attributes:
      vertices: the caller's part vertices (m), as given.
      com: centre of mass (m, caller's frame).
      start, goal: poses ``(x, y, theta)``.
      pushes: the pushes in execution order.
      plan_class: one of ``translation``, ``cw``, ``ccw`` (the sense of the
        main reorient run), ``singular-cw``, ``singular-ccw`` (the main run with
        reorient pushes in the opposite sense before or after it: the paper's
        singularity handler and the search's excursions).
      reorient_edge: the stable edge that most reorient pushes land (caller
        indices; the first such edge on a tie), ``None`` for a translation
        plan; every push names its own edge.
      object_class: ``uni-stable``, ``biplus-stable`` or ``nice-stable``.
      objective_value: the LP objective: total push distance (m) for
        ``distance``; for ``pushes`` the number of pushes.
      total_distance: sum of the push distances, m.
      final_error: ``(position error m, |angle error| rad)`` of the exact
        replay's final pose against the goal.
      options: the :class:`~planning.PushOptions` the plan was made with (margin,
        safety factor, objective, strategy, support, slip bound, workspace,
        effort): ``plan_pose(vertices, start, goal, com, plan.options)`` plans
        it again.
      distance_rule: ``peshkin`` (reorient distances for any support) or
        ``quasi-static`` (for supports with a limit-surface ratio in
        ``support_c``; replay it with ``rate_c = min(support_c[1], radius)``).
      support_c: ``(lo, hi)`` limit-surface ratio range (m) the distances are
        valid for, or ``None`` (Peshkin's bound): the range of
        ``options.support`` (given, or every ``c`` its family gives the part).
        A plan is only as valid as that assumption.
      turns: extra full turns of the main reorient run (0 or 1).

    The plan interface (:mod:`planning.kinds`): ``kind`` ``"push"``,
    :attr:`n_steps`, :attr:`verdict`, :meth:`nominal_part`, :meth:`draw_shape`.
    """

    #: the plan's kind: its key in the evaluation's dispatch table (:mod:`planning.kinds`)
    kind: ClassVar[str] = "push"

    vertices: tuple[tuple[float, float], ...]
    com: tuple[float, float]
    start: tuple[float, float, float]
    goal: tuple[float, float, float]
    pushes: tuple[Push, ...]
    plan_class: str
    reorient_edge: Optional[tuple[int, int]]
    object_class: str
    objective_value: float
    total_distance: float
    final_error: tuple[float, float]
    options: PushOptions = DEFAULTS
    distance_rule: str = "peshkin"
    support_c: Optional[tuple[float, float]] = None
    turns: int = 0

    @property
    def n_pushes(self) -> int:
        """Number of pushes."""
        return len(self.pushes)

    @property
    def n_steps(self) -> int:
        """The plan's steps (its pushes): the plan interface."""
        return len(self.pushes)

    @property
    def verdict(self) -> str:
        """``"solved"``: the planner returns only plans its exact replay verified
        (the plan interface; a tumble plan's verdict can be another)."""
        return "solved"

    def nominal_part(self):
        """The nominal part, a :class:`kernels.Polygon` of the plan's vertices and
        centre of mass (nominal hull order; a part warning is not repeated)."""
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", PartWarning)
            return make_polygon(np.asarray(self.vertices), np.asarray(self.com))

    def draw_shape(self) -> dict:
        """What a sampler draws for one sample of this plan: the keywords
        ``n_vertices``, ``dim`` (2), ``n_pushes`` of
        :meth:`robustness.Sampler.sample` and of its columns."""
        return dict(n_vertices=len(self.vertices), dim=2, n_pushes=len(self.pushes))

    @property
    def n_reorients(self) -> int:
        """Number of reorient pushes."""
        return sum(p.kind == "reorient" for p in self.pushes)

    def to_dict(self) -> dict:
        """JSON-ready dict (round-trips through :meth:`from_dict`): the options
        flat beside the plan's own fields, the LP solver only where it is not
        the default closed form."""
        o = self.options
        return {
            "vertices": [list(v) for v in self.vertices], "com": list(self.com),
            "start": list(self.start), "goal": list(self.goal),
            "pushes": [p.to_dict() for p in self.pushes], "plan_class": self.plan_class,
            "reorient_edge": None if self.reorient_edge is None else list(self.reorient_edge),
            "object_class": self.object_class, "objective": o.objective,
            "objective_value": self.objective_value, "total_distance": self.total_distance,
            "margin_deg": o.margin_deg, "safety_factor": o.safety_factor,
            "final_error": list(self.final_error), "strategy": o.strategy,
            "distance_rule": self.distance_rule,
            "support_c": None if self.support_c is None else list(self.support_c),
            "support": o.support.family,
            "min_fence_mu": o.min_fence_mu,
            "workspace": None if o.workspace is None else list(o.workspace),
            "max_reorients": o.max_reorients, "extra_steps": o.extra_steps,
            "turns": self.turns,
        } | ({} if o.solver == DEFAULTS.solver else {"solver": o.solver})

    @classmethod
    def from_dict(cls, d: dict) -> "PushPlan":
        """Inverse of :meth:`to_dict` (the options check themselves: :class:`PushOptions`)."""
        if d["plan_class"] not in PLAN_CLASSES:
            raise ValueError(f"plan_class: expected one of {PLAN_CLASSES}, got {d['plan_class']!r}")
        if d.get("distance_rule", "peshkin") not in DISTANCE_RULES:
            raise ValueError(f"distance_rule: expected one of {DISTANCE_RULES}, got "
                             f"{d['distance_rule']!r}")
        re = d.get("reorient_edge")
        sc, ws = d.get("support_c"), d.get("workspace")
        family = str(d.get("support", "any" if sc is None else "c"))
        options = PushOptions(
            margin_deg=float(d["margin_deg"]), safety_factor=float(d["safety_factor"]),
            objective=d["objective"], solver=d.get("solver", DEFAULTS.solver),
            strategy=d.get("strategy", DEFAULTS.strategy),
            support=PlanSupport("c", _tuple(sc, 2)) if family == "c" else PlanSupport(family),
            min_fence_mu=None if d.get("min_fence_mu") is None else float(d["min_fence_mu"]),
            workspace=None if ws is None else _tuple(ws, 4),
            max_reorients=int(d.get("max_reorients", DEFAULTS.max_reorients)),
            extra_steps=int(d.get("extra_steps", DEFAULTS.extra_steps)))
        return cls(
            vertices=tuple(_tuple(v, 2) for v in d["vertices"]), com=_tuple(d["com"], 2),
            start=_tuple(d["start"], 3), goal=_tuple(d["goal"], 3),
            pushes=tuple(Push.from_dict(p) for p in d["pushes"]), plan_class=d["plan_class"],
            reorient_edge=None if re is None else (int(re[0]), int(re[1])),
            object_class=d["object_class"], objective_value=float(d["objective_value"]),
            total_distance=float(d["total_distance"]), final_error=_tuple(d["final_error"], 2),
            options=options, distance_rule=d.get("distance_rule", "peshkin"),
            support_c=None if sc is None else _tuple(sc, 2), turns=int(d.get("turns", 0)),
        )

    def _support_text(self) -> str:
        family = self.options.support.family
        if family == "any":
            return "any support"
        lo, hi = self.support_c
        what = "c" if family == "c" else f"{family} support, c"
        return f"{what} in [{lo * 1e3:.3g}, {hi * 1e3:.3g}] mm only"

    def summary(self) -> str:
        """A short human-readable table of the plan (pushes numbered from 1, as in
        the plan's figure, where pose i is the pose after push i)."""
        lines = [f"{self.object_class} part, {self.plan_class} plan ({self.options.strategy} strategy, "
                 f"{self.distance_rule} distances valid for {self._support_text()}): "
                 f"{self.n_pushes} pushes "
                 f"({self.n_reorients} reorient), total {self.total_distance:.6g} m; replay error "
                 f"{self.final_error[0]:.2e} m / {self.final_error[1]:.2e} rad"]
        lines.append(f"{'#':>3} {'kind':<9} {'dir_x':>9} {'dir_y':>9} {'dist_m':>10} {'min_m':>10} "
                     f"{'edge':>8} {'pivot':>5} {'x_after':>10} {'y_after':>10} {'th_after':>9}")
        for i, p in enumerate(self.pushes):
            mn = "" if p.min_distance is None else f"{p.min_distance:.4g}"
            pv = "" if p.contact_vertex is None else str(p.contact_vertex)
            lines.append(f"{i + 1:>3} {p.kind:<9} {p.direction[0]:>9.4f} {p.direction[1]:>9.4f} "
                         f"{p.distance:>10.4g} {mn:>10} {str(list(p.edge)):>8} {pv:>5} "
                         f"{p.pose_after[0]:>10.4g} {p.pose_after[1]:>10.4g} "
                         f"{p.pose_after[2]:>9.4f}")
        return "\n".join(lines)
