"""Certify plans against part tolerances, friction and robot errors (``nudge certify``).

Usage::

    nudge certify CONFIG.yaml [--out DIR] [--n-samples N|auto] [--max-samples M] [--seed S]
                              [--synthesize] [--design]
                              [--quiet]

For every task of the config: plan it (the Akella-Mason pose planner for a
polygon part, the Marigo-Bicchi tumble planner for a polyhedron), replay the
plan on Monte-Carlo samples of the tolerances, and say exactly what was shown
(:mod:`robustness.certificates`): ``certified`` when the one-sided
Clopper-Pearson lower bound of the success probability at the required
confidence reaches the required probability; otherwise ``not certified`` with
the reason (too few samples, failures and the dominant failure mode, nothing
perturbed), or ``no plan``.  The analytic first-order bound is printed beside
it with the model it assumes; it never certifies on its own.

``--n-samples auto`` is a sequential test: it looks at a schedule of sample
counts fixed in advance (from the fewest that could certify, doubling, up to
``--max-samples``) and stops at the first look that decides; the error
``1 - confidence`` is split over the ``K`` looks (Bonferroni: each look's bound
at ``1 - (1 - confidence) / K``), so the verdict holds the stated confidence over
all looks, and the certificate names the procedure (``procedure``,
``look_confidence``, ``n_looks``, ``look``).  A fixed ``--n-samples N`` is one
look, the plain one-sided bound.  With a
``margin_search`` section, a push task that is not certified is re-planned over
a grid of margin angles and safety factors, judged on selection draws, and the
first setting that passes is certified on the task's own draws and, if
certified, recommended (:func:`robustness.recommend_margins`; a re-run with it
gives that verdict).  ``--synthesize`` (a ``synthesize:`` section) replaces
the default plan of a push task by the best of many candidates scored on the
same selection draws (:mod:`robustness.synthesis`), certified on fresh draws
(a choice MuJoCo contradicts against the default plan on
``synthesize.veto_samples`` common draws keeps the default plan:
:func:`robustness.physics_veto`);
``--design`` (a ``design:`` section) adds the tolerance design of the certified
plan (:mod:`robustness.tolerance_design`: table ``design``, ``report.html``).

Config (YAML; unknown keys are errors; numbers such as ``1e-5`` are numbers;
a length may carry a unit, ``tau_v: 0.05 mm``, converted to metres once)::

    part: biplus_stable              # a bundled name, a path relative to this file (a part
                                     # file, or a CAD file: plate.dxf, bracket.stl), or inline
                                     # ({mesh: bracket.stl, units: mm}: sweeps.partfile)
    tolerances: {tau_v: 2.0e-5, tau_com: 1.0e-4}       # robustness.GeometryTolerance
    friction: {mu_f: [0.4, 0.8], mu_s: [0.3, 0.6]}     # robustness.FrictionRange
    execution: {start_xy: 5.0e-4, fence_angle: 0.002}  # robustness.ExecutionTolerance
    planner: {margin_deg: 7, safety_factor: 1.15, objective: distance}
    eps: {pos_eps_m: 0.002, theta_eps_rad: 0.035}
    required: {probability: 0.9, confidence: 0.95}
    n_samples: 300                   # or auto
    seed: 0
    model: quasistatic               # or exact, or mujoco (physics; tumbles: exact or mujoco)
    tasks:
      - {name: turn, start: [0, 0, 0], goal: [0.1, 0.05, 60deg]}
      # sensorless (issue 40): any heading (or heading: [lo, hi]) anywhere in the region;
      # each sample starts uniformly there, and the claim says "from any heading in ..."
      - {name: feed, start: {heading: any, region: [0, 0.04, 0, 0.04]}, goal: [0.15, 0.1, 30deg]}

Output: ``results/certify-<config stem>/<run-id>/`` (or ``--out DIR``) with one
folder per table (``samples/``, ``summary/``, ``plans/``, ``certificates/``,
``config_id=00000`` partitions) and ``manifest.json``; a rerun of the same
command resumes.  A short table on stdout.  Exit status: 0 every task
certified, 1 some task not certified, 2 bad input (``error: ...`` naming the
field and the fix, before any work), 3 internal error, 4 out of memory or a
native crash, 130 interrupted.
"""
from __future__ import annotations

