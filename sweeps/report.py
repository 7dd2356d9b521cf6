"""``report.html`` of a study: one self-contained page (figures embedded as
PNG data URIs, no network) with what was run, the figures of
:mod:`sweeps.figures.study` and a table per configuration.
"""
from __future__ import annotations

import base64
import html
import math
import pathlib

import jinja2
import pandas as pd

from robustness import model_for
from sweeps.parquet import atomic_write

#: the style both reports share
STYLE = """body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1150px; color: #222; }
h1 { font-size: 1.5em; } h2 { font-size: 1.15em; margin-top: 1.6em; border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; font-size: 0.82em; margin: 0.6em 0; }
td, th { border: 1px solid #ccc; padding: 2px 6px; text-align: right; }
th { background: #f3f3f3; } td.l, th.l { text-align: left; }
pre { background: #f7f7f7; padding: 0.8em; font-size: 0.8em; overflow-x: auto; }
.note { color: #555; font-size: 0.9em; }
.advice { background: #f4f4fa; border: 1px solid #aac; padding: 0.6em; }
"""

TEMPLATE = jinja2.Template("""<!doctype html>
<html lang="en"><head><meta charset="utf-8">
<title>nudge study {{ name }} ({{ run_id }})</title>
<style>
{{ style | safe }}.figs figure { margin: 0.8em 0; } .figs img { width: 100%; height: auto; }
</style></head><body>
<h1>nudge study <code>{{ name }}</code></h1>
<p>run <code>{{ run_id }}</code> &middot; {{ kind }} study &middot; part <code>{{ part }}</code>
from <code>{{ part_source }}</code>
&middot; model <code>{{ model }}</code> &middot; {{ n_configs }} configuration(s) &times; {{ n_tasks }} task(s)
&middot; {{ samples }} samples per (configuration, task) &middot; seed {{ seed }}</p>
<p class="note">Success: final position within {{ pos_eps }} m and orientation within {{ theta_eps }} rad
of the goal{% if kind == "tumble" %}, on the goal face{% endif %}. Rates are pooled over tasks;
bands are two-sided Clopper-Pearson intervals at {{ confidence }} confidence.
Tables: <code>pd.read_parquet("{{ root }}/summary")</code> (also <code>samples</code>, <code>plans</code>).</p>
<h2>Recommendation</h2><p class="advice">{{ advice }}</p>
{% for section, figs in sections %}
<h2>{{ section }}</h2><div class="figs">
{% for title, png in figs %}<figure><img alt="{{ title }}" src="data:image/png;base64,{{ png }}"></figure>{% endfor %}
</div>{% if section == "Failure modes" and modes %}<p class="note">{% for name, text in modes %}<code>{{ name }}</code>: {{ text }}{% if not loop.last %}; {% endif %}{% endfor %}.</p>{% endif %}{% endfor %}
{% if designs %}<h2>Tolerance design</h2>
<p class="note">Per configuration and task: all tolerance axes together, as far toward their
one-axis limits as still certifies, verified on fresh draws (table <code>design</code>: every
axis's loosest value alone, the failures each removes).</p>
<table><tr><th class="l">configuration</th><th class="l">task</th><th class="l">tighten first</th>
<th class="l">joint design and what was shown</th></tr>
{% for r in designs %}<tr><td class="l">{{ r.config }}</td><td class="l">{{ r.task }}</td>
<td class="l">{{ r.first }}</td><td class="l">{{ r.drawing }}</td></tr>{% endfor %}</table>{% endif %}
<h2>Configurations</h2>
<table><tr>{% for h in header %}<th{% if loop.index0 == 0 %} class="l"{% endif %}>{{ h }}</th>{% endfor %}</tr>
{% for r in rows %}<tr>{% for c in r %}<td{% if loop.index0 == 0 %} class="l"{% endif %}>{{ c }}</td>{% endfor %}</tr>
{% endfor %}</table>
<h2>Config as run</h2><pre>{{ config }}</pre>
</body></html>
""", autoescape=True)


