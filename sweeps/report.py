"""``report.html`` of a study: one self-contained page (figures embedded as
PNG data URIs, no network) with what was run, the figures of
:mod:`sweeps.figures.study` and a table per configuration.
"""
from __future__ import annotations

import base64
import html
import pathlib

import jinja2

from robustness import model_for
from sweeps.parquet import atomic_write

TEMPLATE = jinja2.Template("""<!doctype html>
<html lang="en"><head><meta charset="utf-8">
<title>nudge study {{ name }} ({{ run_id }})</title>
<style>
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1150px; color: #222; }
h1 { font-size: 1.5em; } h2 { font-size: 1.15em; margin-top: 1.6em; border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; font-size: 0.82em; margin: 0.6em 0; }
td, th { border: 1px solid #ccc; padding: 2px 6px; text-align: right; }
th { background: #f3f3f3; } td.l, th.l { text-align: left; }
.figs { display: flex; flex-wrap: wrap; gap: 12px; } .figs img { max-width: 540px; }
pre { background: #f7f7f7; padding: 0.8em; font-size: 0.8em; overflow-x: auto; }
.note { color: #555; font-size: 0.9em; }
</style></head><body>
<h1>nudge study <code>{{ name }}</code></h1>
<p>run <code>{{ run_id }}</code> &middot; {{ kind }} study &middot; part <code>{{ part }}</code>
&middot; model <code>{{ model }}</code> &middot; {{ n_configs }} configuration(s) &times; {{ n_tasks }} task(s)
&middot; {{ samples }} samples per (configuration, task) &middot; seed {{ seed }}</p>
<p class="note">Success: final position within {{ pos_eps }} m and orientation within {{ theta_eps }} rad
of the goal{% if kind == "tumble" %}, on the goal face{% endif %}. Rates are pooled over tasks;
bands are two-sided Clopper-Pearson intervals at {{ confidence }} confidence.
Tables: <code>pd.read_parquet("{{ root }}/summary")</code> (also <code>samples</code>, <code>plans</code>).</p>
{% for section, figs in sections %}
<h2>{{ section }}</h2><div class="figs">
{% for title, png in figs %}<figure><img alt="{{ title }}" src="data:image/png;base64,{{ png }}"></figure>{% endfor %}
</div>{% endfor %}
<h2>Configurations</h2>
<table><tr>{% for h in header %}<th{% if loop.index0 == 0 %} class="l"{% endif %}>{{ h }}</th>{% endfor %}</tr>
{% for r in rows %}<tr>{% for c in r %}<td{% if loop.index0 == 0 %} class="l"{% endif %}>{{ c }}</td>{% endfor %}</tr>
{% endfor %}</table>
<h2>Config as run</h2><pre>{{ config }}</pre>
</body></html>
""", autoescape=True)


