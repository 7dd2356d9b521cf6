"""Figures of a parameter study (for ``report.html``): each function takes the
run's tables (pandas frames) and returns PNG bytes, or None when the figure
does not apply.

Success rates are pooled over a study's tasks and over the other swept
parameters at each value of the one on the x axis, with two-sided
Clopper-Pearson bands at the study's confidence.
"""
from __future__ import annotations

import functools
import io
import math
from typing import Optional

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from robustness import FAILURE_MODE_COLOURS, FAILURE_MODES, clopper_pearson

MODE_COLORS = FAILURE_MODE_COLOURS   # one home for every mode's name, colour and description

#: The smallest text in a figure, pt: tick labels and legends (titles and axis labels are larger)
MIN_FONT_PT = 10.0
#: Text sizes (pt) of every study figure (matplotlib rc keys)
STYLE = {"font.size": 11.0, "axes.titlesize": 12.0, "axes.labelsize": 11.0,
         "xtick.labelsize": MIN_FONT_PT, "ytick.labelsize": MIN_FONT_PT,
         "legend.fontsize": MIN_FONT_PT, "legend.title_fontsize": MIN_FONT_PT,
         "figure.titlesize": 12.0}
#: A figure's width (inches) and resolution (dots per inch): report.html shows a figure
#: at the page's full width (1,100 px), the PNG's own width, so its text is the size above
WIDTH_IN, DPI = 10.0, 110
#: One panel's height, inches
HEIGHT_IN = 4.2


def _styled(figure):
    """A figure function drawn and saved under :data:`STYLE` (every text it makes)."""
    @functools.wraps(figure)
    def drawn(*args, **kw):
        with plt.rc_context(STYLE):
            return figure(*args, **kw)
    return drawn


def _figure(ncols: int = 1, width: float = WIDTH_IN, **kw):
    """``plt.subplots(1, ncols)`` of a figure ``width`` inches wide (axes in ``[0]``)."""
    return plt.subplots(1, ncols, figsize=(width, HEIGHT_IN), squeeze=False,
                        layout="constrained", **kw)


def _png(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI, bbox_inches="tight")
    plt.close(fig)
    return buf.getvalue()


def _marks(fmt: str, num: bool) -> str:
    """A plot format for x values that are numbers (``fmt``, markers joined by
    lines) or categories (the markers alone: nothing lies between two categories)."""
    return fmt if num else "".join(c for c in fmt if c not in "-:")


def _spread(x, i: int, n: int, num: bool):
    """Categorical positions ``x`` of series ``i`` of ``n``, side by side (numbers as they are)."""
    return x if num or n == 1 else np.asarray(x, float) + 0.12 * (i - (n - 1) / 2)


def _interval(ax, x, mid, lo, hi, color, num: bool, label=None, alpha: float = 0.15):
    """An interval ``[lo, hi]`` about ``mid``: a band over numbers, error bars on categories."""
    if num:
        ax.fill_between(x, lo, hi, color=color, alpha=alpha, lw=0, label=label)
    else:
        mid, lo, hi = (np.asarray(v, float) for v in (mid, lo, hi))
        ax.errorbar(x, mid, yerr=[mid - lo, hi - mid], fmt="none", ecolor=color, elinewidth=1.5,
                    capsize=5, label=label)


def _numeric(col: pd.Series) -> bool:
    return pd.api.types.is_numeric_dtype(col) and not pd.api.types.is_bool_dtype(col)


def _x(ax, col: pd.Series, label: str):
    ax.set_xlabel(label)
    if _numeric(col):
        vals = np.sort(col.unique())
        if len(vals) > 2 and vals.min() > 0 and vals.max() / vals.min() > 50:
            ax.set_xscale("log")


def effect(frame: pd.DataFrame, column: str, value: str, weight: Optional[str] = None) -> float:
    """How much a swept parameter moves a quantity: the range (max - min) over
    the parameter's values of ``value`` pooled at each (a ratio of sums when
    ``weight`` is given, e.g. successes over samples; else the median)."""
    if column not in frame or frame[column].nunique() < 2:
        return 0.0
    g = frame.groupby(column, sort=True, observed=True)
    v = (g[value].sum() / g[weight].sum().clip(lower=1)) if weight else g[value].median()
    v = v.to_numpy(float)
    v = v[np.isfinite(v)]
    return float(v.max() - v.min()) if v.size else 0.0


def _groups(frame: pd.DataFrame, column: Optional[str], most: int):
    """``[(value or None, rows)]``: one group per value of ``column`` (panels
    or lines; at most ``most`` values, otherwise one group of everything)."""
    if column is not None and 1 < frame[column].nunique() <= most:
        return list(frame.groupby(column, sort=True, observed=True))
    return [(None, frame)]


