"""Run a parameter study: ``python -m sweeps.run CONFIG.yaml`` (also ``nudge sweep``).

Usage::

    python -m sweeps.run CONFIG.yaml [--out DIR] [--set path=value ...] [--dry-run]
                                     [--executor local|dask] [--quiet] [--no-report]

``CONFIG.yaml`` is a study file (format: :mod:`sweeps.study`); a bare name such
as ``margins.yaml`` is looked up among the bundled studies (``examples/studies``)
when no such file is in the working folder.  ``--set`` overrides fields by
dotted path (``--set samples=2000``; a comma list sweeps:
``--set planner.margin_deg=5,7,9``).  ``--dry-run`` prints the design
(configurations, tasks, samples, chunks, a rough time estimate) and runs
nothing.

Results go to ``results/<study>/<run-id>/`` (or ``--out DIR``): one folder per
table (``samples/``, ``summary/``, ``plans/``), Hive-partitioned by
``config_id``, a ``manifest.json`` and ``report.html``;
``pd.read_parquet("results/<study>/<run-id>/summary")`` is one frame.  The run
id is a hash of the resolved config, so running the same command again resumes:
finished chunks are skipped and the rows end up exactly those of an
uninterrupted run.  A changed config on an existing ``--out`` is refused.

Exit status: 0 the study ran (or resumed to the end; 130 after Ctrl-C, with
the finished chunks kept), 2 bad input (one line per mistake, ``error: ...``,
naming the field path and the fix, before anything runs), 3 internal error, 4
out of memory or a native crash (one line, the finished chunks kept).
"""
from __future__ import annotations

import json
import math
import pathlib
import sys
from typing import Optional, Sequence

from sweeps.errors import Exit, UserError
from sweeps.terminal import Parser, fail, report_part, run_main


#: the estimate's compilation time per distinct kernel shape (s, cold cache)
COMPILE_S = 8.0


def build_parser(prog: str = "python -m sweeps.run") -> Parser:
    p = Parser(prog=prog, description="Run a parameter study: plan every task under every "
               "configuration of the design, replay the plans on perturbed parts (Monte Carlo), "
               "and write Parquet tables and an HTML report.",
               epilog="Units: metres, radians (angles in configs may carry 'deg'). Results: "
                      "results/<study>/<run-id>/<table>/config_id=<k>/*.parquet (read a table "
                      "with pandas.read_parquet on its folder), manifest.json, report.html. "
                      "Rerunning the same command resumes. Exit status: 0 ran, 2 bad input, "
                      "3 internal error, 4 out of memory or a native crash, 130 interrupted (finished "
                      "chunks kept).")
    p.add_argument("config", metavar="CONFIG.yaml",
                   help="a study file, or the name of a bundled study (e.g. margins.yaml)")
    p.add_argument("--out", metavar="DIR", help="run folder (default results/<study>/<run-id>)")
    p.add_argument("--set", dest="overrides", action="extend", nargs="+", default=[],
                   metavar="PATH=VALUE",
                   help="override fields by dotted path (--set samples=2000 "
                        "planner.margin_deg=5,7,9); a comma list makes the field a swept axis, "
                        "[a, b] is a list value")
    p.add_argument("--dry-run", action="store_true", help="print the design and run nothing")
    p.add_argument("--executor", choices=("local", "dask"), help="override the config's executor")
    p.add_argument("--quiet", action="store_true", help="no progress bar, no summary table")
    p.add_argument("--no-report", action="store_true", help="do not write report.html")
    p.add_argument("--yes", action="store_true",
                   help="run even when the estimate is over the budget (an hour on 2 CPU cores)")
    return p