def write_report(store, design) -> pathlib.Path:
    """Write ``report.html`` into the run folder; returns its path."""
    from sweeps.figures import study as figs
    from sweeps.work import swept_fields

    summary, plans, samples = store.read("summary"), store.read("plans"), store.read("samples")
    top = design.top
    kind = top.kind
    for df in (summary, plans, samples):
        if "config_id" in df:
            df["config_id"] = df["config_id"].astype(int)
    cols = [f.name for f in swept_fields(design)]
    labels = [", ".join(figs.fmt(pt[p]) for p in design.paths) or f"config {i}"
              for i, pt in enumerate(design.points)]
    long_labels = [", ".join(f"{p}={figs.fmt(pt[p])}" for p in design.paths) or f"config {i}"
                   for i, pt in enumerate(design.points)]
    axis_label = ", ".join(design.paths) or "configuration"
    conf = top.required.confidence
    sections = []
    axes = list(zip(design.paths, cols)) or [(None, None)]
    if kind == "push":
        sweep = [("Success rate", [(f"success vs {p}", figs.success_vs_param(
                      summary, c, p, conf, *_by_effect(summary, axes, p))) for p, c in axes if c]),
                 ("Errors", [(f"errors vs {p or 'configuration'}",
                              figs.error_quantiles(samples, c, p or "", top.eps.pos_eps_m))
                             for p, c in axes]),
                 ("Failure modes", [("failure modes", figs.failure_modes(summary, labels, axis_label))]),
                 ("Plans", [(f"plan length vs {p or 'configuration'}",
                             figs.plan_shape(plans, c, p or "", kind,
                                             *_by_effect(plans, axes, p, "total_distance_m")[:2]))
                            for p, c in axes])]
    else:
        sweep = [("Solvable fraction", [(f"solvable vs {p}", figs.solvable_fraction(plans, c, p, conf))
                                        for p, c in axes if c]),
                 ("Tumble count", [(f"tumbles vs {p or 'configuration'}",
                                    figs.plan_shape(plans, c, p or "", kind)) for p, c in axes]),
                 ("Bounds and Monte Carlo", [(f"bounds vs {p or 'configuration'}",
                                              figs.bound_vs_monte_carlo(summary, c, p or ""))
                                             for p, c in axes]),
                 ("Success rate", [(f"success vs {p}", figs.success_vs_param(
                     summary, c, p, conf, *_by_effect(summary, axes, p))) for p, c in axes if c]),
                 ("Failure modes", [("failure modes", figs.failure_modes(summary, labels, axis_label))])]
    for title, items in sweep:
        pngs = [(t, base64.b64encode(png).decode()) for t, png in items if png]
        if pngs:
            sections.append((title, pngs))
    header, rows = _config_rows(summary, plans, design, long_labels)
    page = TEMPLATE.render(
        name=design.name, run_id=design.run_id, kind=kind, part=design.part(0).name,
        model=model_for(top.model, kind), n_configs=len(design.configs),
        n_tasks=len(design.tasks(0)), samples=top.samples, seed=top.seed,
        pos_eps=top.eps.pos_eps_m, theta_eps=f"{top.eps.theta_eps_rad:.4g}", confidence=conf,
        root=html.escape(str(store.root)), sections=sections, header=header, rows=rows,
        config=design.text)
    path = store.root / "report.html"
    atomic_write(path, lambda fh: fh.write(page), mode="w")
    return path


def _by_effect(frame, axes, path, value: str = "n_success", weight=None):
    """``(by, by_label, facet, facet_label)`` for a figure against ``path``:
    the other swept axes ranked by their effect on ``value``
    (:func:`sweeps.figures.study.effect`; success pools ``n_success`` over
    ``n``), the largest drawn as lines, the next as panels, so that an axis that
    decides success alone does not flatten every other curve."""
    from sweeps.figures.study import effect

    if value == "n_success":
        weight = "n"
        frame = frame[frame["n"] > 0] if "n" in frame else frame
    ranked = sorted(((effect(frame, c, value, weight), i, p, c) for i, (p, c) in enumerate(axes)
                     if p != path and c is not None and c in frame),
                    key=lambda t: (-t[0], t[1]))
    out = []
    for _, _, p, c in ranked[:2]:
        out += [c, p]
    return tuple(out + [None, ""] * (2 - len(ranked[:2])))


def _config_rows(summary, plans, design, labels):
    from sweeps.figures.study import fmt

    header = ["configuration", "tasks planned", "samples", "success rate", "worst one-sided CP low",
              "median plan steps", "worst q99 error (mm)", "dominant failure"]
    rows = []
    for cid, label in enumerate(labels):
        s = summary[summary["config_id"] == cid] if not summary.empty else summary
        p = plans[plans["config_id"] == cid] if not plans.empty else plans
        n = int(s["n"].sum()) if len(s) else 0
        k = int(s["n_success"].sum()) if len(s) else 0
        modes = s["dominant_failure_mode"].value_counts() if len(s) else None
        modes = modes[modes.index != "none"] if modes is not None else []
        rows.append([label, f"{int(p['planned'].sum())}/{len(p)}" if len(p) else "-", n,
                     fmt(k / n) if n else "-",
                     fmt(s["ci_low_one_sided"].min()) if len(s) else "-",
                     fmt(float(p.loc[p["planned"], "n_steps"].median())) if len(p) and p["planned"].any() else "-",
                     fmt(float(s["err_pos_m_q99"].max()) * 1e3) if len(s) and "err_pos_m_q99" in s else "-",
                     modes.index[0] if len(modes) else "none"])
    return header, rows
