"""Sensorless orienting (Goldberg 1993): the push function as a step function,
its symmetry, and the shortest sequence of fence push directions that takes
every heading (or every heading of an interval) to one heading up to that
symmetry.

Frames and units: radians, CCW positive.  A push's direction is the world
angle ``psi`` of the fence's motion ``d = (cos psi, sin psi)``.  Headings
relative to a push use the convention of :mod:`planning.pushing.stability`:
for a fence moving in +y (``psi = pi/2``) the relative heading is the part's
world heading, and for any other push ``theta_rel = theta - psi + pi/2``.

The push function ``p`` maps a relative heading to the heading at which the
push leaves the part: a long normal push ends with the stable edge of the
basin the heading lies in flush (``edge_theta[e]``); the basins are bounded by
the divergent orientations (the radius function's maxima), where the push
does not decide (an unstable equilibrium, a set of measure zero).  So ``p`` is
a step function with one step per stable edge, and the relative headings
after a push are a finite set of stable edges: the funnel is a breadth-first
search over those sets, whose actions are the relative turns ``alpha`` of
the push direction, one per cell between the turns at which a possible
heading crosses a basin boundary (Goldberg's construction; every turn in a
cell gives the same sets).  It ends when every possible edge lies in one
orbit of the push function's symmetry (period ``2 pi / m``): pushes cannot
tell those headings apart.  Each turn is its cell's middle, so a push's margin
(how far a possible heading stays from a basin boundary) is the cell's
half-width; among the shortest sequences the search keeps the one whose least
margin (:func:`least_margin`) is largest: a heading error smaller than it
cannot change a push's outcome.

Parts with a marginal edge (an unstable equilibrium a push can end on,
:mod:`kernels.push`) are refused: their push function has a third kind of
step.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Optional

import numpy as np

from planning.pushing.part import PlanningError, PushPart

TWO_PI = 2.0 * math.pi
#: rad: two angles this close are the same (symmetry tests, basin bookkeeping)
ANGLE_TOL = 1e-9
#: rad: starts this close to a divergent orientation of the first push are not
#: covered (an unstable equilibrium: a push from exactly there does not turn);
#: the first push is long enough for every start farther away.
EXCLUDED = 1e-6


def _mod(a):
    return np.mod(a, TWO_PI)


def _circ_dist(a, b):
    d = np.abs(_mod(np.asarray(a) - np.asarray(b)))
    return np.minimum(d, TWO_PI - d)


@dataclasses.dataclass(frozen=True)
class PushFunction:
    """The push function of a part as a step function (relative headings, rad).

    Attributes:
      part: the prepared part.
      divergent: (m,) increasing basin boundaries in [0, 2 pi) (rad).
      basin_edge: (m,) hull index of the stable edge a push from the open
        interval ``(divergent[j], divergent[j + 1])`` ends on.
      edge_theta: (n,) relative heading at which each hull edge lies flush.
      period: the push function's period ``2 pi / symmetry`` (rad):
        ``p(theta + period) = p(theta) + period``.
      symmetry: the order ``m`` of that symmetry (1: none).
      part_symmetric: the part's hull (about its centre of mass) is itself
        unchanged by a turn of ``period``: headings one period apart give the
        same footprint.  When False and ``symmetry > 1``, pushes cannot tell
        apart headings that place the part differently.
    """

    part: PushPart
    divergent: np.ndarray
    basin_edge: np.ndarray
    edge_theta: np.ndarray
    period: float
    symmetry: int
    part_symmetric: bool

    def basin(self, theta):
        """Index of the basin holding relative heading ``theta`` (rad, arrays ok)."""
        t = _mod(np.asarray(theta, float))
        return (np.searchsorted(self.divergent, t, side="right") - 1) % len(self.divergent)

    def __call__(self, theta):
        """Hull index of the stable edge a long push from relative heading
        ``theta`` ends on (arrays ok; undecided on a basin boundary)."""
        return self.basin_edge[self.basin(theta)]

    def margin(self, theta):
        """Distance (rad) from relative heading ``theta`` to the nearest basin boundary."""
        t = np.asarray(theta, float)
        return np.min(_circ_dist(t[..., None], self.divergent), axis=-1)

    def orbit(self, edge: int) -> frozenset:
        """Stable edges whose flush headings differ from ``edge``'s by a multiple of the period."""
        th = self.edge_theta
        return frozenset(int(e) for e in self.basin_edge
                         if min(_circ_dist(th[e] - th[edge], k * self.period)
                                for k in range(self.symmetry)) < ANGLE_TOL)