def main(argv: Optional[Sequence[str]] = None, prog: str = "python -m sweeps.run") -> int:
    """Run the command line; returns the exit status."""
    args = build_parser(prog).parse_args(sys.argv[1:] if argv is None else argv)
    try:
        design, out, spec = _prepare(args)
    except UserError as exc:   # a ConfigError (one line per mistake) or the file's YamlError
        for line in exc.lines:
            fail(line)
        return Exit.INPUT
    for part in design.parts():   # a CAD part: its file, unit and what reading it found
        report_part(part)
    for line in design.warnings:   # implausible values (sweeps.plausible): shown even with --quiet
        sys.stderr.write(f"warning: {line}\n")
    if args.dry_run:
        sys.stdout.write(describe_design(design, out, spec) + "\n")
        return Exit.OK
    from sweeps.budget import estimate_line, refusal
    from sweeps.store import finished_units
    from sweeps.work import plan_units

    blocks = plan_units(design, finished_units(out))[0]   # a resumed run: what is left
    secs, peak = estimate_seconds(design, blocks), estimate_peak(design, blocks)
    no = refusal(secs, f"study {design.name}", args.yes,
                 "lower samples, sweep fewer values or choose a faster model", peak)
    if no:
        return fail(no)
    _say(args.quiet, estimate_line(secs, peak))
    from sweeps.executors import ExecutorError, check_scheduler
    from sweeps.store import RunError
    from sweeps.tasks import PlanInputError

    try:
        if spec.kind == "dask" and spec.address:
            check_scheduler(spec.address)   # seconds, before the run folder is made
        return execute(design, out, spec, quiet=args.quiet, report=not args.no_report)
    except (RunError, ExecutorError) as exc:
        return fail(str(exc))
    except PlanInputError as exc:   # a setting the planner refused: bad input, found planning
        return fail(f"{design.path}: {exc}")


def _prepare(args):
    from sweeps.study import Executor, load_design
    from sweeps.work import check_units

    design = load_design(args.config, args.overrides)
    check_units(design)
    top = design.top
    spec = top.executor_spec
    if args.executor:
        spec = Executor(**{**spec.model_dump(), "kind": args.executor})
    out = pathlib.Path(args.out) if args.out else pathlib.Path(top.output) / design.name / design.run_id
    return design, out, spec


def describe_design(design, out: pathlib.Path, spec) -> str:
    """The ``--dry-run`` text: configurations, tasks, samples, chunks, estimate."""
    from sweeps.budget import estimate_line
    from sweeps.work import plan_units

    blocks, _ = plan_units(design, {})
    n_samples = sum(u.samples for u in blocks)
    pairs = sum(len(design.tasks(cid)) for cid in range(len(design.configs)))
    lines = [f"study {design.name} ({design.top.kind}), run {design.run_id} -> {out}",
             f"part: {design.part(0).name} ({design.part(0).kind}, from "
             f"{design.part(0).source_label}); executor: {spec.kind}"
             + (f" ({spec.workers} workers)" if spec.kind == "dask" and not spec.address else ""),
             f"{len(design.configs)} configuration(s) x {len(design.tasks(0))} task(s) = "
             f"{pairs} (configuration, task) pairs; {n_samples} samples in "
             f"{len(blocks)} chunk(s)"]
    if design.paths:
        lines.append("swept: " + ", ".join(
            f"{p} ({len({json.dumps(pt[p]) for pt in design.points})} values)" for p in design.paths))
        for i, pt in enumerate(design.points[:20]):
            lines.append(f"  config {i:3d}: " + ", ".join(f"{k}={v}" for k, v in pt.items()))
        if len(design.points) > 20:
            lines.append(f"  ... {len(design.points) - 20} more")
    secs, peak = estimate_seconds(design, blocks), estimate_peak(design, blocks)
    lines.append(estimate_line(secs, peak, "rough: model throughput and compilation; a warm "
                               "compilation cache is faster"))
    return "\n".join(lines)


def estimate_seconds(design, blocks) -> float:
    """A rough run time (s) from the measured throughput of each configuration's
    model and support family (:data:`robustness.THROUGHPUT`) and per-shape
    compilation."""
    from robustness import samples_per_second

    total, shapes = 0.0, set()
    for u in blocks:
        cfg = design.configs[u.config_id]
        rate = samples_per_second(cfg.kind, cfg.model, cfg.friction.support)
        total += u.samples / rate + 0.05
        shapes.add((cfg.kind, cfg.model, cfg.dtype, design.part(u.config_id).name))
    return total + COMPILE_S * (len(shapes) + 1)


def estimate_peak(design, blocks) -> float:
    """The peak memory (bytes) of a process running the study's largest unit of
    work (:func:`robustness.peak_bytes`; with Dask, of each worker)."""
    from robustness import model_for, peak_bytes

    peak = 0.0
    for u in blocks:
        cfg = design.configs[u.config_id]
        peak = max(peak, peak_bytes(model_for(cfg.model, cfg.kind), u.hi - u.lo))   # a task at a time
    return peak or peak_bytes("quasistatic", 0)


