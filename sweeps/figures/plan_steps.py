"""The PSD figure's marks of a plan's reorient steps (:func:`sweeps.figures.push.plot_psd`
with a plan): one arrow per reorient push on its landing edge's row, in degrees of
the part's orientation relative to the fence."""
from __future__ import annotations

import math

import numpy as np

from planning import PushPart, PushPlan, PushStability


def mark_steps(bx, plan: PushPlan, part: PushPart, data: PushStability, stable) -> None:
    """Arrows on the edge rows of the bottom panel: each reorient push of the
    plan, numbered by its index in the plan, from the orientation relative to
    the fence where it starts (its landing orientation less its planned
    rotation, degrees) to where its edge lands.  An arrow that crosses 0/360
    degrees is drawn in two pieces, the head on the landing side."""
    row = {e: len(stable) - 1 - r for r, e in enumerate(stable)}
    steps = [(i, part.polygon.caller_edge_to_hull(p.edge), p) for i, p in enumerate(plan.pushes)
             if p.kind == "reorient" and p.rotation is not None]
    total = {e: sum(1 for _, f, _ in steps if f == e) for _, e, _ in steps}
    count = {}
    for i, e, p in steps:
        a, b = arrow_span(float(np.degrees(data.edge_theta[e])), math.degrees(p.rotation))
        k = count.get(e, 0)
        count[e] = k + 1
        y = row[e] - 0.4 + 0.8 * (k + 0.5) / total[e]   # the arrows of one row spread over it
        tail = min(max(a, 0.0), 360.0)
        bx.annotate("", xy=(b, y), xytext=(tail, y), zorder=6,
                    arrowprops=dict(arrowstyle="->", color="k", lw=1.0, shrinkA=0, shrinkB=0))
        if a != tail:   # the rest of the tail, beyond the other end of the axis
            bx.plot([a + 360.0 if a < 0 else a - 360.0, 360.0 if a < 0 else 0.0], [y, y],
                    color="k", lw=1.0, zorder=6)
        # the push's index just beyond the tail, clear of the arrow
        bx.text(tail + (-1.0 if b > tail else 1.0), y, str(i), fontsize=5, zorder=6, va="center",
                ha="right" if b > tail else "left")


def arrow_span(end_deg: float, rotation_deg: float) -> tuple[float, float]:
    """``(tail, head)`` (deg) of a reorient arrow landing at ``end_deg`` after a
    CCW-positive rotation of ``rotation_deg``: the head in [0, 360], shifted
    by a turn where that keeps the whole arrow on the axis."""
    b = end_deg % 360.0
    a = b - rotation_deg
    if a < 0.0 and b < 1e-6:
        a, b = a + 360.0, 360.0
    elif a > 360.0 and b > 360.0 - 1e-6:
        a, b = a - 360.0, 0.0
    return a, b