import math
import pathlib
import sys
import warnings
from typing import TYPE_CHECKING, Optional

from sweeps.budget import MAX_SAMPLES
from sweeps.errors import Exit, UserError
from sweeps.terminal import Parser, fail, report_part, report_warnings, run_main

if TYPE_CHECKING:   # the config module imports pydantic: loaded at run time, after the cheap checks
    from sweeps.config import CertifyConfig

# The config's schema (sweeps.config.CertifyConfig) and the layers below (JAX, MuJoCo,
# pandas) are imported where a command runs, not here: `nudge certify --help` reads
# only the parser.

def build_parser(prog: str = "nudge certify") -> Parser:
    p = Parser(prog=prog, description="Certify push / tumble plans against part tolerances, "
               "friction and robot errors: plan each task, replay the plan on Monte-Carlo "
               "samples, and state what was shown (one-sided Clopper-Pearson bound at the "
               "required confidence); writes Parquet tables.",
               epilog="Units: metres, radians (a 'deg' suffix in configs). Output: "
                      "results/certify-<stem>/<run-id>/{samples,summary,plans,certificates}/ "
                      "(pandas.read_parquet on a folder). Exit status: 0 every task certified, "
                      "1 some task not certified, 2 bad input, 3 internal error, 4 out of memory or "
                      "a native crash, 130 interrupted (rerun to resume).")
    p.add_argument("config", help="certification config (YAML)")
    p.add_argument("--out", help="run folder (default results/certify-<config stem>/<run-id>)")
    p.add_argument("--n-samples", help="Monte-Carlo samples per task, or 'auto' (a sequential "
                                       "test: doubling looks up to --max-samples, stopping when "
                                       "decided, the confidence split over the looks)")
    p.add_argument("--max-samples", type=int, help=f"cap of --n-samples auto (default "
                                                    f"{MAX_SAMPLES})")
    p.add_argument("--seed", type=int, help="override seed")
    p.add_argument("--synthesize", action="store_true",
                   help="robust plan synthesis (push tasks): score many candidate plans on the "
                        "same selection draws, certify the best on fresh draws (the config's "
                        "synthesize: section sets the grid and the objective)")
    p.add_argument("--design", action="store_true",
                   help="tolerance design: the loosest value of each tolerance that still "
                        "certifies the plan, what drives its failures, a joint design verified "
                        "on fresh draws (the design table and report.html; the config's design: "
                        "section sets the draws)")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    p.add_argument("--yes", action="store_true",
                   help="run even when the estimate is over the budget (an hour on 2 CPU cores)")
    return p


def _task_samples(cfg: CertifyConfig) -> int:
    """The most samples a task draws (``auto``: up to ``max_samples``)."""
    return cfg.max_samples if cfg.n_samples == "auto" else int(cfg.n_samples)


#: evaluations of the design draws a tolerance design takes: about this many per
#: axis (bracket and bisection, the knock-outs) and this many besides (the joint
#: design); measured 66-76 on the triangle's six push axes
DESIGN_EVALUATIONS_PER_AXIS, DESIGN_EVALUATIONS_BESIDES = 10, 12


