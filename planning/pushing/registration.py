"""Fence lines for pushes whose start position is only known to lie in a
region, and the registration push that makes the position known.

A sensorless push is given by its direction ``d = (cos psi, sin psi)`` (world)
and its fence's final line ``{q : d . q = line}`` (m): the fence comes from
behind every possible position of the part and stops there.  A push that
ends with a stable edge ``e`` flush leaves the centre of mass at
``d . p = line + height[e]`` whatever the start: that coordinate is set
absolutely.  The coordinate along the fence is not: in the no-slip model the
contact vertex does not move along the fence, so after the push it is the
coordinate along the fence before the push plus a shift that depends on the
heading only.  Hence registration: the funnel's last push sets the coordinate
along its direction ``d_A``; one more push along ``d_B`` perpendicular to it
sets ``d_B . p`` and keeps ``d_A . p`` (the coordinate along its fence) known,
**if the part does not slide along the fence** during that push: under slip
the coordinate along the register push's fence (``d_A . p``) is what remains
uncertain.  (A push not perpendicular to ``d_A`` would mix the unknown
coordinate into the one along its fence: two non-parallel pushes are not
enough unless they are perpendicular.)

Each push's fence travels, after first touching the part, at least the
distance that completes the turn from the worst possible heading
(:func:`travel`); its line is set so that it does from every possible position
(:class:`Spread` tracks a rectangle holding every possible centre of mass).

Units: metres, radians, world frame, CCW positive.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from planning.pushing.funnel import EXCLUDED, PushFunction
from planning.pushing.part import PlanningError, PushPart

#: the push's heading margin (rad) below which a registration push is refused
MIN_REGISTER_MARGIN = 1e-3


def check_region(region, field: str = "region") -> tuple[float, float, float, float]:
    """Validate ``(xmin, xmax, ymin, ymax)`` (m, world): finite, ``xmin <= xmax``,
    ``ymin <= ymax``; one line naming ``field`` otherwise."""
    try:
        r = tuple(float(v) for v in region)
    except (TypeError, ValueError):
        raise ValueError(f"{field}: expected XMIN,XMAX,YMIN,YMAX numbers (m), got {region!r}") from None
    if len(r) != 4:
        raise ValueError(f"{field}: expected 4 numbers XMIN,XMAX,YMIN,YMAX (m), got {len(r)}")
    if not all(math.isfinite(v) for v in r):
        raise ValueError(f"{field}: holds NaN or inf; give finite bounds in metres")
    if r[0] > r[1] or r[2] > r[3]:
        raise ValueError(f"{field}: needs XMIN <= XMAX and YMIN <= YMAX, got {list(r)}; "
                         "swap the bounds")
    return r


def check_heading_interval(interval, field: str = "start_heading") -> tuple[float, float]:
    """Validate ``(lo, hi)`` (rad): finite, ``lo <= hi < lo + 2 pi``."""
    try:
        lo, hi = (float(v) for v in interval)
    except (TypeError, ValueError):
        raise ValueError(f"{field}: expected LO,HI headings (rad), got {interval!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ValueError(f"{field}: holds NaN or inf; give finite headings (rad)")
    if not lo <= hi < lo + 2 * math.pi:
        raise ValueError(f"{field}: needs LO <= HI < LO + 2 pi, got [{lo}, {hi}]; for every "
                         "heading give --start any without an interval")
    return lo, hi


def travel(part: PushPart, margin: float) -> float:
    """Fence travel (m) after contact that completes a normal push from every
    relative heading at least ``margin`` rad (floored at :data:`EXCLUDED`) from
    a basin boundary, times the part's safety factor.

    The first pass turns about a vertex from the angle ``beta >= min(margin,
    beta_u)`` (``beta_u`` the least starting angle after an unstable edge
    lands) and each unstable edge lands at most once, each pass ending below
    ``pi/2``: Peshkin's length ``k ln(tan(b/2) / tan(a/2))`` with the largest
    gain ``k`` bounds the sum."""
    geom = part.geom
    body = part.body
    rho = np.hypot(body[:, 0], body[:, 1])
    a = float(geom.radius)
    k = float(np.max((a * a + rho * rho) / rho))
    foot = np.asarray(geom.foot)
    unstable = [e for e in range(part.n) if e not in part.stable]
    betas = [float(part.beta2[e, 0 if foot[e] < 0.5 else 1]) for e in unstable]
    b0 = max(float(margin), EXCLUDED)
    if betas:
        b0 = min(b0, min(betas))
    total = math.log(1.0 / math.tan(0.5 * b0)) + sum(math.log(1.0 / math.tan(0.5 * b)) for b in betas)
    return part.safety_factor * k * total * (1.0 + 1e-9) + 1e-9 * part.size


@dataclasses.dataclass(frozen=True)
class Spread:
    """Every possible centre of mass lies in this rectangle, in the frame of a
    push direction ``psi``: ``along = d . p`` in ``[a_lo, a_hi]``, ``across =
    d_perp . p`` in ``[c_lo, c_hi]`` (m)."""

    psi: float
    a_lo: float
    a_hi: float
    c_lo: float
    c_hi: float

    def corners(self) -> np.ndarray:
        d = np.array([math.cos(self.psi), math.sin(self.psi)])
        n = np.array([-d[1], d[0]])
        return np.array([a * d + c * n for a in (self.a_lo, self.a_hi) for c in (self.c_lo, self.c_hi)])

    @staticmethod
    def of_region(region) -> "Spread":
        xmin, xmax, ymin, ymax = region
        return Spread(0.0, xmin, xmax, ymin, ymax)


def fence_line(part: PushPart, spread: Spread, psi: float, margin: float):
    """``(line, stroke)`` of a push along ``psi`` from every centre of mass in
    ``spread`` and every heading at least ``margin`` from a boundary: the line
    is the latest contact (the part's support towards the fence is at least the
    least edge height) plus :func:`travel`; the stroke (m) is the fence's run
    from the earliest possible contact (support at most the part's radius) to
    the line."""
    d = np.array([math.cos(psi), math.sin(psi)])
    proj = spread.corners() @ d
    lo_h = float(np.min(np.asarray(part.geom.height)))
    line = float(np.max(proj)) - lo_h + travel(part, margin)
    stroke = line - (float(np.min(proj)) - float(part.geom.radius))
    return line, stroke


def after_push(part: PushPart, psi: float, line: float, edges, before: Spread) -> Spread:
    """The rectangle (frame ``psi``) holding every centre of mass after a push
    along ``psi`` to ``line`` that ends on one of ``edges`` (hull indices):
    along the push exactly ``line + height[e]``; across it, where it was, widened
    by the perimeter and the radius on each side (the contact point does not
    move along the fence; the part rolls along it at most once around)."""
    h = np.asarray(part.geom.height)[sorted(edges)]
    d = np.array([math.cos(psi), math.sin(psi)])
    n = np.array([-d[1], d[0]])
    across = before.corners() @ n
    body = part.body
    widen = float(np.sum(np.linalg.norm(np.roll(body, -1, axis=0) - body, axis=1))) + 2 * float(part.geom.radius)
    return Spread(psi, line + float(np.min(h)), line + float(np.max(h)),
                  float(np.min(across)) - widen, float(np.max(across)) + widen)


def register_turn(pf: PushFunction, edges, psi_a: float):
    """The registration push after the funnel: ``(psi_b, landing_edges, margin)``,
    ``psi_b = psi_a +- pi/2`` (the sign with the larger heading margin; a
    turn landing a flush edge keeps the heading).

    Raises:
      PlanningError: both perpendicular pushes start on a basin boundary."""
    th = pf.edge_theta[sorted(edges)]
    best = None
    for turn in (0.5 * math.pi, -0.5 * math.pi):
        rel = th - turn
        m = float(np.min(pf.margin(rel)))
        land = frozenset(int(e) for e in pf(rel))
        if best is None or m > best[2]:
            best = (float(np.mod(psi_a + turn, 2 * math.pi)), land, m)
    if best[2] < MIN_REGISTER_MARGIN:
        raise PlanningError("registration: both pushes perpendicular to the funnel's last start "
                            "within 1e-3 rad of an unstable equilibrium of the part")
    return best


__all__ = ["check_region", "check_heading_interval", "travel", "Spread", "fence_line",
           "after_push", "register_turn", "MIN_REGISTER_MARGIN"]
