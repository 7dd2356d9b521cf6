"""Every failure mode a model can give a sample: its name, what it means, and
the colour it is drawn in.  The one home that the tables (one ``n_<mode>``
count column each, :mod:`robustness.tables`), the kernels' and the physics
models' classifications, the report's figures and the terminal read.

The kernel models (exact, quasistatic, limit_surface; tumbles) assign the
first nine (:mod:`robustness.evaluation`); MuJoCo adds those only a physics
engine can see (a part leaving the workspace, toppling, a fence striking it):
``robustness.physics.PUSH_FAILURE_MODES`` and ``TUMBLE_FAILURE_MODES`` list, in
assignment order, names from here (``tests/test_report_figures.py`` holds them
to it).
"""
from __future__ import annotations

import dataclasses


@dataclasses.dataclass(frozen=True)
class FailureMode:
    """One outcome of a sample: ``name`` (a table value and a column suffix),
    ``description`` (one sentence for a person), ``colour`` (a matplotlib
    colour for the figures)."""

    name: str
    description: str
    colour: str


#: In table order: ``none`` (success) first.
MODES = (
    FailureMode("none", "success: the final pose within the position and heading tolerances",
                "tab:green"),
    FailureMode("incomplete_reorientation",
                "a push ended before an edge of the part lay flush against the fence", "tab:orange"),
    FailureMode("wrong_edge", "a push ended flush on another edge than planned", "tab:red"),
    FailureMode("slip", "the part slid along the fence by at least the slip fraction of the "
                "position tolerance (tumbles: along the pads)", "tab:purple"),
    FailureMode("hull_changed", "the perturbed polygon is no longer the nominal convex shape "
                "(or its centre of mass lies outside it): outside the model", "tab:brown"),
    FailureMode("wrong_face", "a tumble was invalid or another face lies on the plane at the end",
                "tab:pink"),
    FailureMode("combinatorics_changed", "the perturbed polyhedron's faces or edges differ from "
                "the nominal ones: outside the model", "tab:olive"),
    FailureMode("position", "the final position is outside the tolerance", "tab:cyan"),
    FailureMode("orientation", "the final heading is outside the tolerance", "tab:gray"),
    FailureMode("left_workspace", "physics: the part left the cell's workspace", "gold"),
    FailureMode("toppled", "physics: the part tipped over onto a side face", "black"),
    FailureMode("fence_strike", "physics: the fence touched the part while coming down or "
                "moving lifted between pushes", "tab:blue"),
)

BY_NAME = {m.name: m for m in MODES}
#: the names, in table order
NAMES = tuple(m.name for m in MODES)
COLOURS = {m.name: m.colour for m in MODES}

__all__ = ["FailureMode", "MODES", "BY_NAME", "NAMES", "COLOURS"]