def estimate_seconds(cfg: CertifyConfig, part, n_tasks: int, kept: int = 0,
                     sensorless: int = 0) -> float:
    """The certification's time (s) on 2 CPU cores from the measured throughput
    of each model on its support (:func:`robustness.models.samples_per_second`):
    every task's samples (``auto``: up to ``max_samples``) under the config's
    model (``sensorless`` of the ``n_tasks`` at a sensorless plan's rate: one
    rollout a sample from its own start under MuJoCo), less the ``kept``
    samples of an interrupted run's finished blocks;
    the synthesis's selection draws over its candidate cap under the model that
    chooses (:func:`robustness.decision_model`; the exact limit surface scores
    a shortlist that the quasi-static model draws up), or the margin search's
    grid and its recommendation's certification (every task failing); the
    tolerance design's evaluations; plus a few seconds a task of planning and
    compilation."""
    from robustness import (decision_model, DESIGN_AXES, kind_for_part, samples_per_second,
                            SHORTLIST)

    kind = kind_for_part(part.kind)
    support = cfg.friction.support
    rate = lambda model, k=kind: samples_per_second(k, model, support)  # noqa: E731
    choose = decision_model(cfg.model, kind)
    # seconds a sample, averaged over the tasks (a sensorless plan replays slower in MuJoCo)
    per = ((n_tasks - sensorless) / rate(cfg.model)
           + sensorless / rate(cfg.model, "sensorless")) / max(n_tasks, 1)
    secs = max(n_tasks * _task_samples(cfg) - kept, 0) * per
    if cfg.synthesize is not None and cfg.synthesize.enabled:
        s = cfg.synthesize
        scored = s.max_candidates
        if choose == "limit_surface" and s.max_candidates > SHORTLIST:
            secs += n_tasks * s.n_samples * s.max_candidates / rate("quasistatic")
            scored = SHORTLIST
        secs += n_tasks * s.n_samples * scored / rate(choose)
    elif kind == "push" and cfg.margin_search is not None and cfg.margin_search.enabled:
        m = cfg.margin_search
        grid = len(m.margins_deg) * len(m.safety_factors)
        secs += n_tasks * (m.n_samples * grid + _task_samples(cfg)) * per
    if cfg.design is not None and cfg.design.enabled:
        axes = len(cfg.design.axes or DESIGN_AXES[kind])
        evals = DESIGN_EVALUATIONS_PER_AXIS * axes + DESIGN_EVALUATIONS_BESIDES
        secs += n_tasks * evals * cfg.design.n_samples / rate(choose)
    return secs + 2.0 * n_tasks + 8.0


def estimate_peak(cfg: CertifyConfig, part) -> float:
    """The certification's peak memory (bytes): a block of samples at a time
    (:func:`robustness.block_samples`, :func:`robustness.peak_bytes`), never
    more than a task's sample count."""
    from robustness import block_samples, kind_for_part, model_for, peak_bytes

    kind = kind_for_part(part.kind)
    model = model_for(cfg.model, kind)
    return peak_bytes(model, min(_task_samples(cfg), block_samples(kind, model,
                                                                   cfg.friction.support)))


def _check_sample_cap(cfg: CertifyConfig, field: str) -> None:
    """``n_samples: auto`` under a cap (``field``) below the fewest samples that
    can certify even when every one succeeds: refused before any work (it ran
    the cap's samples, then said how many more were needed)."""
    from robustness import samples_needed
    from sweeps.config import ConfigError

    if cfg.n_samples != "auto":
        return
    p, conf = cfg.required.probability, cfg.required.confidence
    need = samples_needed(p, conf)
    if cfg.max_samples < need:
        raise ConfigError(f"{field}: {cfg.max_samples} samples cannot certify P(success) >= {p:g} "
                          f"at {conf * 100:.4g}% confidence even if every one succeeds: with p and "
                          f"confidence as given, at least {need} samples are needed; raise {field} "
                          f"to {need} or more (--n-samples auto)")