@_styled
def success_vs_param(summary: pd.DataFrame, column: str, label: str, confidence: float,
                     by: Optional[str] = None, by_label: str = "", facet: Optional[str] = None,
                     facet_label: str = "") -> Optional[bytes]:
    """Pooled success rate against one swept parameter, with a CP band; one line
    per value of a second swept parameter ``by`` (at most 6 values) and one
    panel per value of a third, ``facet`` (at most 4), pooled over everything
    else."""
    s = summary[summary["n"] > 0]
    if s.empty:
        return None
    panels = _groups(s, facet, 4)
    fig, axs = _figure(len(panels), sharey=True)
    num = _numeric(s[column])
    cats = sorted(s[column].unique(), key=str)
    for ax, (fval, panel) in zip(axs[0], panels):
        groups = _groups(panel, by, 6)
        for i, (val, part) in enumerate(groups):
            g = part.groupby(column, sort=True, observed=True).agg(
                n=("n", "sum"), k=("n_success", "sum")).reset_index()
            lo, hi = zip(*(clopper_pearson(int(k), int(n), confidence) for k, n in zip(g["k"], g["n"])))
            x = g[column] if num else np.array([cats.index(v) for v in g[column]])
            x = _spread(x, i, len(groups), num)
            color = f"C{i}"
            name = "success rate" if val is None else f"{by_label or by} = {fmt(val)}"
            _interval(ax, x, g["k"] / g["n"], lo, hi, color, num)
            ax.plot(x, g["k"] / g["n"], _marks("o-", num), color=color, label=name)
        if not num:
            ax.set_xticks(np.arange(len(cats)), [str(v) for v in cats])
            ax.set_xlim(-0.5, len(cats) - 0.5)
        _x(ax, s[column], label)
        ax.set_ylim(-0.02, 1.02)
        ax.grid(alpha=0.3)
        title = f"success against {label}"
        ax.set_title(title if fval is None else f"{facet_label or facet} = {fmt(fval)}")
    axs[0][0].set_ylabel("success rate (pooled over tasks)")
    axs[0][-1].legend(loc="best", title=f"{'bands' if num else 'bars'}: {confidence:.0%} "
                      "Clopper-Pearson")
    if len(panels) > 1:
        fig.suptitle(f"success against {label}", y=1.03)
    return _png(fig)


