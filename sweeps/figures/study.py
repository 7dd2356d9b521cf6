"""Figures of a parameter study (for ``report.html``): each function takes the
run's tables (pandas frames) and returns PNG bytes, or None when the figure
does not apply.

Success rates are pooled over a study's tasks and over the other swept
parameters at each value of the one on the x axis, with two-sided
Clopper-Pearson bands at the study's confidence.
"""
from __future__ import annotations

import io
import math
from typing import Optional

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from robustness import clopper_pearson, FAILURE_MODES
from robustness import failure_modes as _modes   # the name failure_modes is this module's figure

MODE_COLORS = _modes.COLOURS   # one home for every mode's name, colour and description


def _png(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    return buf.getvalue()


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
    fig, axs = plt.subplots(1, len(panels), figsize=(5.2 + 3.6 * (len(panels) - 1), 3.4),
                            sharey=True, squeeze=False)
    num = _numeric(s[column])
    cats = sorted(s[column].unique(), key=str)
    for ax, (fval, panel) in zip(axs[0], panels):
        for i, (val, part) in enumerate(_groups(panel, by, 6)):
            g = part.groupby(column, sort=True, observed=True).agg(
                n=("n", "sum"), k=("n_success", "sum")).reset_index()
            lo, hi = zip(*(clopper_pearson(int(k), int(n), confidence) for k, n in zip(g["k"], g["n"])))
            x = g[column] if num else np.array([cats.index(v) for v in g[column]])
            color = f"C{i}"
            name = "success rate" if val is None else f"{by_label or by} = {fmt(val)}"
            ax.fill_between(x, lo, hi, color=color, alpha=0.15, lw=0)
            ax.plot(x, g["k"] / g["n"], "o-", color=color, label=name)
        if not num:
            ax.set_xticks(np.arange(len(cats)), [str(v) for v in cats], rotation=20)
        _x(ax, s[column], label)
        ax.set_ylim(-0.02, 1.02)
        ax.grid(alpha=0.3)
        title = f"success against {label}"
        ax.set_title(title if fval is None else f"{facet_label or facet} = {fmt(fval)}", fontsize=10)
    axs[0][0].set_ylabel("success rate (pooled over tasks)")
    axs[0][-1].legend(loc="best", fontsize=8, title=f"bands: {confidence:.0%} Clopper-Pearson",
                      title_fontsize=7)
    if len(panels) > 1:
        fig.suptitle(f"success against {label}", fontsize=10, y=1.03)
    return _png(fig)


def error_quantiles(samples: pd.DataFrame, column: Optional[str], label: str,
                    eps: float) -> Optional[bytes]:
    """Position error quantiles (q50, q90, q99, max; mm) per value of a swept
    parameter (or per configuration), successes and failures together."""
    s = samples[np.isfinite(samples["err_pos_m"])]
    if s.empty:
        return None
    key = column or "config_id"
    g = s.groupby(key, sort=True, observed=True)["err_pos_m"]
    q = pd.DataFrame({name: g.quantile(v) for name, v in
                      (("q50", 0.5), ("q90", 0.9), ("q99", 0.99), ("max", 1.0))}).reset_index()
    fig, ax = plt.subplots(figsize=(5.2, 3.4))
    num = column is not None and _numeric(q[key])
    x = q[key] if num else np.arange(len(q))
    for name, st in (("q50", "o-"), ("q90", "s--"), ("q99", "^:"), ("max", "x-")):
        ax.plot(x, q[name] * 1e3, st, label=name)
    ax.axhline(eps * 1e3, color="k", lw=0.8, ls="--", label="pos_eps")
    if not num:
        ax.set_xticks(x, [str(v) for v in q[key]], rotation=20)
    _x(ax, q[key], label if column else "configuration")
    ax.set_yscale("symlog", linthresh=max(eps * 1e3 / 10, 1e-6))
    ax.set_ylabel("final position error (mm)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, ncol=2)
    ax.set_title("position error quantiles", fontsize=10)
    return _png(fig)


def failure_modes(summary: pd.DataFrame, labels: list, axis_label: str = "configuration") -> Optional[bytes]:
    """Failure modes per configuration (stacked fractions); ``labels`` name the
    configurations (their swept values), ``axis_label`` says what they are."""
    s = summary[summary["n"] > 0]
    if s.empty:
        return None
    g = s.groupby("config_id", sort=True, observed=True)[[f"n_{m}" for m in FAILURE_MODES]].sum()
    fig, ax = plt.subplots(figsize=(max(5.2, 0.35 * len(g) + 2), 3.4))
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
                  rotation=45 if len(g) > 6 else 0, ha="right" if len(g) > 6 else "center",
                  fontsize=7)
    ax.set_xlabel(axis_label, fontsize=8)
    ax.set_ylabel("fraction of samples")
    ax.set_ylim(0, 1)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    ax.set_title("outcome of every sample, per configuration", fontsize=10)
    return _png(fig)


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
    fig, axs = plt.subplots(1, n_ax, figsize=(5.2 + 3.6 * (n_ax - 1), 3.4), squeeze=False)
    ax_len = axs[0][0]
    for i, (val, part) in enumerate(_groups(p, by, 6)):
        g = part.groupby(key, sort=True, observed=True)
        xs = np.asarray(list(g.groups)) if num else np.array([cats.index(v) for v in g.groups])
        color = f"C{i}"
        name = "" if val is None else f"{by_label or by} = {fmt(val)}"
        ax_len.plot(xs, g["n_steps"].median().to_numpy(), "o-", color=color,
                    label=name or f"median {'pushes' if kind == 'push' else 'tumbles'}")
        ax_len.fill_between(xs, g["n_steps"].min().to_numpy(), g["n_steps"].max().to_numpy(),
                            color=color, alpha=0.12, lw=0)
        if kind == "push":
            axs[0][1].plot(xs, g["total_distance_m"].median().to_numpy(), "s-", color=color,
                           label=name or "median push distance")
    ax_len.set_ylabel(f"{'pushes' if kind == 'push' else 'tumbles'} per plan "
                      "(median; band: min-max over tasks)", fontsize=8)
    ax_len.set_title("plan length", fontsize=10)
    if kind == "push":
        axs[0][1].set_ylabel("total push distance (m, median over tasks)", fontsize=8)
        axs[0][1].set_ylim(bottom=0)
        axs[0][1].set_title("push distance", fontsize=10)
    for ax in axs[0]:
        if not num:
            ax.set_xticks(np.arange(len(cats)), [str(v) for v in cats], rotation=20)
        _x(ax, p[key], label if column else "configuration")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    return _png(fig)


def solvable_fraction(plans: pd.DataFrame, column: str, label: str,
                      confidence: float) -> Optional[bytes]:
    """Fraction of tasks with a verified plan against a swept parameter, with a CP band."""
    if plans.empty:
        return None
    g = plans.groupby(column, sort=True, observed=True)["planned"].agg(["sum", "count"]).reset_index()
    lo, hi = zip(*(clopper_pearson(int(k), int(n), confidence) for k, n in zip(g["sum"], g["count"])))
    fig, ax = plt.subplots(figsize=(5.2, 3.4))
    num = _numeric(g[column])
    x = g[column] if num else np.arange(len(g))
    ax.fill_between(x, lo, hi, color="tab:purple", alpha=0.2, lw=0,
                    label=f"{confidence:.0%} Clopper-Pearson")
    ax.plot(x, g["sum"] / g["count"], "o-", color="tab:purple", label="solvable fraction")
    if not num:
        ax.set_xticks(x, [str(v) for v in g[column]], rotation=20)
    _x(ax, g[column], label)
    ax.set_ylim(-0.02, 1.02)
    ax.set_ylabel("tasks with a verified plan")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(f"solvable fraction against {label}", fontsize=10)
    return _png(fig)


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
    fig, ax = plt.subplots(figsize=(5.2, 3.4))
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
        ax.set_xticks(xs, [str(v) for v in g.groups], rotation=20)
    _x(ax, s[key], label if column else "configuration")
    ax.set_yscale("log")
    ax.set_ylabel("position error (mm)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)
    ax.set_title("analytic bounds and the Monte-Carlo maximum", fontsize=10)
    return _png(fig)


def fmt(v) -> str:
    """A value for the report's tables."""
    if isinstance(v, (float, np.floating)):
        return "-" if not math.isfinite(v) else f"{v:.4g}"
    return str(v)