def load(path, n_samples=None, max_samples=None, seed=None, synthesize: bool = False,
         design: bool = False):
    """Read a certify config and apply command-line overrides (``synthesize``,
    ``design``: ``--synthesize`` / ``--design``, that section enabled, created
    with its defaults when absent).

    Returns:
      ``(config, document as run, its YAML text, part, tasks)``.

    Raises:
      UserError: one line per mistake (``lines``), each naming the file.
    """
    from robustness.physics import check_pad_friction
    from sweeps.config import (CertifyConfig, ConfigError, check_sensorless, explicit_tasks,
                               validate)
    from sweeps.plausible import screen_config
    from sweeps.study import load_part_ref, part_polyhedron
    from sweeps.yamlio import dump_yaml, read_yaml

    path = pathlib.Path(path)
    doc, _ = read_yaml(path, "config")   # a YamlError names the file
    if not isinstance(doc, dict):
        raise ConfigError(f"{path}: expected a mapping with keys "
                          f"{', '.join(CertifyConfig.model_fields)}")
    for flag, key, v in (("--n-samples", "n_samples", n_samples),
                         ("--max-samples", "max_samples", max_samples), ("--seed", "seed", seed)):
        if v is None:
            continue
        if key == "n_samples" and v != "auto":
            try:
                v = int(v)
            except ValueError:
                raise ConfigError(f"--n-samples: expected an integer >= 1 or auto, got {v!r}") from None
        if v != "auto" and v < (1 if key != "seed" else 0):
            raise ConfigError(f"{flag}: must be >= {1 if key != 'seed' else 0}, got {v}")
        doc[key] = v
    for flag, name in ((synthesize, "synthesize"), (design, "design")):
        if flag:
            sec = doc.get(name)
            doc[name] = {**(sec if isinstance(sec, dict) else {}), "enabled": True}
    try:
        cfg = validate(CertifyConfig, doc)
        _check_sample_cap(cfg, "--max-samples" if max_samples is not None else "max_samples")
        part = load_part_ref(cfg.part, path.parent)
        tasks = explicit_tasks(cfg.tasks, part.kind)
        check_sensorless(cfg, tasks)
        if cfg.model == "mujoco":
            if part.kind == "polyhedron":
                check_pad_friction(cfg.friction, "tumble", part_polyhedron(part),
                                   cfg.physics.cell.grip_ratio)
            # the part file's thickness and density into the cell, once
            cell = cfg.physics.run(part, cfg.friction).settings
            cfg = cfg.model_copy(update={"physics": cfg.physics.model_copy(update={"cell": cell})})
        screen_config(cfg, part)   # implausible values (sweeps.plausible), before any work
    except UserError as exc:
        raise exc.within(path) from None
    except ValueError as exc:   # a friction the MuJoCo tumble device cannot use, a part the cell refuses
        raise ConfigError(f"{path}: {exc}") from None
    return cfg, doc, dump_yaml(doc), part, tasks


def main(argv=None, prog: str = "nudge certify") -> int:
    """Run the command line; returns the exit status."""
    args = build_parser(prog).parse_args(sys.argv[1:] if argv is None else argv)
    from sweeps.config import ConfigError
    from sweeps.store import RunError

    path = pathlib.Path(args.config)
    try:
        cfg, doc, text, part, tasks = load(path, args.n_samples, args.max_samples, args.seed,
                                           args.synthesize, args.design)
    except UserError as exc:
        for line in exc.lines:
            fail(line)
        return Exit.INPUT
    report_part(part)   # a CAD part: its file, unit and what reading it found
    from sweeps.budget import estimate_line, refusal
    from sweeps.store import finished_units, run_id as run_id_of

    run_id = run_id_of(doc)
    out = pathlib.Path(args.out) if args.out else pathlib.Path("results") / f"certify-{path.stem}" / run_id
    # a resumed run: the samples its finished blocks hold are not drawn again
    kept = sum(int(r.get("rows") or 0) for r in finished_units(out).values())
    from sweeps.config import SensorlessStart

    secs = estimate_seconds(cfg, part, len(tasks), kept,
                            sum(isinstance(start, SensorlessStart) for _, start, _ in tasks))
    peak = estimate_peak(cfg, part)
    no = refusal(secs, f"certifying {len(tasks)} task(s) of {path.name} with model {cfg.model}",
                 args.yes, "lower --n-samples / --max-samples or choose a faster model", peak,
                 "lower --n-samples")
    if no:
        return fail(no)
    _log(args.quiet, estimate_line(secs, peak, f"model {cfg.model}, support "
                                   f"{cfg.friction.support}"))
    try:
        code, certs = run(cfg, text, part, tasks, out, run_id, quiet=args.quiet)
    except (ConfigError, RunError) as exc:
        return fail(str(exc))
    if code == Exit.INTERRUPTED:
        return code

    # a sensorless task: --synthesize and --design need a known start, never suggested
    unknown = {name for name, start, _ in tasks if isinstance(start, SensorlessStart)}
    sys.stdout.write(format_table(certs, lambda c: next_steps(
        c, cfg.friction.support, synthesized=bool(args.synthesize) or c["task"] in unknown,
        designed=bool(args.design) or c["task"] in unknown)) + "\n")
    sys.stdout.write(f"results: {out}\n")
    return code


def run(cfg: CertifyConfig, text: str, part, tasks, out: pathlib.Path, run_id: str,
        quiet: bool = False) -> tuple[int, list]:
    """Certify every task into the run folder ``out``; returns ``(status, certificate rows)``."""
    from sweeps.executors import compilation_cache

    with compilation_cache():
        return _run(cfg, text, part, tasks, out, run_id, quiet)