@_styled
def error_quantiles(summary: pd.DataFrame, column: Optional[str], label: str,
                    eps: float) -> Optional[bytes]:
    """Position error quantiles (q50, q90, q99, max; mm) per value of a swept
    parameter (or per configuration): of each, the worst task's, read from the
    summary table's ``err_pos_m_{q50,q90,q99,max}`` (a study's samples table
    can be larger than memory; the worst task is the one an engineer must
    plan for, and its maximum is the samples' maximum)."""
    names = ("q50", "q90", "q99", "max")
    cols = [f"err_pos_m_{n}" for n in names]
    s = summary[np.isfinite(summary[cols].to_numpy(float)).any(axis=1)]
    if s.empty:
        return None
    key = column or "config_id"
    q = (s.groupby(key, sort=True, observed=True)[cols].max()
         .rename(columns=dict(zip(cols, names))).reset_index())
    fig, axs = _figure()
    ax = axs[0][0]
    num = column is not None and _numeric(q[key])
    x = q[key] if num else np.arange(len(q))
    for i, (name, st) in enumerate((("q50", "o-"), ("q90", "s--"), ("q99", "^:"), ("max", "x-"))):
        ax.plot(_spread(x, i, 4, num), q[name] * 1e3, _marks(st, num), label=name, ms=7)
    ax.axhline(eps * 1e3, color="k", lw=0.8, ls="--", label="pos_eps")
    if not num:
        ax.set_xticks(x, [str(v) for v in q[key]], rotation=20 if len(q) > 6 else 0)
        ax.set_xlim(-0.5, len(q) - 0.5)
    _x(ax, q[key], label if column else "configuration")
    _error_scale(ax, q[["q50", "q90", "q99", "max"]].to_numpy(float) * 1e3, eps * 1e3)
    ax.set_ylabel("final position error (mm)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(ncol=2)
    ax.set_title("position error quantiles (the worst task's)")
    return _png(fig)


def _error_scale(ax, values: np.ndarray, eps: float) -> None:
    """The y scale of errors (never negative): logarithmic when every one is
    above zero, from a little under the smallest; else linear from zero (a
    zero error has no place on a log axis, and a symmetric-log axis shows
    negative ticks that no error reaches)."""
    from matplotlib import ticker

    v = values[np.isfinite(values)]
    if v.size and v.min() > 0:
        ax.set_yscale("log")
        lo = 0.7 * min(v.min(), eps)
        ax.set_ylim(bottom=lo)
        if max(v.max(), eps) / lo < 1e3:   # a decade or two: 1, 2, 5, 10, 20 ... as plain numbers
            ax.yaxis.set_major_locator(ticker.LogLocator(subs=(1.0, 2.0, 5.0)))
            ax.yaxis.set_major_formatter(ticker.FuncFormatter(lambda y, _: f"{y:g}"))
            ax.yaxis.set_minor_formatter(ticker.NullFormatter())
    else:
        ax.set_ylim(bottom=0.0)


@_styled
def failure_modes(summary: pd.DataFrame, labels: list, axis_label: str = "configuration") -> Optional[bytes]:
    """Failure modes per configuration (stacked fractions); ``labels`` name the
    configurations (their swept values), ``axis_label`` says what they are."""
    s = summary[summary["n"] > 0]
    if s.empty:
        return None
    g = s.groupby("config_id", sort=True, observed=True)[[f"n_{m}" for m in FAILURE_MODES]].sum()
    fig, axs = _figure(width=max(WIDTH_IN, 0.45 * len(g) + 3))
    ax = axs[0][0]
    x = np.arange(len(g))
    bottom = np.zeros(len(g))
    tot = np.array(g.sum(axis=1), dtype=float)
    tot[tot == 0] = 1.0
    ax.bar(x, g["n_none"] / tot, bottom=bottom, color=MODE_COLORS["none"], label="success")
    bottom += g["n_none"].to_numpy() / tot
    for m in FAILURE_MODES[1:]:
        v = g[f"n_{m}"].to_numpy() / tot
        if v.any():
            ax.bar(x, v, bottom=bottom, color=MODE_COLORS[m], label=m)
            bottom += v
    ax.set_xticks(x, [labels[int(i)] if int(i) < len(labels) else str(i) for i in g.index],
                  rotation=45 if len(g) > 6 else 0, ha="right" if len(g) > 6 else "center")
    ax.set_xlabel(axis_label)
    ax.set_ylabel("fraction of samples")
    ax.set_ylim(0, 1)
    ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0))
    ax.set_title("outcome of every sample, per configuration")
    return _png(fig)


@_styled
def plan_shape(plans: pd.DataFrame, column: Optional[str], label: str, kind: str,
               by: Optional[str] = None, by_label: str = "") -> Optional[bytes]:
    """Plan length (pushes / tumbles, median and range over tasks) and, for
    pushes, the median total push distance (m) against a swept parameter, one
    line per value of ``by`` (at most 6)."""
    p = plans[plans["planned"]]
    if p.empty:
        return None
    key = column or "config_id"
    num = column is not None and _numeric(p[key])
    cats = sorted(p[key].unique(), key=str)
    n_ax = 2 if kind == "push" else 1
    fig, axs = _figure(n_ax)
    ax_len = axs[0][0]
    groups = _groups(p, by, 6)
    for i, (val, part) in enumerate(groups):
        g = part.groupby(key, sort=True, observed=True)
        xs = np.asarray(list(g.groups)) if num else np.array([cats.index(v) for v in g.groups])
        xs = _spread(xs, i, len(groups), num)
        color = f"C{i}"
        name = "" if val is None else f"{by_label or by} = {fmt(val)}"
        med = g["n_steps"].median().to_numpy(float)
        ax_len.plot(xs, med, _marks("o-", num), color=color,
                    label=name or f"median {'pushes' if kind == 'push' else 'tumbles'}")
        _interval(ax_len, xs, med, g["n_steps"].min().to_numpy(float),
                  g["n_steps"].max().to_numpy(float), color, num, alpha=0.12)
        if kind == "push":
            axs[0][1].plot(xs, g["total_distance_m"].median().to_numpy(), _marks("s-", num),
                           color=color, label=name or "median push distance")
    what = "band" if num else "bars"
    ax_len.set_ylabel(f"{'pushes' if kind == 'push' else 'tumbles'} per plan\n"
                      f"(median; {what}: min-max over tasks)")
    ax_len.set_ylim(bottom=0)
    ax_len.set_title("plan length")
    if kind == "push":
        axs[0][1].set_ylabel("total push distance (m,\nmedian over tasks)")
        axs[0][1].set_ylim(bottom=0)
        axs[0][1].set_title("push distance")
    for ax in axs[0]:
        if not num:
            ax.set_xticks(np.arange(len(cats)), [str(v) for v in cats],
                          rotation=20 if len(cats) > 6 else 0)
            ax.set_xlim(-0.5, len(cats) - 0.5)
        _x(ax, p[key], label if column else "configuration")
        ax.grid(alpha=0.3)
        ax.legend(loc="best")
    return _png(fig)