def push_function(part: PushPart) -> PushFunction:
    """The step push function of ``part`` (module docstring), built from
    :func:`planning.pushing.stability.push_stability` (the exact replay's
    divergent orientations and flush headings) and checked against its
    replayed grid: every grid heading away from a boundary must end on its
    basin's edge.

    Raises:
      PlanningError: the part has a marginal edge, or the step function and
        the replay disagree.
    """
    from planning.pushing.stability import push_stability

    st = push_stability(part, n_grid=720)
    if st.marginal:
        edges = [list(st.caller_edge(e)) for _, e, _ in st.marginal]
        raise PlanningError(f"part: edges {edges} are marginal (the centre of mass's foot at an "
                            "end: an unstable equilibrium a push can end on); sensorless "
                            "orienting needs every edge stable or unstable: move the centre of "
                            "mass off the edge's end")
    div = np.array(sorted(_mod(t) for t, _ in st.divergent))
    et = np.asarray(st.edge_theta)
    stable = list(part.stable)
    if len(div) != len(stable):
        raise PlanningError(f"part: {len(div)} divergent orientations but {len(stable)} stable "
                            "edges; the push function is not a step function here")
    basin_edge = np.full(len(div), -1)
    for e in stable:
        j = int((np.searchsorted(div, _mod(et[e]), side="right") - 1) % len(div))
        if basin_edge[j] >= 0:
            raise PlanningError("part: two stable edges in one basin of the push function")
        basin_edge[j] = e
    pf = PushFunction(part=part, divergent=div, basin_edge=basin_edge, edge_theta=et,
                      period=TWO_PI, symmetry=1, part_symmetric=True)
    far = pf.margin(st.theta) > 2 * TWO_PI / len(st.theta)
    if np.any(pf(st.theta)[far] != st.final_edge[far]):
        raise PlanningError("push function: the step function disagrees with the exact replay")
    m = _symmetry(div, et[stable])
    period = TWO_PI / m
    return dataclasses.replace(pf, period=period, symmetry=m,
                               part_symmetric=_turn_invariant(part.body, period))


def _same_set(a, b) -> bool:
    return all(np.min(_circ_dist(x, b)) < ANGLE_TOL for x in a)


def _symmetry(div, stable_theta) -> int:
    """Largest ``m`` such that the boundaries and the flush headings are
    unchanged by a turn of ``2 pi / m``."""
    for m in range(len(div), 1, -1):
        if len(div) % m == 0:
            t = TWO_PI / m
            if _same_set(div + t, div) and _same_set(stable_theta + t, stable_theta):
                return m
    return 1


def _turn_invariant(body, angle) -> bool:
    c, s = math.cos(angle), math.sin(angle)
    turned = body @ np.array([[c, s], [-s, c]])
    size = float(np.max(np.hypot(body[:, 0], body[:, 1])))
    d = np.min(np.linalg.norm(turned[:, None, :] - body[None, :, :], axis=-1), axis=1)
    return bool(np.all(d < 1e-9 * size))