def _run(cfg, text, part, tasks, out, run_id, quiet):
    from robustness import CERTIFICATES_SCHEMA, rows_table
    from sweeps.progress import StopFlag
    from sweeps.store import RunStore, manifest_for

    from sweeps.partfile import geometry_identity

    identity = text + geometry_identity([part])   # an edited CAD file does not resume this run
    store = RunStore.open(out, manifest_for(run_id, f"certify-{part.name}", identity, cfg.seed,
                                            {"tasks": [t[0] for t in tasks]}, config_as_run=text))
    done = store.done()
    certs = []
    stopped = (f"stopped: finished chunks are kept; run the same command again to resume "
               f"(results so far: {out})\n")
    with StopFlag(f"run the same command again to resume (results so far: {out})") as flag:
        for ti, (name, start, goal) in enumerate(tasks):
            if flag.stop:
                sys.stderr.write(stopped)
                return Exit.INTERRUPTED, certs
            key = f"t{ti:04d}-certificate"
            if key in done:
                row = store.read("certificates", 0)
                row = row[row["task"] == name].iloc[0].to_dict()
                certs.append(row)
                _log(quiet, f"[{name}] {row['verdict']} (already done)")
                continue
            row = certify_task(cfg, part, ti, name, start, goal, store, done, quiet, flag)
            if row is None:
                continue
            row = {"run_id": store.run_id, **row}
            schema = CERTIFICATES_SCHEMA
            path = store.write("certificates", 0, f"t{ti:04d}", rows_table([row], schema), schema)
            store.mark_done(key, [path])
            certs.append(row)
        if flag.stop:   # during the last task (its synthesis, blocks or design): no verdict, no report
            sys.stderr.write(stopped)
            return Exit.INTERRUPTED, certs
    status = Exit.OK if all(c["verdict"] == "certified" for c in certs) else Exit.NEGATIVE
    if cfg.design is not None and cfg.design.enabled or cfg.synthesize is not None \
            and cfg.synthesize.enabled:
        from sweeps.report import write_certify_report

        path = write_certify_report(store, part, text)
        _log(quiet, f"wrote {path}")
    return status, certs


