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


# ---------------------------------------------------------------- readable figures (issue 42)
def _texts(fig):
    """Every piece of text a figure shows (titles, labels, ticks, legends)."""
    import matplotlib.text

    fig.canvas.draw()   # the tick labels exist once drawn
    return [t for t in fig.findobj(matplotlib.text.Text) if t.get_visible() and t.get_text()]


def _joined(ax):
    """The plotted series whose markers a line joins (axhline's reference lines aside)."""
    return [ln for ln in ax.get_lines() if ln.get_linestyle() not in ("None", "", " ")
            and len(set(np.asarray(ln.get_xdata(), float).tolist())) > 1
            and ln.get_transform() == ax.transData]


def readable(fig, categorical: bool):
    """What issue 42 asked of a report figure: text of 10 pt or more, no line
    between categories, a non-negative quantity's axis from zero or on a log
    scale (no "0" or "-10^-1" ticks)."""
    small = sorted({(t.get_text(), t.get_fontsize()) for t in _texts(fig)
                    if t.get_fontsize() < figs.MIN_FONT_PT})
    assert not small, f"text under {figs.MIN_FONT_PT} pt: {small[:5]}"
    for ax in fig.axes:
        if categorical:
            assert not _joined(ax), [ln.get_label() for ln in _joined(ax)]
        assert ax.get_yscale() in ("linear", "log"), ax.get_yscale()
    assert fig.get_figwidth() * figs.DPI >= 1000      # drawn for the page's full width


def _errors():
    """A summary's error quantiles: 2 configurations x 4 tasks."""
    rng = np.random.default_rng(0)
    q = np.sort(rng.lognormal(np.log(2e-3), 1.0, (8, 4)), axis=1)
    return pd.DataFrame(dict(config_id=np.repeat([0, 1], 4), task=np.tile(range(4), 2),
                             strategy=np.repeat(["paper", "search"], 4),
                             margin=np.repeat([3.0, 7.0], 4),
                             **{f"err_pos_m_{n}": q[:, i]
                                for i, n in enumerate(("q50", "q90", "q99", "max"))}))


@pytest.mark.parametrize("column, categorical", [("strategy", True), ("margin", False),
                                                 (None, True)])
def test_the_error_figure_has_no_negative_ticks_and_readable_text(monkeypatch, column,
                                                                  categorical):
    """A symmetric-log axis showed "0" and "-10^-1" ticks for a positive error,
    lines joined the categories "paper" and "search", and the text was 7-8 pt."""
    monkeypatch.setattr(figs, "_png", lambda fig: fig)
    fig = figs.error_quantiles(_errors(), column, column or "", 3e-3)
    readable(fig, categorical)
    ax = fig.axes[0]
    assert ax.get_yscale() == "log" and ax.get_ylim()[0] > 0
    fig.canvas.draw()
    assert all(t.get_position()[1] > 0 for t in ax.get_yticklabels() if t.get_text())
    # a zero error: a linear axis from zero
    zero = _errors().assign(err_pos_m_q50=0.0)
    ax = figs.error_quantiles(zero, column, column or "", 3e-3).axes[0]
    assert ax.get_yscale() == "linear" and ax.get_ylim()[0] == 0.0


def test_the_error_figure_draws_each_value_s_worst_task():
    """Of each configuration, every quantile is its worst task's (the summary's
    per-task quantiles; the samples are not read)."""
    import matplotlib

    matplotlib.use("Agg")
    e = _errors()
    fig = None
    orig = figs._png
    try:
        figs._png = lambda f: f
        fig = figs.error_quantiles(e, "margin", "margin", 3e-3)
    finally:
        figs._png = orig
    lines = {ln.get_label(): ln.get_ydata() for ln in fig.axes[0].get_lines()}
    for n in ("q50", "q90", "q99", "max"):
        want = e.groupby("margin")[f"err_pos_m_{n}"].max().to_numpy() * 1e3
        assert np.allclose(lines[n], want), n
    assert figs.error_quantiles(e.assign(**{f"err_pos_m_{n}": np.nan for n in
                                            ("q50", "q90", "q99", "max")}), "margin", "m",
                                3e-3) is None


def test_every_study_figure_is_readable_and_marks_categories(monkeypatch):
    monkeypatch.setattr(figs, "_png", lambda fig: fig)
    s = _summary()
    for col, cat in (("c", True), ("b", False)):
        readable(figs.success_vs_param(s, col, col, 0.95, "a", "friction.a"), cat)
    plans = pd.DataFrame([dict(config_id=0 if st == "paper" else 1, strategy=st, task=t,
                               planned=True, n_steps=5 + t, total_distance_m=0.2 + 0.01 * t)
                          for st in ("paper", "search") for t in range(3)])
    readable(figs.plan_shape(plans, "strategy", "planner.strategy", "push"), True)
    readable(figs.solvable_fraction(plans, "strategy", "planner.strategy", 0.95), True)
    fm = s.assign(config_id=np.arange(len(s)) % 3, n_none=s.n_success,
                  **{f"n_{m}": 0 for m in figs.FAILURE_MODES[1:]})
    readable(figs.failure_modes(fm, ["a", "b", "c"]), True)


@pytest.mark.slow
def test_the_report_shows_readable_figures_at_full_width(tmp_path, monkeypatch):
    """Through ``nudge sweep``: every figure of report.html is readable (as above)
    and shown at the page's full width (figures were at 40% of it)."""
    from tests.commandline import ROOT, nudge_here

    drawn = []
    original = figs._png

    def keep(fig):
        drawn.append((fig, not all(_numeric_x(ax) for ax in fig.axes)))
        return original(fig)

    monkeypatch.setattr(figs, "_png", keep)
    study = tmp_path / "s.yaml"
    study.write_text((ROOT / "examples" / "studies" / "margins.yaml").read_text()
                     .replace("planner.margin_deg: [3, 7, 12]", "planner.margin_deg: [3, 12]")
                     .replace("execution.fence_angle: [0.002, 0.02, 0.04]",
                              "execution.fence_angle: [0.002]")
                     .replace("sample: {n: 4,", "sample: {n: 2,"))
    r = nudge_here("sweep", study, "--set", "samples=8", "--out", tmp_path / "out")
    assert r.returncode == 0, r.stderr
    assert len(drawn) >= 5
    for fig, categorical in drawn:
        readable(fig, categorical)
    html = (tmp_path / "out" / "report.html").read_text()
    assert ".figs img { width: 100%; height: auto; }" in html and "max-width: 540px" not in html


def _numeric_x(ax):
    """Whether an axis's x values are numbers (tick labels that read as numbers)."""
    labels = [t.get_text() for t in ax.get_xticklabels() if t.get_text()]
    try:
        [float(x.replace("\N{MINUS SIGN}", "-")) for x in labels]
    except ValueError:
        return False
    return True
