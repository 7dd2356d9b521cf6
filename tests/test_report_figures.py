"""The study report's figures choose what to draw from the data: the other
axis that moves success most becomes the lines, the next the panels (a
pooled curve over an axis that decides success alone sits flat at its mean)."""
import itertools

import numpy as np
import pandas as pd
import pytest

from sweeps import report
from sweeps.figures import study as figs


def _summary():
    rows = []
    for a, b, c in itertools.product([0.3, 0.8], [3, 7, 12], ["x", "y"]):
        # a decides success (0 or ~1); b moves it a little when c == "y"; c alone moves it less
        p = 0.0 if a == 0.3 else (0.6 + 0.03 * b if c == "y" else 0.95)
        rows.append(dict(a=a, b=b, c=c, n=100, n_success=int(round(100 * p))))
    return pd.DataFrame(rows)


def test_effect_is_the_range_of_the_pooled_rate():
    s = _summary()
    assert figs.effect(s, "a", "n_success", "n") == pytest.approx(
        s[s.a == 0.8].n_success.sum() / s[s.a == 0.8].n.sum())
    assert figs.effect(s, "a", "n_success", "n") > figs.effect(s, "b", "n_success", "n") > 0
    assert figs.effect(s.assign(b=3), "b", "n_success", "n") == 0.0   # one value: no effect


def test_lines_are_the_largest_effect_and_panels_the_next():
    s = _summary()
    axes = [("planner.b", "b"), ("planner.c", "c"), ("friction.a", "a")]
    assert report._by_effect(s, axes, "planner.b") == ("a", "friction.a", "c", "planner.c")
    assert report._by_effect(s, axes, "friction.a")[:2] == ("b", "planner.b") or \
        report._by_effect(s, axes, "friction.a")[:2] == ("c", "planner.c")
    assert report._by_effect(s, axes[:1], "planner.b") == (None, "", None, "")


def test_success_figure_draws_a_panel_per_facet_and_a_line_per_value(monkeypatch):
    monkeypatch.setattr(figs, "_png", lambda fig: fig)
    fig = figs.success_vs_param(_summary(), "b", "planner.b", 0.95, "a", "friction.a", "c", "planner.c")
    axs = fig.axes
    assert len(axs) == 2
    assert [ax.get_title() for ax in axs] == ["planner.c = x", "planner.c = y"]
    for ax in axs:
        assert len(ax.get_lines()) == 2                     # a = 0.3, a = 0.8
    y = [np.asarray(line.get_ydata(), float) for line in axs[1].get_lines()]
    assert np.allclose(y[0], 0.0) and np.all(np.diff(y[1]) > 0)   # the small effect is visible


def test_plan_figure_shows_length_and_distance_per_strategy(monkeypatch):
    monkeypatch.setattr(figs, "_png", lambda fig: fig)
    plans = pd.DataFrame([dict(margin=m, strategy=st, task=t, planned=True, n_steps=5 + t,
                               total_distance_m=(0.5 - 0.015 * m) if st == "paper" else 0.22)
                          for m in (3, 7, 12) for st in ("paper", "search") for t in range(2)])
    fig = figs.plan_shape(plans, "margin", "planner.margin_deg", "push", "strategy",
                          "planner.strategy")
    dist = fig.axes[1]
    assert dist.get_title() == "push distance" and len(dist.get_lines()) == 2
    paper = np.asarray(dist.get_lines()[0].get_ydata(), float)
    assert np.allclose(paper, [0.455, 0.395, 0.32])


def test_every_failure_mode_has_one_home_that_the_figure_and_the_models_read(monkeypatch):
    """Each mode a kernel or a physics model assigns is named in
    robustness.failure_modes (with a colour and a description), and the
    failure-mode figure draws a summary holding all of them."""
    from robustness import FAILURE_MODES, failure_modes
    from robustness.physics import PUSH_FAILURE_MODES, TUMBLE_FAILURE_MODES

    assert FAILURE_MODES == failure_modes.NAMES and FAILURE_MODES[0] == "none"
    assert set(PUSH_FAILURE_MODES) <= set(FAILURE_MODES)
    assert set(TUMBLE_FAILURE_MODES) <= set(FAILURE_MODES)
    assert len(set(failure_modes.COLOURS.values())) == len(FAILURE_MODES)
    assert all(m.description for m in failure_modes.MODES)
    monkeypatch.setattr(figs, "_png", lambda fig: fig)
    summary = pd.DataFrame([dict(config_id=c, n=len(FAILURE_MODES), **{f"n_{m}": 1 for m in FAILURE_MODES})
                            for c in range(2)])
    fig = figs.failure_modes(summary, ["a", "b"])
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert labels == ["success", *FAILURE_MODES[1:]]