def certify_task(cfg, part, ti, name, start, goal, store, done, quiet, flag) -> Optional[dict]:
    """Plan, sample (resumable blocks), summarise and decide one task; the certificate row."""
    import jax

    from robustness import (auto_schedule, certify_block_size, grow, is_sensorless,
                            kind_for_part, model_for, no_plan, plan_certificate, PLANS_SCHEMA,
                            rows_table, Schedule)
    from sweeps.blocks import StoredBlocks
    from sweeps.config import ConfigError
    from sweeps.tasks import PlanInputError, plan_row, plan_task

    kind = kind_for_part(part.kind)
    model = model_for(cfg.model, kind)
    req = cfg.requirement()
    p, conf = req.probability, req.confidence
    caught: list = []
    try:
        plan, reason = plan_task(part, start, goal, cfg.planner, cfg.eps, caught)
    except PlanInputError as exc:
        raise ConfigError(f"tasks[{ti}] ({name}): {exc}") from None
    report_warnings(caught)
    key = jax.random.fold_in(jax.random.key(cfg.seed), ti)
    syn = None
    if plan is not None and cfg.synthesize is not None and cfg.synthesize.enabled:
        syn = synthesize_task(cfg, part, name, start, goal, key, store, ti)
        plan = syn.plan
        _log(quiet, f"[{name}] {syn.describe()}")
    prow = {"run_id": store.run_id, **plan_row(part, name, start, goal, plan, reason)}
    store.write("plans", 0, f"t{ti:04d}", rows_table([prow], PLANS_SCHEMA),
                PLANS_SCHEMA)
    row = _task_row(cfg, part, name, start, goal, plan, syn)
    schedule = (auto_schedule(p, conf, cfg.max_samples) if cfg.n_samples == "auto"
                else Schedule((int(cfg.n_samples),), conf))
    if plan is None:
        _log(quiet, f"[{name}] no plan: {reason}")
        from robustness import empty_summary

        s = empty_summary(name, kind, model, cfg.dtype, cfg.eps, conf)
        _write_summary(store, ti, s)
        return {**row, **no_plan(reason, req, model, schedule).to_row()}
    size = certify_block_size(plan, model, cfg.friction.support, schedule)   # robustness.certify's
    blocks = StoredBlocks(cfg, store, plan, name, ti, key, size, model, done, flag)
    grow(blocks.extend, schedule, req)
    if flag.stop:
        return None
    summary = blocks.task_summary()
    _write_summary(store, ti, summary)
    sensorless = is_sensorless(plan)
    cert = plan_certificate(summary, req, plan, cfg.sampler(), model, schedule)
    row.update(cert.to_row())
    ex = cfg.execution
    if sensorless and (ex.start_xy > 0 or ex.start_theta > 0):
        row["note"] = "; ".join(x for x in (row["note"], "execution.start_xy / start_theta not "
                                            "applied: each sample's start is drawn over the "
                                            "task's heading interval and region") if x)
    if syn is not None:
        row["note"] = "; ".join(x for x in (row["note"], "certified on fresh draws, not the "
                                            "selection draws the plan was chosen on") if x)
        check = confirm_task(cfg, part, plan, summary, key)
        if check is not None:
            row.update(check.to_row())
            row["note"] = "; ".join(x for x in (row["note"], check.sentence()) if x)
            _log(quiet, f"[{name}] {check.sentence()}")
    _log(quiet, f"[{name}] {cert.verdict}: {cert.claim}")
    if cert.verdict != "certified" and kind == "push" and cfg.margin_search is not None \
            and cfg.margin_search.enabled and syn is None:
        rec, trials = margin_search(part, start, goal, cfg, key, model, schedule)
        if rec is not None and rec.certified:
            row.update(recommended_margin_deg=rec.margin_deg,
                       recommended_safety_factor=rec.safety_factor)
        line = (rec.sentence() if rec is not None else
                f"no margin / safety factor of the grid passed the search ({len(trials)} "
                f"settings, {cfg.margin_search.n_samples} search draws each)")
        row["note"] = "; ".join(x for x in (row["note"], line) if x)
        _log(quiet, f"[{name}] margin search: {line}")
    if cfg.design is not None and cfg.design.enabled:
        line = design_task(cfg, part, plan, name, key, store, ti)
        row["note"] = "; ".join(x for x in (row["note"], f"tolerance design: {line}") if x)
        _log(quiet, f"[{name}] tolerance design: {line}")
    return row


def confirm_task(cfg, part, plan, summary, key):
    """The synthesized plan of a push task rolled out in MuJoCo
    (``synthesize.confirm_samples`` fresh draws, :func:`robustness.confirm_in_physics`)
    beside its certificate; None when there is nothing to confirm with: no
    rollouts asked for, a tumble task, a model that is physics already, or a
    support MuJoCo does not build (``points``)."""
    from robustness import confirm_in_physics, confirmation_key
    from sweeps.tasks import realisable

    n = cfg.synthesize.confirm_samples
    if not n or part.kind != "polygon" or cfg.model == "mujoco" or not realisable(cfg):
        return None
    return confirm_in_physics(plan, cfg.sampler(), n, confirmation_key(key), cfg.requirement(),
                              model=cfg.model, model_k=int(summary["n_success"]),
                              model_n=int(summary["n"]),
                              physics=cfg.physics.run(part, cfg.friction))


def design_task(cfg, part, plan, name, key, store, ti) -> str:
    """Tolerance design of one task's plan (:func:`sweeps.tasks.design_rows`);
    writes the task's ``design`` rows and returns the drawing line."""
    from robustness import DESIGN_SCHEMA, rows_table
    from sweeps.tasks import design_rows

    rows, line = design_rows(cfg, part, plan, name, key)
    rows = [{"run_id": store.run_id, **r} for r in rows]
    schema = DESIGN_SCHEMA
    store.write("design", 0, f"t{ti:04d}", rows_table(rows, schema), schema)
    return line


def _write_summary(store, ti, s: dict) -> None:
    from robustness import rows_table, SUMMARY_SCHEMA

    row = {"run_id": store.run_id, **s}
    store.write("summary", 0, f"t{ti:04d}", rows_table([row], SUMMARY_SCHEMA),
                SUMMARY_SCHEMA)


