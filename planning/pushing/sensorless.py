"""Sensorless posing: from any heading (or a heading interval) and any position
in a region to a goal pose, as one list of fence pushes in three phases:

* ``orient``: the funnel (:mod:`planning.pushing.funnel`), the shortest
  sequence of push directions that leaves one heading up to the push
  function's symmetry; its last push also sets the coordinate along it;
* ``register``: one push perpendicular to the last (:mod:`planning.pushing.registration`),
  which sets the other coordinate: the pose is then known (the coordinate
  along that push's fence only if the part does not slide along it);
* ``pose``: the known-start plan of :func:`planning.plan_pose` from the
  registered pose to the goal (or to a goal heading one symmetry period
  away, when the part looks the same there).

Every push is ``(direction, fence line)``: the fence comes from behind every
possible position and stops at its line (:mod:`planning.pushing.registration`),
so one push list serves every start.  :func:`replay_sensorless` replays it with
the exact kinematics (:func:`kernels.push.replay_push`) from many starts, and
:func:`plan_sensorless` returns a plan only after that replay from a grid of
headings and positions reached the goal from every one.

Units: metres, radians (CCW positive), world frame; poses ``(x, y, theta)``
of the centre of mass, as :mod:`planning.pushing.plan`.
"""
from __future__ import annotations

import dataclasses
import math
from typing import ClassVar, Optional

import jax
import jax.numpy as jnp
import numpy as np

from kernels import float64, replay_push, rot2, wrap_angle_np
from planning.pushing import registration as rg
from planning.pushing.funnel import EXCLUDED, Funnel, PushFunction, orient, push_function
from planning.pushing.options import PushOptions
from planning.pushing.part import ANG_TOL, PlanningError, PushPart, check_pose, prepare_part
from planning.pushing.plan import PushPlan
from planning.pushing.planner import plan_pose, replay_rate

PHASES = ("orient", "register", "pose")


@dataclasses.dataclass(frozen=True)
class FencePush:
    """One push of a sensorless plan.

    Attributes:
      phase: ``orient``, ``register`` or ``pose``.
      direction: unit vector of the fence's motion (world).
      line: the fence's final line ``{q : direction . q = line}`` (m, world).
      travel: least fence travel after contact (m), over every start covered.
      stroke: the fence's run from behind every possible position to its line (m).
      edges: the stable edges the push may end flush on, as caller vertex-index
        pairs (CCW); more than one only where the part's symmetry hides which.
    """

    phase: str
    direction: tuple[float, float]
    line: float
    travel: float
    stroke: float
    edges: tuple[tuple[int, int], ...]

    def to_dict(self) -> dict:
        return {"phase": self.phase, "direction": list(self.direction), "line": self.line,
                "travel": self.travel, "stroke": self.stroke,
                "edges": [list(e) for e in self.edges]}