@dataclasses.dataclass(frozen=True)
class Funnel:
    """The shortest orienting sequence of fence pushes.

    Attributes:
      push_function: the part's :class:`PushFunction`.
      directions: world angles ``psi`` (rad) of the fence's motion, in order.
      margins: per push, the least distance (rad) of a possible relative
        heading from a basin boundary (the first push: 0 when a boundary lies
        inside the start headings, whose neighbourhood of :data:`EXCLUDED` rad
        is then not covered).
      states: per push, the stable edges (hull indices) the part may rest on
        after it (relative to that push: heading ``edge_theta[e] + psi - pi/2``).
      start_heading: ``(lo, hi)`` world headings (rad) covered, or None (any).
    """

    push_function: PushFunction
    directions: tuple[float, ...]
    margins: tuple[float, ...]
    states: tuple[frozenset, ...]
    start_heading: Optional[tuple[float, float]] = None

    @property
    def length(self) -> int:
        return len(self.directions)

    @property
    def final_edges(self) -> frozenset:
        return self.states[-1]

    def final_headings(self) -> tuple[float, ...]:
        """World headings (rad, in (-pi, pi]) the part may have after the funnel
        (one per edge of the final orbit)."""
        psi = self.directions[-1]
        return tuple(float(np.angle(np.exp(1j * (self.push_function.edge_theta[e] + psi - 0.5 * math.pi))))
                     for e in sorted(self.final_edges))

    def summary(self) -> str:
        pf = self.push_function
        sym = (f"push function of period {math.degrees(pf.period):.4g} deg (symmetry {pf.symmetry})"
               if pf.symmetry > 1 else "no symmetry")
        head = ", ".join(f"{math.degrees(h):.4g}" for h in self.final_headings())
        lines = [f"funnel: {self.length} push{'es' if self.length != 1 else ''}, {sym}; final heading(s) {head} deg"]
        if pf.symmetry > 1:
            lines.append("  headings one period apart cannot be told apart by pushing"
                         + (" (the part looks the same: same footprint)" if pf.part_symmetric
                            else " and the part does NOT look the same at them"))
        return "\n".join(lines)


def _cells(critical):
    """Midpoints and half-widths of the cells between sorted angles on the circle."""
    c = np.unique(np.round(_mod(np.asarray(critical, float)), 14))
    nxt = np.append(c[1:], c[0] + TWO_PI)
    return _mod(0.5 * (c + nxt)), 0.5 * (nxt - c)


def _goal(pf: PushFunction, state: frozenset) -> bool:
    return state <= pf.orbit(next(iter(state)))


def _first_pushes(pf: PushFunction, start_heading):
    """Candidate first pushes: ``(psi, state, margin)``."""
    if start_heading is None:
        return [(0.5 * math.pi, frozenset(int(e) for e in pf.basin_edge), 0.0)]
    lo, hi = start_heading
    out = []
    # shift s = psi - pi/2: the relative interval is [lo - s, hi - s]
    mids, _ = _cells(np.concatenate([lo - pf.divergent, hi - pf.divergent]))
    for s in mids:
        a, b = lo - s, hi - s
        inside = _mod(pf.divergent - a) <= (b - a)
        if np.any(inside):
            margin = 0.0
            # basins met: every basin whose start boundary lies inside, and the one holding a
            idx = set(np.flatnonzero(inside).tolist()) | {int(pf.basin(a))}
            state = frozenset(int(pf.basin_edge[j]) for j in idx)
        else:
            margin = float(min(pf.margin(a), pf.margin(b)))
            state = frozenset({int(pf(a))})
        out.append((float(_mod(s + 0.5 * math.pi)), state, margin))
    return out


def least_margin(margins) -> float:
    """A funnel's least margin (rad): the smallest of its pushes' margins, the
    first push's left out where it is 0 (a basin boundary inside the start
    headings: every funnel from them has it, and its neighbourhood is not
    covered).  The distance by which a heading error can stay inside every
    basin the funnel relies on."""
    m = [float(x) for i, x in enumerate(margins) if not (i == 0 and x == 0.0)]
    return min(m) if m else math.inf