def synthesize_task(cfg, part, name, start, goal, key, store, ti):
    """Robust synthesis of one push or tumble task (:func:`sweeps.tasks.synthesize_for`
    on the selection draws of ``key``, :func:`robustness.selection_key`); writes
    the task's ``candidates`` rows and returns the :class:`~robustness.Synthesis`."""
    from robustness import CANDIDATES_SCHEMA, rows_table
    from sweeps.tasks import plan_json, synthesize_for

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        syn = synthesize_for(cfg, part, start, goal, key)
    report_warnings(caught)
    push = part.kind == "polygon"
    model = syn.model
    s = syn.scores
    rows = []
    for i, c in enumerate(syn.candidates):
        pl = c.plan
        if push:
            o = pl.options
            how = dict(margin_deg=o.margin_deg, safety_factor=o.safety_factor,
                       strategy=o.strategy, distance_rule=pl.distance_rule,
                       support=o.support.family,
                       min_fence_mu=math.nan if o.min_fence_mu is None else o.min_fence_mu,
                       n_steps=pl.n_steps, total_distance_m=pl.total_distance,
                       tumble_eps=math.nan)
        else:
            how = dict(margin_deg=math.nan, safety_factor=math.nan,
                       strategy="short" if c.options.shorten else "paper", distance_rule=None,
                       support=None, min_fence_mu=math.nan, n_steps=pl.n_steps,
                       total_distance_m=math.nan, tumble_eps=c.options.eps)
        rows.append(dict(run_id=store.run_id, task=name, candidate=i, label=c.label, **how,
                         alternative=c.rank, bound_position_m=float(s.bound_position_m[i]),
                         bound_theta_rad=float(s.bound_theta_rad[i]), model=model, n_samples=s.n,
                         n_success=int(s.n_success[i]), ci_low_one_sided=float(s.ci_low[i]),
                         confidence=s.confidence, objective=syn.objective,
                         chosen=i == syn.chosen, plan_json=plan_json(pl)))
    schema = CANDIDATES_SCHEMA
    store.write("candidates", 0, f"t{ti:04d}", rows_table(rows, schema), schema)
    return syn


def _task_row(cfg, part, name, start, goal, plan, syn=None) -> dict:
    from robustness import NO_PHYSICS, kind_for_part, model_for
    from sweeps.config import reference_start

    start = reference_start(start)   # a sensorless task: the region's centre (its claim says)

    kind = kind_for_part(part.kind)
    push = kind == "push"
    sel = dict(selection="default plan", n_candidates=0, selection_n_samples=0,
               selection_ci_low=math.nan, default_selection_ci_low=math.nan)
    if syn is not None:
        sel = dict(selection=syn.describe(), n_candidates=len(syn.candidates),
                   selection_n_samples=syn.scores.n,
                   selection_ci_low=float(syn.scores.ci_low[syn.chosen]),
                   default_selection_ci_low=float(syn.scores.ci_low[0]))
    return dict(**sel, **NO_PHYSICS, task=name, kind=kind, part=part.name,
                part_source=part.source.name, part_units=part.units,
                model=model_for(cfg.model, kind),
                start_x_m=start[0], start_y_m=start[1], start_theta_rad=start[2],
                start_face=start[3] if not push else -1, goal_x_m=goal[0], goal_y_m=goal[1],
                goal_theta_rad=goal[2], goal_face=goal[3] if not push else -1,
                plan_steps=0 if plan is None else plan.n_steps,
                plan_distance_m=plan.total_distance if (push and plan is not None) else math.nan,
                plan_verdict="no_plan" if plan is None else plan.verdict,
                margin_deg=(plan.options.margin_deg if plan is not None
                            else cfg.planner.margin_deg) if push else math.nan,
                safety_factor=(plan.options.safety_factor if plan is not None
                               else cfg.planner.safety_factor) if push else math.nan,
                pos_eps_m=cfg.eps.pos_eps_m, theta_eps_rad=cfg.eps.theta_eps_rad,
                recommended_margin_deg=math.nan, recommended_safety_factor=math.nan)