def execute(design, out: pathlib.Path, spec, quiet: bool = False, report: bool = True) -> int:
    """Run (or resume) a study into ``out``; returns the exit status."""
    from sweeps.executors import make_executor
    from sweeps.progress import Progress, StopFlag
    from sweeps.store import RunStore, manifest_for
    from sweeps.work import (Context, check_layout, design_units, plan_units, run_block,
                             run_design, run_summary, with_stats)

    from sweeps.partfile import geometry_identity

    identity = design.identity + geometry_identity(design.parts())   # an edited CAD file: refused
    manifest = manifest_for(design.run_id, design.name, identity, design.top.seed,
                            {"paths": design.paths, "points": design.points},
                            config_as_run=design.text)
    store = RunStore.open(out, manifest)
    done = store.done()
    check_layout(done, out, design)
    blocks, summaries = plan_units(design, done)
    designs = design_units(design, done)
    ctx = Context(str(design.path), json.dumps(design.doc), str(out), json.dumps(store.manifest),
                  design=design)
    total = sum(u.samples for u in blocks)
    resume = f"run the same command again to resume (results so far: {out})"
    if done:
        _say(quiet, f"resuming run {design.run_id}: {len(done)} chunk(s) already done, "
                    f"{len(blocks) + len(summaries) + len(designs)} to go")
    bar = Progress(total, quiet=quiet)
    warned: set = set(design.warnings)   # shown before the run
    findings: dict = {}
    try:
        with StopFlag(resume) as flag, make_executor(spec) as ex:
            records: dict = {}      # this run's block records: their statistics feed the summaries
            for phase, fn, units in (("samples", run_block, blocks),
                                     ("summary", run_summary, summaries),
                                     ("design", run_design, designs)):
                if flag.stop:
                    break
                if phase == "summary":
                    units = with_stats(design, store, units, records)
                for unit, rec in ex.run(fn, ctx, units):
                    store.mark_done(rec["key"], rec["files"], rows=rec["rows"], sync=False)
                    if phase == "samples":
                        records[rec["key"]] = rec
                    for kind, line in rec.get("findings", ()):
                        findings.setdefault(kind, []).append(line)
                    for w in rec.get("warnings", ()):
                        if w not in warned:
                            warned.add(w)
                            bar.note(f"warning: {w}")
                    bar.advance(unit.samples)
                    if flag.stop:
                        break
            stopped = flag.stop
    finally:
        store.sync_log()
        bar.close()
    for kind, msgs in findings.items():
        sys.stderr.write(f"finding: {kind} in {len(msgs)} (configuration, task) pair(s), e.g. "
                         f"{msgs[0]} (see the summary table's bound columns)\n")
    if stopped:
        sys.stderr.write(f"stopped: finished chunks are kept; {resume}\n")
        return Exit.INTERRUPTED
    if report and design.top.report:
        from sweeps.report import write_report

        path = write_report(store, design)
        _say(quiet, f"wrote {path}")
    if not quiet:
        from sweeps.report import recommendation

        sys.stdout.write(summary_table(store, design) + "\n")
        sys.stdout.write(recommendation(store.read("summary"), store.read("plans"), design) + "\n")
    sys.stdout.write(f"results: {out}\n")
    return Exit.OK


def _say(quiet: bool, text: str) -> None:
    if not quiet:
        sys.stderr.write(text + "\n")


def summary_table(store, design) -> str:
    """Per configuration: swept values, tasks planned, samples, success, weakest task."""
    from sweeps.report import config_stats

    s = store.read("summary")
    p = store.read("plans")
    if s.empty:
        return "(no summary rows)"
    s = s.assign(config_id=s["config_id"].astype(int))
    p = p.assign(config_id=p["config_id"].astype(int))
    head = ["config"] + [f.replace(".", "_") for f in design.paths] + \
        ["planned", "samples", "success", "worst CP low", "dominant failure"]
    rows = []
    for cid in sorted(s["config_id"].unique()):
        c = config_stats(s, p, int(cid))
        n, lows = c["n"], c["lows"]
        pt = design.points[cid]
        rows.append([str(cid)] + [_short(pt[x]) for x in design.paths] + [
            f"{c['planned']}/{c['tasks']}", str(n),
            f"{c['k'] / n:.3f}" if n else "-", f"{lows.min():.3f}" if len(lows) else "-",
            c["mode"]])
    widths = [max(len(r[i]) for r in rows + [head]) for i in range(len(head))]
    fmt = "  ".join(f"{{:>{w}}}" for w in widths)
    lines = [fmt.format(*head), fmt.format(*["-" * w for w in widths])]
    lines += [fmt.format(*r) for r in rows]
    return "\n".join(lines)


def _short(v) -> str:
    if isinstance(v, float):
        return f"{v:.4g}" if math.isfinite(v) else str(v)
    return str(v)


if __name__ == "__main__":
    run_main(main, supervised=True)