def _modes_seen(summary: pd.DataFrame) -> list:
    """``[(name, description)]`` of the failure modes some sample of the summary
    had (success excluded), in table order."""
    from robustness import FAILURE_MODE_TABLE

    return [(m.name, m.description) for m in FAILURE_MODE_TABLE[1:]
            if f"n_{m.name}" in summary and summary[f"n_{m.name}"].sum() > 0]


def write_report(store, design) -> pathlib.Path:
    """Write ``report.html`` into the run folder; returns its path."""
    from sweeps.figures import study as figs
    from sweeps.work import swept_fields

    top = design.top
    kind = top.kind
    cols = [f.name for f in swept_fields(design)]
    # the summary and plans only: a study's samples table can be larger than memory
    summary, plans = store.read("summary"), store.read("plans")
    for df in (summary, plans):
        if "config_id" in df:
            df["config_id"] = df["config_id"].astype(int)
    labels = [", ".join(figs.fmt(pt[p]) for p in design.paths) or f"config {i}"
              for i, pt in enumerate(design.points)]
    long_labels = config_labels(design)
    axis_label = ", ".join(design.paths) or "configuration"
    conf = top.required.confidence
    sections = []
    axes = list(zip(design.paths, cols)) or [(None, None)]
    if kind == "push":
        sweep = [("Success rate", [(f"success vs {p}", figs.success_vs_param(
                      summary, c, p, conf, *_by_effect(summary, axes, p))) for p, c in axes if c]),
                 ("Errors", [(f"errors vs {p or 'configuration'}",
                              figs.error_quantiles(summary, c, p or "", top.eps.pos_eps_m))
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
    dz = store.read("design")
    designs = []
    if not dz.empty:
        dz["config_id"] = dz["config_id"].astype(int)
        for (cid, task), g in dz.groupby(["config_id", "task"], sort=True):
            g = g.sort_values("rank")
            lead = g.iloc[0]
            if lead.failures_removed > 0:
                first = (f"{lead.axis} (made perfect, {lead.failures_removed:.1%} of the samples "
                         "no longer fail)")
            else:
                first = "nothing fails as configured" + (
                    f"; least headroom: {lead.axis} (certifies up to {lead.scale:.3g}x its "
                    "configured value)" if lead.scale == lead.scale else "")
            designs.append(dict(config=long_labels[cid], task=task, first=first,
                                drawing=lead.drawing))
    page = TEMPLATE.render(
        name=design.name, run_id=design.run_id, kind=kind, part=design.part(0).name,
        part_source=design.part(0).source_label,
        model=model_for(top.model, kind), n_configs=len(design.configs),
        n_tasks=len(design.tasks(0)), samples=top.samples, seed=top.seed,
        pos_eps=top.eps.pos_eps_m, theta_eps=f"{top.eps.theta_eps_rad:.4g}", confidence=conf,
        root=html.escape(str(store.root)), sections=sections, header=header, rows=rows,
        designs=designs, config=design.text, style=STYLE, modes=_modes_seen(summary),
        advice=recommendation(summary, plans, design))
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


def config_stats(summary: pd.DataFrame, plans: pd.DataFrame, cid: int) -> dict:
    """One configuration's figures over its tasks (the one home of what the run's
    table, the report's table and the recommendation show): samples ``n``,
    successes ``k``, tasks ``planned`` of ``tasks``, the tasks' one-sided lower
    bounds ``lows`` (NaN dropped), the median plan ``steps`` and the worst q99
    position error ``q99`` (None where there is none), the dominant failure
    ``mode`` (``none`` when nothing failed)."""
    s = summary[summary["config_id"].astype(int) == cid] if not summary.empty else summary
    p = plans[plans["config_id"].astype(int) == cid] if not plans.empty else plans
    planned = int(p["planned"].sum()) if len(p) else 0
    modes = s["dominant_failure_mode"].value_counts() if len(s) else pd.Series(dtype=int)
    modes = modes[modes.index != "none"]
    return dict(n=int(s["n"].sum()) if len(s) else 0,
                k=int(s["n_success"].sum()) if len(s) else 0,
                planned=planned, tasks=len(p),
                lows=s["ci_low_one_sided"].dropna() if len(s) else pd.Series(dtype=float),
                n_summaries=len(s),
                steps=float(p.loc[p["planned"], "n_steps"].median()) if planned else None,
                q99=(float(s["err_pos_m_q99"].max()) if len(s) and "err_pos_m_q99" in s
                     else None),
                mode=modes.index[0] if len(modes) else "none")


def config_labels(design) -> list:
    """``path=value, ...`` of every configuration (``config i`` without swept paths)."""
    from sweeps.figures.study import fmt

    return [", ".join(f"{p}={fmt(pt[p])}" for p in design.paths) or f"config {i}"
            for i, pt in enumerate(design.points)]


def recommendation(summary: pd.DataFrame, plans: pd.DataFrame, design) -> str:
    """Which configuration to use, in one sentence: the configurations that meet
    the requirement (every task planned, each task's one-sided Clopper-Pearson
    lower bound at least ``required.probability``), or, when none does, that
    none does and the best one's figures.  Best: every task planned, then the
    highest worst-task lower bound, then the success rate, then the shortest
    median plan."""
    req = design.top.required
    if summary.empty:
        return "no configuration was evaluated"
    labels = config_labels(design)
    ranked = []
    for cid in range(len(design.configs)):
        c = config_stats(summary, plans, cid)
        lows, tasks = c["lows"], c["tasks"]
        low = float(lows.min()) if len(lows) == c["n_summaries"] and len(lows) else -1.0
        meets = (tasks > 0 and c["planned"] == tasks and len(lows) == tasks
                 and low >= req.probability)
        ranked.append(dict(cid=cid, meets=meets, planned=c["planned"], tasks=tasks, low=low,
                           rate=c["k"] / c["n"] if c["n"] else 0.0,
                           steps=math.inf if c["steps"] is None else c["steps"], mode=c["mode"]))
    ranked.sort(key=lambda r: (not r["meets"], -(r["planned"] == r["tasks"]), -r["low"],
                               -r["rate"], r["steps"]))
    best = ranked[0]
    need = f"P(success) >= {req.probability:g} at {req.confidence:.0%} confidence on every task"
    what = (f"configuration {best['cid']} ({labels[best['cid']]}): worst task's lower bound "
            f"{max(best['low'], 0.0):.3f}, success {best['rate']:.3f}")
    n_meet = sum(r["meets"] for r in ranked)
    if n_meet:
        return (f"use {what}; {n_meet} of {len(ranked)} configuration(s) meet {need}, this one "
                "with the highest lower bound")
    tail = (f"; {best['tasks'] - best['planned']} of its {best['tasks']} task(s) unplanned"
            if best["planned"] < best["tasks"] else "")
    return (f"no configuration meets {need}; the best is {what}{tail}, dominant failure "
            f"{best['mode']} (more samples, a fence that grips better, a measured support or "
            "robust synthesis may close the gap: nudge certify prints what to try)")


def _config_rows(summary, plans, design, labels):
    from sweeps.figures.study import fmt

    header = ["configuration", "tasks planned", "samples", "success rate", "worst one-sided CP low",
              "median plan steps", "worst q99 error (mm)", "dominant failure"]
    rows = []
    for cid, label in enumerate(labels):
        c = config_stats(summary, plans, cid)
        n = c["n"]
        rows.append([label, f"{c['planned']}/{c['tasks']}" if c["tasks"] else "-", n,
                     fmt(c["k"] / n) if n else "-",
                     fmt(c["lows"].min()) if c["n_summaries"] else "-",
                     fmt(c["steps"]) if c["steps"] is not None else "-",
                     fmt(c["q99"] * 1e3) if c["q99"] is not None else "-",
                     c["mode"]])
    return header, rows


CERTIFY_TEMPLATE = jinja2.Template("""<!doctype html>
<html lang="en"><head><meta charset="utf-8">
<title>nudge certification {{ part }} ({{ run_id }})</title>
<style>
{{ style | safe }}h3 { font-size: 1.0em; }
.drawing { background: #eef6ee; border: 1px solid #9c9; padding: 0.6em; font-family: monospace; }
.drawing.no { background: #fbeeee; border-color: #c99; }
td.bad { background: #fbeeee; color: #900; font-weight: bold; }
</style></head><body>
<h1>nudge certification of <code>{{ part }}</code></h1>
<p>part from <code>{{ part_source }}</code>{% if part_cad %}: {{ part_cad }}{% endif %}</p>
<p>run <code>{{ run_id }}</code> &middot; tables: <code>pd.read_parquet("{{ root }}/certificates")</code>
(also <code>candidates</code>, <code>design</code>, <code>samples</code>, <code>plans</code>).</p>
<h2>Certificates</h2>
<table><tr><th class="l">task</th><th class="l">verdict</th><th>n</th><th>success</th><th>CP low</th>
<th class="l">selection</th><th class="l">MuJoCo</th></tr>
{% for c in certs %}<tr><td class="l">{{ c.task }}</td><td class="l">{{ c.verdict }}</td><td>{{ c.n }}</td>
<td>{{ c.rate }}</td><td>{{ c.low }}</td><td class="l">{{ c.selection }}</td>
<td class="l{% if c.disagree %} bad{% endif %}">{{ c.physics }}</td></tr>
<tr><td></td><td class="l" colspan="6">{{ c.claim }}{% if c.physics_line %}<br>{{ c.physics_line }}{% endif %}</td></tr>{% endfor %}</table>
{% for t in synth %}<h3>Robust synthesis: {{ t.task }}</h3>
<p class="note">{{ t.n }} candidates on the same {{ t.draws }} selection draws ({{ t.model }} model);
the ten with the highest lower bound, and the default plan. Bounds here are on the selection draws
(the chosen one's is optimistic); the certificate above is on fresh draws.</p>
<table><tr><th>#</th><th class="l">candidate</th><th>successes</th><th>CP low</th><th>distance m</th>
<th>steps</th><th>first-order bound mm</th><th class="l"></th></tr>
{% for r in t.rows %}<tr><td>{{ r.candidate }}</td><td class="l">{{ r.label }}</td><td>{{ r.k }}</td>
<td>{{ r.low }}</td><td>{{ r.dist }}</td><td>{{ r.pushes }}</td><td>{{ r.bound }}</td><td class="l">{{ r.tag }}</td></tr>{% endfor %}
</table>{% endfor %}
{% for t in design %}<h2>Tolerance design: {{ t.task }}</h2>
<p class="drawing{% if not t.certified %} no{% endif %}">{{ t.drawing }}</p>
<p class="note">One axis at a time, the others as configured: the loosest value whose one-sided
Clopper-Pearson lower bound of success at {{ t.confidence }} confidence still reaches {{ t.p }}
(bisection on the same {{ t.n }} design draws, {{ t.model }} model). {% if t.n_fresh %}The line above is all axes
together, {{ t.t }} of the way from {{ t.basis }} to those limits, verified on {{ t.n_fresh }} fresh
draws.{% else %}No joint design is stated: none certifies on the design draws, not even every axis
nearly perfect.{% endif %} Values in metres, radians, fractions (relative push distance) and friction coefficients. Failures with every axis
perfect: {{ t.base }} (what no axis covers, e.g. the support).</p>
<table><tr><th>rank</th><th class="l">axis</th><th class="l">fields</th><th class="l">configured</th>
<th class="l">loosest alone</th><th>certified as configured</th><th>failure rate</th>
<th>without this axis</th><th>this axis alone</th><th class="l">joint design</th></tr>
{% for r in t.rows %}<tr><td>{{ r.rank }}</td><td class="l">{{ r.axis }}</td><td class="l">{{ r.fields }}</td>
<td class="l">{{ r.configured }}</td><td class="l">{{ r.loosest }}</td><td>{{ r.ok }}</td>
<td>{{ r.f }}</td><td>{{ r.fw }}</td><td>{{ r.fa }}</td><td class="l">{{ r.joint }}</td></tr>{% endfor %}
</table>{% endfor %}
<h2>Config as run</h2><pre>{{ config }}</pre>
</body></html>
""", autoescape=True)


def _values(v) -> str:
    return ", ".join("-" if x != x else f"{x:.4g}" for x in v)


def _physics_cell(c) -> dict:
    """A certificate's MuJoCo confirmation for the report (``physics_*`` columns;
    the sentence is the note's)."""
    n = int(getattr(c, "physics_n_samples", 0) or 0)
    if not n:
        return dict(physics="-", disagree=False, physics_line="")
    agrees = getattr(c, "physics_agrees", None)
    line = next((x for x in str(c.note or "").split("; ") if x.startswith("MuJoCo on")), "")
    return dict(physics=f"{int(c.physics_n_success)}/{n}" + (" agrees" if agrees else " DISAGREES"),
                disagree=not agrees, physics_line=line)


def write_certify_report(store, part, config_text: str) -> pathlib.Path:
    """``report.html`` of a certification run: its certificates, the candidates
    of synthesized tasks and the tolerance design (read from the run's tables);
    ``part`` the :class:`~sweeps.partfile.PartFile` (its name, source file and unit)."""
    import math

    import pandas as pd

    certs = store.read("certificates")
    cands = store.read("candidates")
    design = store.read("design")
    f = lambda x, fmt=".4f": "-" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, fmt)  # noqa: E731
    crow = [dict(task=c.task, verdict=c.verdict, n=int(c.n_samples), rate=f(c.success_rate),
                 low=f(c.ci_low_one_sided), selection=c.selection or "default plan",
                 claim=c.claim, **_physics_cell(c)) for c in certs.itertuples()]
    synth = []
    for task, g in (cands.groupby("task", sort=False) if not cands.empty else ()):
        g = g.sort_values(["ci_low_one_sided", "total_distance_m", "bound_position_m"],
                          ascending=[False, True, True])
        top = g.head(10)
        if not (top["candidate"] == 0).any():
            top = pd.concat([top, g[g["candidate"] == 0]])
        rows = [dict(candidate=int(r.candidate), label=r.label, k=int(r.n_success),
                     low=f(r.ci_low_one_sided), dist=f(r.total_distance_m, ".3f"),
                     pushes=int(r.n_steps), bound=f(r.bound_position_m * 1e3, ".3g"),
                     tag=("chosen" if r.chosen else "") + (" default" if r.candidate == 0 else ""))
                for r in top.itertuples()]
        synth.append(dict(task=task, n=len(g), draws=int(g["n_samples"].iloc[0]),
                          model=g["model"].iloc[0], rows=rows))
    des = []
    for task, g in (design.groupby("task", sort=False) if not design.empty else ()):
        g = g.sort_values("rank")
        r0 = g.iloc[0]
        rows = [dict(rank=int(r.rank), axis=r.axis, fields=r.fields, configured=_values(r.configured),
                     loosest=_values(r.loosest) + (f" ({r.limit})" if r.limit else ""),
                     ok="yes" if r.certified_at_configured else "no", f=f(r.failure_rate, ".3f"),
                     fw=f(r.failure_rate_without, ".3f"), fa=f(r.failure_rate_alone, ".3f"),
                     joint=_values(r.joint)) for r in g.itertuples()]
        des.append(dict(task=task, drawing=r0.drawing, certified=bool(r0.joint_certified),
                        confidence=f"{r0.confidence:.4g}", p=f"{r0.required_probability:g}",
                        n=int(r0.n_samples), model=r0.model, t=f"{r0.joint_t:.3g}",
                        basis=("the configured tolerances" if r0.joint_basis == "configured"
                               else "perfect (the configured tolerances do not certify)"),
                        n_fresh=int(r0.joint_n_fresh), base=f(r0.failure_rate_all_perfect, ".3f"),
                        rows=rows))
    page = CERTIFY_TEMPLATE.render(part=part.name, part_source=part.source_label,
                                   part_cad=part.cad.description if part.cad is not None else "",
                                   run_id=store.run_id, root=str(store.root),
                                   certs=crow, synth=synth, design=des, config=config_text,
                                   style=STYLE)
    path = store.root / "report.html"
    atomic_write(path, lambda fh: fh.write(page), mode="w")
    return path