def margin_search(part, start, goal, cfg, key, model, schedule):
    """The margin recommendation of a push task that did not certify
    (:func:`robustness.recommend_margins`): the config's grid searched on
    ``margin_search.n_samples`` selection draws of the task's ``key``, the
    chosen plan certified on the task's own draws (``schedule``, ``model``).

    Returns:
      ``(recommendation or None, trials)``.
    """
    from robustness import recommend_margins
    from sweeps.tasks import plan_task

    ms = cfg.margin_search

    def replan(margin_deg, safety_factor):
        planner = cfg.planner.model_copy(update={"margin_deg": margin_deg,
                                                 "safety_factor": safety_factor})
        return plan_task(part, start, goal, planner, cfg.eps)[0]

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return recommend_margins(replan, [(m, sf) for m in ms.margins_deg for sf in ms.safety_factors],
                                 cfg.sampler(), ms.n_samples, key, cfg.requirement(),
                                 samples=schedule, model=cfg.model_spec(model, cfg.physics_run()))


def next_steps(cert: dict, support: str = "any", synthesized: bool = False,
               designed: bool = False) -> str:
    """What an engineer can change when a task did not certify (one line, empty
    when it certified): more samples where they can still decide, else the
    remedy of the dominant failure, robust synthesis, tolerance design and a
    measured support."""
    if cert.get("verdict") == "certified":
        return ""
    reason, kind = cert.get("reason"), cert.get("kind")
    if reason == "too_few_samples":
        need = int(cert.get("samples_needed") or 0)
        return (f"next: more samples: --n-samples {need} (or --n-samples auto) can certify it "
                "if no sample fails")
    if reason == "nothing_perturbed":
        return "next: give the tolerances to certify against (tolerances:, friction:, execution:)"
    if reason not in ("failures", "below_requirement"):
        return ""
    from sweeps.remedies import remedies

    steps = remedies(kind, cert.get("dominant_failure_mode"), support, synthesized, designed)
    margin, safety = cert.get("recommended_margin_deg"), cert.get("recommended_safety_factor")
    if margin is not None and margin == margin:   # the margin search's setting certified
        steps = [f"the margin search's setting, planner: {{margin_deg: {margin:g}, safety_factor: "
                 f"{safety:g}}} (its plan certified on this task's draws; a re-run with it gives "
                 "that verdict)", *steps]
    head = ("more samples cannot certify this plan; try" if reason == "below_requirement"
            else "to certify it, try")
    return f"next: {head} " + "; ".join(steps) if steps else ""


def format_table(certs: list, advice=None) -> str:
    """The verdict table printed on stdout (one line per task, then its claim;
    ``advice``: a function of a certificate row giving its next-steps line)."""
    hdr = (f"{'task':16s} {'kind':6s} {'steps':>5s} {'n':>6s} {'success':>8s} {'CP low':>8s} "
           f"{'bound mm':>9s} {'bound deg':>9s} {'verdict':14s} {'reason':18s} {'dominant failure':24s}")
    lines = [hdr, "-" * len(hdr)]

    def f(v, fmt):
        return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else format(v, fmt)

    for c in certs:
        bp, bt = c.get("bound_position_m"), c.get("bound_theta_rad")
        lines.append(
            f"{str(c['task'])[:16]:16s} {c['kind']:6s} {int(c.get('plan_steps') or 0):5d} "
            f"{int(c.get('n_samples') or 0):6d} {f(c.get('success_rate'), '.4f'):>8s} "
            f"{f(c.get('ci_low_one_sided'), '.4f'):>8s} "
            f"{f(None if bp is None else bp * 1e3, '.3f'):>9s} "
            f"{f(None if bt is None else math.degrees(bt), '.3f'):>9s} "
            f"{c['verdict']:14s} {str(c.get('reason') or '-'):18s} "
            f"{str(c.get('dominant_failure_mode') or '-'):24s}")
        lines.append(f"{'':16s} {c.get('claim') or ''}")
        if c.get("n_candidates"):
            lines.append(f"{'':16s} {c['selection']}")
        if c.get("note"):
            lines.append(f"{'':16s} note: {c['note']}")
        step = advice(c) if advice else ""
        if step:
            lines.append(f"{'':16s} {step}")
    return "\n".join(lines)


def _log(quiet: bool, msg: str) -> None:
    if not quiet:
        sys.stderr.write(msg + "\n")
        sys.stderr.flush()


if __name__ == "__main__":
    run_main(main, supervised=True)