@dataclasses.dataclass(frozen=True)
class SensorlessPlan:
    """A verified sensorless plan (module docstring).

    Attributes:
      pushes: every push, in order (``phase`` on each).
      region: ``(xmin, xmax, ymin, ymax)`` (m) of the start positions covered.
      start_heading: ``(lo, hi)`` (rad) of the start headings covered, None: any.
      goal: the goal pose; ``reached_goal``: the pose the plan ends at (the goal,
        or the goal turned by a multiple of the period when the part looks the same there).
      registered: the pose after the register push.
      period, symmetry: of the push function (rad, order).
      part_symmetric: headings one period apart give the same footprint.
      excluded: world headings (rad) of the first push's basin boundaries: starts within
        :data:`EXCLUDED` rad of them are not covered (unstable equilibria).
      uncertain_under_slip: what the plan leaves uncertain if the part slides along a fence.
      pose_plan: the known-start :class:`PushPlan` of the pose phase.
      funnel: the :class:`Funnel`.
      checked: ``(headings, positions, reached)`` of the grid replay that verified it.

    The plan interface (:mod:`planning.kinds`): ``kind`` ``"sensorless"`` (its own
    kind, not ``"push"``: it has no single start pose; the Monte-Carlo evaluation
    has no entry for it yet, :data:`robustness.kinds.NOT_EVALUATED`),
    :attr:`n_steps`, :attr:`verdict`, :meth:`nominal_part`, :meth:`draw_shape`.
    """

    #: the plan's kind: its key in the evaluation's dispatch table (:mod:`planning.kinds`)
    kind: ClassVar[str] = "sensorless"

    pushes: tuple[FencePush, ...]
    region: tuple[float, float, float, float]
    start_heading: Optional[tuple[float, float]]
    goal: tuple[float, float, float]
    reached_goal: tuple[float, float, float]
    registered: tuple[float, float, float]
    period: float
    symmetry: int
    part_symmetric: bool
    excluded: tuple[float, ...]
    uncertain_under_slip: str
    pose_plan: PushPlan
    funnel: Funnel
    checked: tuple[int, int, int] = (0, 0, 0)

    @property
    def vertices(self):
        """The part's vertices as the caller gave them (m, part frame)."""
        return self.pose_plan.vertices

    @property
    def com(self):
        """The part's centre of mass (m, part frame)."""
        return self.pose_plan.com

    @property
    def start(self) -> tuple[float, float, float]:
        """The reference start ``(x, y, theta)`` (m, m, rad; world): the region's
        centre and the heading interval's middle (0 for any heading).  Not a
        start the plan needs: rows and Monte-Carlo start offsets name it."""
        r, h = self.region, self.start_heading
        return (0.5 * (r[0] + r[1]), 0.5 * (r[2] + r[3]),
                0.0 if h is None else 0.5 * (h[0] + h[1]))

    @property
    def n_pushes(self) -> int:
        return len(self.pushes)

    @property
    def total_distance(self) -> float:
        """The fences' least travel after contact, summed (m): :attr:`total_travel`."""
        return self.total_travel

    @property
    def options(self):
        """The pose phase's :class:`~planning.PushOptions` (the orient and
        register pushes use Peshkin's distances and its safety factor)."""
        return self.pose_plan.options

    @property
    def n_steps(self) -> int:
        """The plan's steps (every push of the three phases): the plan interface."""
        return len(self.pushes)

    @property
    def verdict(self) -> str:
        """``"solved"``: returned only after the grid replay reached the goal from
        every start (the plan interface)."""
        return "solved"

    def nominal_part(self):
        """The nominal part (:class:`kernels.Polygon`), that of the pose phase's plan."""
        return self.pose_plan.nominal_part()

    def draw_shape(self) -> dict:
        """What a sampler would draw for one sample: the part's vertices (2-d) and
        one set of push errors per push of the three phases."""
        return dict(n_vertices=len(self.pose_plan.vertices), dim=2, n_pushes=len(self.pushes))

    def count(self, phase: str) -> int:
        return sum(p.phase == phase for p in self.pushes)

    @property
    def total_travel(self) -> float:
        return float(sum(p.travel for p in self.pushes))

    def to_dict(self) -> dict:
        return {"pushes": [p.to_dict() for p in self.pushes], "region": list(self.region),
                "start_heading": None if self.start_heading is None else list(self.start_heading),
                "goal": list(self.goal), "reached_goal": list(self.reached_goal),
                "registered": list(self.registered), "period": self.period,
                "symmetry": self.symmetry, "part_symmetric": self.part_symmetric,
                "excluded": list(self.excluded), "uncertain_under_slip": self.uncertain_under_slip,
                "pose_plan": self.pose_plan.to_dict(), "checked": list(self.checked)}

    def summary(self) -> str:
        """The plan as a table with a ``phase`` column."""
        heads = ("any heading" if self.start_heading is None else
                 f"headings [{math.degrees(self.start_heading[0]):.4g}, "
                 f"{math.degrees(self.start_heading[1]):.4g}] deg")
        r = self.region
        lines = [f"sensorless plan from {heads}, x in [{r[0]:.4g}, {r[1]:.4g}] m, y in "
                 f"[{r[2]:.4g}, {r[3]:.4g}] m: {len(self.pushes)} pushes ({self.count('orient')} "
                 f"orient, {self.count('register')} register, {self.count('pose')} pose)",
                 self.funnel.summary().replace("\n", "\n  ").replace("funnel:", "  funnel:", 1)]
        if self.symmetry > 1:
            lines.append(f"  goal reached up to the symmetry: heading "
                         f"{math.degrees(self.reached_goal[2]):.6g} deg (goal "
                         f"{math.degrees(self.goal[2]):.6g} deg"
                         + (", the same footprint)" if self.part_symmetric else ")"))
        if self.excluded and (self.start_heading is None or any(
                self.start_heading[0] <= h <= self.start_heading[1] for h in self.excluded)):
            lines.append(f"  not covered: starts within {EXCLUDED:g} rad of the unstable headings "
                         + ", ".join(f"{math.degrees(h):.4g}" for h in self.excluded) + " deg")
        lines.append(f"  registered pose ({self.registered[0]:.6g}, {self.registered[1]:.6g}, "
                     f"{math.degrees(self.registered[2]):.6g} deg); under slip: "
                     f"{self.uncertain_under_slip}")
        lines.append(f"  checked: exact replay from {self.checked[0]} headings x {self.checked[1]} "
                     f"positions, {self.checked[2]} reached the goal")
        lines.append(f"{'#':>3} {'phase':<9} {'dir_x':>9} {'dir_y':>9} {'line_m':>10} "
                     f"{'travel_m':>10} {'stroke_m':>10}  edges")
        for i, p in enumerate(self.pushes):
            lines.append(f"{i + 1:>3} {p.phase:<9} {p.direction[0]:>9.4f} {p.direction[1]:>9.4f} "
                         f"{p.line:>10.4g} {p.travel:>10.4g} {p.stroke:>10.4g}  "
                         + " or ".join(str(list(e)) for e in p.edges))
        return "\n".join(lines)