def orient(part_or_pf, start_heading=None, max_pushes: int = 64,
           enough: float = math.radians(7.0)) -> Funnel:
    """The shortest funnel (module docstring) for ``start_heading`` (``(lo, hi)``,
    world rad, ``hi - lo < 2 pi``) or every heading (None); among the shortest,
    the one whose :func:`least_margin` is largest, margins of ``enough`` rad or
    more counting alike (then the first found: a turn in the first cell of
    the widest kind).  :func:`planning.plan_sensorless` passes the pose
    planner's ``margin_deg``, the same margin from an unstable equilibrium.
    Before December 2026 every funnel from any heading compared equal here (the
    first push's inherent 0 was in the minimum), and the nice-stable pentagon's
    funnel turned 0.16 deg from a basin boundary (MuJoCo landed the other edge
    from 3 of 4 random starts, ``bench/sensorless.py``); now 3.8 deg.

    Raises:
      PlanningError: none within ``max_pushes`` (cannot happen for a valid part:
        Goldberg's theorem).
    """
    pf = part_or_pf if isinstance(part_or_pf, PushFunction) else push_function(part_or_pf)

    def score(margins) -> float:
        return min(least_margin(margins), enough)

    level = {}
    for psi, state, margin in _first_pushes(pf, start_heading):
        if state not in level or margin > level[state][1][0]:
            level[state] = ((psi,), (margin,), (state,))
    seen = set(level)
    for _ in range(max_pushes):
        done = [(score(v[1]), k) for k, v in level.items() if _goal(pf, k)]
        if done:
            key = max(done, key=lambda t: t[0])[1]
            dirs, margins, states = level[key]
            return Funnel(pf, tuple(float(d) for d in dirs), tuple(float(m) for m in margins),
                          states, None if start_heading is None else tuple(start_heading))
        nxt = {}
        for state, (dirs, margins, states) in level.items():
            th = pf.edge_theta[sorted(state)]
            mids, half = _cells((th[:, None] - pf.divergent[None, :]).ravel())
            for alpha, h in zip(mids, half):
                new = frozenset(int(e) for e in pf(th - alpha))
                if new in seen and new not in nxt:
                    continue
                cand = (dirs + (float(_mod(dirs[-1] + alpha)),), margins + (float(h),),
                        states + (new,))
                if new not in nxt or score(cand[1]) > score(nxt[new][1]):
                    nxt[new] = cand
        seen |= set(nxt)
        level = nxt
        if not level:
            break
    raise PlanningError(f"funnel: no orienting sequence of at most {max_pushes} pushes found")


def exhaustive_length(pf: PushFunction, n_directions: int = 72, max_pushes: int = 4,
                      start_heading=None) -> Optional[int]:
    """Reference check of :func:`orient`: the fewest pushes, turns taken from
    the ``n_directions`` multiples of ``2 pi / n_directions`` (offset by half a
    step, off every boundary of regular parts), found by trying every sequence
    of ``k = 1, 2, ...`` pushes (the sets one level reaches are kept once: a
    set's futures do not depend on how it was reached); None when
    none of at most ``max_pushes`` orients.  It can only be longer than the
    funnel (a coarse set of turns may miss a narrow cell), never shorter."""
    turns = (np.arange(n_directions) + 0.5) * (TWO_PI / n_directions)
    if start_heading is None:
        firsts = [frozenset(int(e) for e in pf.basin_edge)]
    else:   # every first push direction of the set, the start headings sampled densely
        lo, hi = start_heading
        h = np.linspace(lo, hi, 2001)
        firsts = {frozenset(int(e) for e in pf(h - s)) for s in turns}
    frontier = sorted({tuple(sorted(s)) for s in firsts})
    for k in range(1, max_pushes + 1):
        if any(_goal(pf, frozenset(s)) for s in frontier):
            return k
        if k == max_pushes:
            return None
        new = set()
        for s in frontier:
            th = pf.edge_theta[list(s)]
            rows = pf(th[None, :] - turns[:, None])
            new |= {tuple(sorted(set(r.tolist()))) for r in rows}
        frontier = sorted(new)
    return None


__all__ = ["PushFunction", "Funnel", "push_function", "orient", "least_margin", "exhaustive_length",
           "EXCLUDED", "ANGLE_TOL"]