@_styled
def solvable_fraction(plans: pd.DataFrame, column: str, label: str,
                      confidence: float) -> Optional[bytes]:
    """Fraction of tasks with a verified plan against a swept parameter, with a CP band."""
    if plans.empty:
        return None
    g = plans.groupby(column, sort=True, observed=True)["planned"].agg(["sum", "count"]).reset_index()
    lo, hi = zip(*(clopper_pearson(int(k), int(n), confidence) for k, n in zip(g["sum"], g["count"])))
    fig, axs = _figure()
    ax = axs[0][0]
    num = _numeric(g[column])
    x = g[column] if num else np.arange(len(g))
    rate = g["sum"] / g["count"]
    _interval(ax, x, rate, lo, hi, "tab:purple", num, label=f"{confidence:.0%} Clopper-Pearson",
              alpha=0.2)
    ax.plot(x, rate, _marks("o-", num), color="tab:purple", label="solvable fraction")
    if not num:
        ax.set_xticks(x, [str(v) for v in g[column]], rotation=20 if len(g) > 6 else 0)
        ax.set_xlim(-0.5, len(g) - 0.5)
    _x(ax, g[column], label)
    ax.set_ylim(-0.02, 1.02)
    ax.set_ylabel("tasks with a verified plan")
    ax.grid(alpha=0.3)
    ax.legend()
    ax.set_title(f"solvable fraction against {label}")
    return _png(fig)


@_styled
def bound_vs_monte_carlo(summary: pd.DataFrame, column: Optional[str], label: str) -> Optional[bytes]:
    """Analytic bounds (first order; the paper's eq. 6) beside the Monte-Carlo
    maximum of the position error, against a swept parameter."""
    s = summary[summary["n"] > 0]
    if s.empty:
        return None
    key = column or "config_id"
    g = s.groupby(key, sort=True, observed=True)
    num = column is not None and _numeric(s[key])
    xs = np.asarray(list(g.groups)) if num else np.arange(g.ngroups)
    fig, axs = _figure()
    ax = axs[0][0]
    series = (("emp_max_pos_in_model_m", "o-", "Monte-Carlo max (in the bound's model)"),
              ("bound_position_m", "s--", "first-order bound"),
              ("paper_bound_position_m", "^:", "Marigo-Bicchi eq. (6)"))
    vals = {col: g[col].max().to_numpy(float) * 1e3 for col, _, _ in series}
    shown = np.concatenate([v[np.isfinite(v) & (v > 0)] for c, v in vals.items()
                            if c != "paper_bound_position_m"] or [np.zeros(0)])
    if not shown.size and not np.isfinite(vals["paper_bound_position_m"]).any():
        plt.close(fig)
        return None
    lo = shown.min() / 30 if shown.size else None
    for col, st, lab in series:
        st = _marks(st, num)
        v = vals[col]
        ok = np.isfinite(v) & (v > 0)
        if not ok.any():
            continue
        x = np.asarray(xs)[ok]
        if col == "paper_bound_position_m" and lo is not None and (v[ok] < lo).any():
            # eq. (6) in metres can collapse far below anything measurable: mark it at the
            # bottom of the axis with its value instead of stretching the axis to 1e-100
            below = v[ok] < lo
            if (~below).any():
                ax.plot(x[~below], v[ok][~below], st, color="tab:green", label=lab)
            ax.plot(x[below], np.full(below.sum(), lo), "v", color="tab:green",
                    label=f"{lab}: below the axis (down to {v[ok].min():.1e} mm)")
            continue
        ax.plot(x, v[ok], st, label=lab)
    if lo is not None:
        ax.set_ylim(bottom=lo * 0.7)
    if not num:
        ax.set_xticks(xs, [str(v) for v in g.groups], rotation=20 if g.ngroups > 6 else 0)
        ax.set_xlim(-0.5, g.ngroups - 0.5)
    _x(ax, s[key], label if column else "configuration")
    ax.set_yscale("log")
    ax.set_ylabel("position error (mm)")
    ax.grid(alpha=0.3, which="both")
    ax.legend()
    ax.set_title("analytic bounds and the Monte-Carlo maximum")
    return _png(fig)


def fmt(v) -> str:
    """A value for the report's tables."""
    if isinstance(v, (float, np.floating)):
        return "-" if not math.isfinite(v) else f"{v:.4g}"
    return str(v)