# --------------------------------------------------------------------------
# Exact replay of fence-line pushes
# --------------------------------------------------------------------------
def _one(geom, pose, dirs, lines, valid, rate_c):
    def step(p, x):
        d, c, v = x
        world = p[:2] + geom.body @ rot2(p[2]).T
        s = c - jnp.min(world @ d)
        out = replay_push(geom, p, d, jnp.where(v, jnp.maximum(s, 0.0), 0.0), rate_c)
        return jnp.where(v, out.pose, p), (jnp.where(v, s, jnp.inf), out.complete | ~v)
    final, (s, ok) = jax.lax.scan(step, pose, (dirs, lines, valid))
    return final, jnp.min(s), jnp.all(ok)


_replay_many = jax.jit(jax.vmap(_one, in_axes=(None, 0, None, None, None, None)))


@float64
def replay_sensorless(part: PushPart, pushes, starts):
    """Replay fence-line pushes from each start pose with the exact kinematics.

    Args:
      part: the prepared part.
      pushes: :class:`FencePush` values (or ``(direction, line)`` pairs).
      starts: (S, 3) start poses (m, m, rad).

    Returns:
      ``(final, least_travel, complete)``: (S, 3) final poses, (S,) the least
      fence travel after contact over the pushes (m; negative: a fence missed
      the part), (S,) every push ended with a stable edge flush.
    """
    p = len(pushes)
    pad = max(8, -(-p // 8) * 8)     # padded to a multiple of 8: fewer recompiles
    dirs = np.zeros((pad, 2))
    dirs[:, 0] = 1.0
    lines = np.zeros(pad)
    valid = np.arange(pad) < p
    for i, q in enumerate(pushes):
        dirs[i] = q.direction if isinstance(q, FencePush) else q[0]
        lines[i] = q.line if isinstance(q, FencePush) else q[1]
    f, s, ok = _replay_many(part.geom, jnp.asarray(np.asarray(starts, float)), jnp.asarray(dirs),
                            jnp.asarray(lines), jnp.asarray(valid), replay_rate(part))
    return np.asarray(f), np.asarray(s), np.asarray(ok)


def goal_errors(plan: SensorlessPlan, part: PushPart, final):
    """``(position error m, heading error rad)`` of final poses against the plan's
    reached goal (headings modulo the period when the part looks the same)."""
    final = np.asarray(final)
    g = np.asarray(plan.reached_goal)
    pos = np.hypot(final[:, 0] - g[0], final[:, 1] - g[1])
    per = plan.period if plan.part_symmetric else 2 * math.pi
    d = np.mod(final[:, 2] - g[2], per)
    return pos, np.minimum(d, per - d)


def start_grid(region, start_heading=None, n_headings: int = 360, n_side: int = 3):
    """Start poses: ``n_headings`` headings (equally spaced over the circle, or
    over the interval with its ends) times an ``n_side x n_side`` grid of the
    region (corners included)."""
    if start_heading is None:
        th = np.arange(n_headings) * (2 * math.pi / n_headings)
    else:
        th = np.linspace(start_heading[0], start_heading[1], n_headings)
    xs = np.linspace(region[0], region[1], n_side)
    ys = np.linspace(region[2], region[3], n_side)
    X, Y, T = np.meshgrid(xs, ys, th, indexing="ij")
    return np.stack([X.ravel(), Y.ravel(), T.ravel()], axis=1)


def covered(plan: SensorlessPlan, starts) -> np.ndarray:
    """(S,) bool: the start's heading is not within :data:`EXCLUDED` of an excluded heading."""
    th = np.asarray(starts)[:, 2]
    if not plan.excluded:
        return np.ones(len(th), bool)
    d = np.abs(wrap_angle_np(th[:, None] - np.asarray(plan.excluded)[None, :]))
    return np.all(d > EXCLUDED, axis=1)


def check(plan: SensorlessPlan, part: PushPart, starts):
    """Replay ``plan`` from ``starts``; ``(reached, covered)`` (S,) bools: the
    start reached the goal within the planner's tolerances (every fence touched
    the part, every push ended flush, position within ``pos_tol`` of the
    strokes, heading within ``ANG_TOL``), and the start is covered."""
    final, least, ok = replay_sensorless(part, plan.pushes, starts)
    pos, ang = goal_errors(plan, part, final)
    tol = part.pos_tol(sum(p.stroke + abs(p.line) for p in plan.pushes))
    reached = ok & (least >= 0.0) & (pos <= tol) & (ang <= ANG_TOL)
    return reached, covered(plan, starts)


# --------------------------------------------------------------------------
# The planner
# --------------------------------------------------------------------------
def _unit(psi):
    return (math.cos(psi), math.sin(psi))


def _representative(pf: PushFunction, funnel: Funnel, region, start_heading):
    """A start of the covered set far from every boundary of the first push."""
    psi = funnel.directions[0]
    if start_heading is None:
        th = np.linspace(0, 2 * math.pi, 721)[:-1]
    else:
        th = np.linspace(start_heading[0], start_heading[1], 721)
    rel = th - psi + 0.5 * math.pi
    best = float(th[int(np.argmax(pf.margin(rel)))])
    return np.array([0.5 * (region[0] + region[1]), 0.5 * (region[2] + region[3]), best])


@float64
def plan_sensorless(vertices, goal, region, start_heading=None, com=None,
                    options: Optional[PushOptions] = None, *, max_stroke: Optional[float] = None,
                    n_headings: int = 360, n_side: int = 3) -> SensorlessPlan:
    """Plan fence pushes that take the part from any heading (or any heading in
    ``start_heading``) at any position in ``region`` to ``goal``.

    Args:
      vertices: (m, 2) part vertices (m, part frame); ``com`` its centre of mass.
      goal: ``(x, y, theta)`` (m, m, rad), world.
      region: ``(xmin, xmax, ymin, ymax)`` (m, world) of the start positions.
      start_heading: ``(lo, hi)`` (rad) or None (any heading).
      options: the pose phase's :class:`~planning.PushOptions` (margin,
        safety factor, workspace, ...); the orient and register pushes use
        Peshkin's distances (any support) and the safety factor.
      max_stroke: the longest fence run (m) a push may have (default: none
        beyond the float64 limit of :attr:`PushPart.longest_plan`).
      n_headings, n_side: the verifying grid (:func:`start_grid`).

    Raises:
      ValueError: bad input, naming the field.
      PlanningError: the region is too large for the strokes or the
        workspace, the part's symmetry hides a difference in position, the
        pose phase has no plan, or the grid replay misses the goal.
    """
    o = options or PushOptions()
    goal = check_pose(goal, "goal")
    region = rg.check_region(region)
    if start_heading is not None:
        start_heading = rg.check_heading_interval(start_heading)
    if max_stroke is not None and not (math.isfinite(max_stroke) and max_stroke > 0):
        raise ValueError(f"max_stroke: must be a positive number of metres, got {max_stroke}")
    part = prepare_part(vertices, com, o.margin_deg, o.safety_factor)
    pf = push_function(part)
    funnel = orient(pf, start_heading, enough=math.radians(o.margin_deg))
    if len(funnel.final_edges) > 1 and not pf.part_symmetric:
        raise PlanningError(
            f"orient: the push function has period {math.degrees(pf.period):.6g} deg but the part "
            "does not look the same turned by it: pushes leave it at one of "
            f"{len(funnel.final_edges)} headings that place it differently; sensorless posing "
            "cannot tell them apart")
    # fence lines, phase by phase
    pushes = []
    spread = rg.Spread.of_region(region)
    for psi, margin, edges in zip(funnel.directions, funnel.margins, funnel.states):
        pushes.append(_fence(part, spread, psi, margin, edges, "orient"))
        spread = rg.after_push(part, psi, pushes[-1].line, edges, spread)
    psi_b, land, margin = rg.register_turn(pf, funnel.final_edges, funnel.directions[-1])
    pushes.append(_fence(part, spread, psi_b, margin, land, "register"))
    spread = rg.after_push(part, psi_b, pushes[-1].line, land, spread)
    _check_limits(part, pushes, spread, region, max_stroke, o.workspace)
    rep = _representative(pf, funnel, region, start_heading)
    final, least, ok = replay_sensorless(part, pushes, rep[None, :])
    if not (ok[0] and least[0] > 0):
        raise PlanningError("registration: the replay from a representative start did not end flush")
    registered = final[0]
    # the pose phase: to the goal, or one period away when the part looks the same there
    goals = [goal] if not pf.part_symmetric else [
        np.array([goal[0], goal[1], float(wrap_angle_np(goal[2] + k * pf.period))])
        for k in range(pf.symmetry)]
    best, err = None, None
    for g in goals:
        try:
            pp = plan_pose(vertices, registered, g, com=com, options=o)
        except PlanningError as exc:
            err = exc
            continue
        if best is None or pp.total_distance < best[0].total_distance:
            best = (pp, g)
    if best is None:
        raise PlanningError(f"pose: no plan from the registered pose: {err}")
    pose_plan, reached_goal = best
    before = registered
    for p in pose_plan.pushes:
        d = np.asarray(p.direction)
        world = before[:2] + part.body @ np.array([[math.cos(before[2]), math.sin(before[2])],
                                                   [-math.sin(before[2]), math.cos(before[2])]])
        line = float(np.min(world @ d)) + p.distance
        pushes.append(FencePush("pose", (float(d[0]), float(d[1])), line, p.distance, p.distance,
                                (tuple(p.edge),)))
        before = np.asarray(p.pose_after)
    excluded = ()
    if start_heading is None or funnel.margins[0] == 0.0:
        excluded = tuple(float(wrap_angle_np(t + funnel.directions[0] - 0.5 * math.pi))
                         for t in pf.divergent)
    plan = SensorlessPlan(
        pushes=tuple(pushes), region=region, start_heading=start_heading,
        goal=tuple(float(v) for v in goal), reached_goal=tuple(float(v) for v in reached_goal),
        registered=tuple(float(v) for v in registered), period=pf.period, symmetry=pf.symmetry,
        part_symmetric=pf.part_symmetric, excluded=excluded,
        uncertain_under_slip=(
            f"the coordinate along the register push's fence (along ({math.cos(funnel.directions[-1]):.4g}, "
            f"{math.sin(funnel.directions[-1]):.4g})) is set by the last orient push only if the "
            "part does not slide along that fence"),
        pose_plan=pose_plan, funnel=funnel)
    starts = start_grid(region, start_heading, n_headings, n_side)
    reached, cov = check(plan, part, starts)
    if not np.all(reached[cov]):
        bad = starts[cov & ~reached][0]
        raise PlanningError(f"check: the exact replay from ({bad[0]:.6g}, {bad[1]:.6g}, "
                            f"{math.degrees(bad[2]):.6g} deg) misses the goal "
                            f"({int(np.sum(cov & ~reached))} of {int(np.sum(cov))} starts)")
    return dataclasses.replace(plan, checked=(n_headings, n_side * n_side, int(np.sum(reached))))


def _fence(part, spread, psi, margin, edges, phase) -> FencePush:
    line, stroke = rg.fence_line(part, spread, psi, margin)
    return FencePush(phase, _unit(psi), line, rg.travel(part, margin), stroke,
                     tuple(part.polygon.edge_vertices(int(e)) for e in sorted(edges)))


def _check_limits(part, pushes, spread, region, max_stroke, workspace):
    limit = part.longest_plan if max_stroke is None else max_stroke
    what = "max_stroke" if max_stroke is not None else "the float64 limit of a plan's length"
    for i, p in enumerate(pushes):
        if p.stroke > limit:
            raise PlanningError(
                f"region: too large for the registration: push {i + 1} ({p.phase}) needs a fence "
                f"stroke of {p.stroke:.6g} m, more than {what} ({limit:.6g} m); shrink the region "
                "or allow a longer stroke")
    if workspace is not None:
        xmin, xmax, ymin, ymax = workspace
        r = float(part.geom.radius)
        c = spread.corners()
        if (np.min(c[:, 0]) - r < xmin or np.max(c[:, 0]) + r > xmax
                or np.min(c[:, 1]) - r < ymin or np.max(c[:, 1]) + r > ymax):
            raise PlanningError(
                "region: too large for the registration: the part may end the register push "
                f"outside the workspace (centres of mass in x [{np.min(c[:, 0]):.4g}, "
                f"{np.max(c[:, 0]):.4g}] m, y [{np.min(c[:, 1]):.4g}, {np.max(c[:, 1]):.4g}] m); "
                "shrink the region or enlarge the workspace")


__all__ = ["FencePush", "SensorlessPlan", "PHASES", "plan_sensorless", "replay_sensorless",
           "start_grid", "check", "covered", "goal_errors"]
