"""The units of work of a study and what each one writes.

Three kinds of unit sample and summarise (a fourth, :func:`run_design`, makes a
task's tolerance design), each idempotent (deterministic inputs, keys and file names):

* a **configuration** ``config_id``, where its tasks' samples are few (every task
  one block, at most :data:`CONFIGURATION_SAMPLES` samples in all): every task's
  samples (one block each, drawn as a block ``0`` below) and its ``plans`` and
  ``summary`` rows, written as one file per table
  (``<table>/config_id=<k>/part-tasks.parquet``, a task after the other).  A file
  costs its creation, encoding and sync (about 1.7 ms) whatever its size: a
  study of many small configurations (the bundled margins.yaml: 18 of 4 tasks x
  100 samples) spent more on files than on its samples;
* a **sample block** ``(config_id, task, block)``: samples ``lo..hi-1`` of a
  task under one configuration, drawn with the key
  ``fold_in(fold_in(key(seed), task), block)`` and written to
  ``samples/config_id=<k>/part-t<task>-b<block>.parquet``.  The key does not
  depend on the configuration: configurations see the same perturbation draws
  wherever the draws have the same shape (common random numbers, so that a swept
  parameter's effect is not drowned in sampling noise);
* a **summary** ``config_id`` (a configuration of sample blocks): after all its blocks,
  merges each task's per-sample statistics the blocks returned
  (:data:`robustness.STAT_COLUMNS`; the blocks of an earlier, interrupted run are
  read back from their files, those columns only) and writes the configuration's
  ``plans`` and ``summary`` rows, a row per task in task order, one file each
  (``plans/config_id=<k>/part-tasks.parquet``): a file per configuration rather
  than per task, since the rows are small and a file costs a creation and a sync
  (and its metadata) whatever its size.

A unit runs in this process or on a Dask worker: it receives a small picklable
:class:`Context` (in this process it carries the driver's validated
:class:`~sweeps.study.Design`; a Dask worker rebuilds the design once per
process from the context's resolved document), plans (cached per process),
evaluates and writes its own files.
"""
from __future__ import annotations

import dataclasses
import json
import pathlib
import time
from typing import Optional

import pyarrow as pa

from robustness import model_for, rows_table, schema_for, TABLE_SCHEMAS, with_design

CONTEXTS: dict = {}


@dataclasses.dataclass(frozen=True)
class Context:
    """What a worker needs to run any unit of a run (small and picklable).

    ``design``: the driver's validated :class:`~sweeps.study.Design` itself, for
    the units run in this process (no rebuild: the values it validated are the
    values the units use).  Pickled (to a Dask worker, another process) the
    context travels without it, and the worker builds the design once from
    ``doc_json``, the resolved document: the wire format between processes."""

    config_path: str
    doc_json: str          # the resolved config document (JSON)
    root: str              # the run folder
    manifest_json: str
    design: Optional[object] = dataclasses.field(default=None, compare=False, repr=False)

    def __getstate__(self):
        state = dict(self.__dict__)
        state["design"] = None
        return state

    def __setstate__(self, state):
        for k, v in state.items():
            object.__setattr__(self, k, v)


#: A configuration whose tasks' samples together are at most this many (each task
#: one block) is one unit of work (:func:`plan_units`).
CONFIGURATION_SAMPLES = 4096

SUMMARY, DESIGN, CONFIGURATION = -1, -2, -3   # Unit.block of the units that are not blocks


@dataclasses.dataclass(frozen=True)
class Unit:
    """One unit of work: a sample block (``block >= 0``), a configuration's
    summary (``block = SUMMARY``, every task: ``task_index = -1``), a task's
    tolerance design (``block = DESIGN``) or a whole configuration (``block =
    CONFIGURATION``, ``task_index = -1``: ``n_tasks`` tasks of samples ``lo..hi-1``)."""

    config_id: int
    task_index: int
    block: int = SUMMARY
    lo: int = 0
    hi: int = 0
    #: a summary's input: per task, its blocks' statistics (:func:`with_stats`), in block order
    stats: Optional[tuple] = dataclasses.field(default=None, compare=False, repr=False)
    n_tasks: int = 1

    @property
    def key(self) -> str:
        if self.block == SUMMARY:
            return f"c{self.config_id:05d}-summary"
        if self.block == CONFIGURATION:
            return f"c{self.config_id:05d}-tasks"
        tail = "design" if self.block == DESIGN else f"b{self.block:04d}"
        return f"c{self.config_id:05d}-t{self.task_index:04d}-{tail}"

    @property
    def samples(self) -> int:
        return max(0, self.hi - self.lo) * self.n_tasks


class Loaded:
    """A context unpacked in a worker: design, store, swept columns (cached per process)."""

    def __init__(self, ctx: Context):
        from sweeps.store import RunStore
        from sweeps.study import Design

        self.design = (ctx.design if ctx.design is not None
                       else Design(pathlib.Path(ctx.config_path), json.loads(ctx.doc_json)))
        self.store = RunStore(pathlib.Path(ctx.root), json.loads(ctx.manifest_json))
        self.swept = swept_fields(self.design)
        self._plan_keys: dict = {}
        self._schemas: dict = {}

    def plan(self, config_id: int, task_index: int):
        """``(plan or None, reason, warnings)`` of a task under a configuration
        (cached by the planner's inputs: configurations that differ only in their
        tolerances or friction share the plan).

        Raises:
          PlanInputError: the planner refused a setting; the message names the
            configuration, the task and the field.
        """
        from sweeps.tasks import PlanInputError

        cfg = self.design.configs[config_id]
        name, start, goal = self.design.tasks(config_id)[task_index]
        part = self.design.part(config_id)
        key = self._plan_keys.get((config_id, task_index))
        if key is None:
            key = self._plan_keys[config_id, task_index] = json.dumps(
                [part.vertices.tolist(), None if part.com is None else part.com.tolist(), start,
                 goal, cfg.planner.model_dump(), cfg.eps.__dict__], sort_keys=True,
                default=lambda o: dataclasses.asdict(o))   # a SensorlessStart
        try:
            out = _plan_cached(key, part, start, goal, cfg.planner, cfg.eps)
            if out[0] is not None and cfg.synthesize is not None and cfg.synthesize.enabled:
                out = _synthesized(key, cfg, part, start, goal, task_index, out)
            return out
        except PlanInputError as exc:
            point = self.design.points[config_id]
            where = f" ({', '.join(f'{p}={v!r}' for p, v in point.items())})" if point else ""
            raise PlanInputError(f"configuration {config_id}{where}, task {name}: {exc}") from None

    def task(self, unit, task_index: Optional[int] = None) -> tuple:
        """``(config, (name, start, goal), (plan or None, reason, warnings))`` of a
        unit's task (or of its configuration's task ``task_index``)."""
        cid = unit.config_id
        ti = unit.task_index if task_index is None else task_index
        return self.design.configs[cid], self.design.tasks(cid)[ti], self.plan(cid, ti)

    def write_rows(self, table: str, unit, rows: list) -> pathlib.Path:
        """A unit's rows of ``table``, each with the run id and the configuration's
        swept columns, written as the unit's file (``part-t<task>``, or
        ``part-tasks`` for a configuration's rows); returns its path."""
        cols = self.columns(unit.config_id)
        schema = self.schema(table)
        rows = [{"run_id": self.store.run_id, **cols, **r} for r in rows]
        stem = "tasks" if unit.task_index < 0 else f"t{unit.task_index:04d}"
        return self.store.write(table, unit.config_id, stem, rows_table(rows, schema),
                                schema)

    def columns(self, config_id: int) -> dict:
        """The swept columns' values of a configuration."""
        point = self.design.points[config_id]
        return {f.name: _column_value(point[path], f.type)
                for path, f in zip(self.design.paths, self.swept)}

    def schema(self, table: str) -> pa.Schema:
        """The schema of ``table`` with the study's swept columns."""
        if table not in self._schemas:
            self._schemas[table] = with_design(schema_for(table), self.swept)
        return self._schemas[table]


_PLANS: dict = {}


def _plan_cached(key: str, part, start, goal, planner, eps):
    """:func:`sweeps.tasks.plan_task`, once per process for each distinct ``key``."""
    from sweeps.tasks import plan_task

    if key not in _PLANS:
        caught: list = []
        plan, reason = plan_task(part, start, goal, planner, eps, caught)
        _PLANS[key] = (plan, reason, tuple(" ".join(str(w.message).split()) for w in caught))
    return _PLANS[key]


_SYNTHESES: dict = {}


def _synthesized(plan_key: str, cfg, part, start, goal, task_index: int, planned):
    """The task's plan chosen by robust synthesis (:func:`sweeps.tasks.synthesize_for`
    on the selection draws of the task's key: ``fold_in(key(seed), task)``, whose
    blocks fold in 0, 1, ...), once per process for each distinct set of inputs;
    ``(plan, "", warnings)`` with a line naming the choice."""
    import jax

    from sweeps.tasks import synthesize_for

    key = json.dumps([plan_key, cfg.synthesize.model_dump(), cfg.tolerances.__dict__,
                      cfg.friction.__dict__, cfg.execution.__dict__, cfg.seed, task_index,
                      cfg.model, cfg.dtype, cfg.required.model_dump()], sort_keys=True,
                     default=str)
    if key not in _SYNTHESES:
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            syn = synthesize_for(cfg, part, start, goal,
                                 jax.random.fold_in(jax.random.key(cfg.seed), task_index))
        _SYNTHESES[key] = (syn.plan, "", planned[2])
    return _SYNTHESES[key]


def loaded(ctx: Context) -> Loaded:
    """The unpacked context (one per process and run)."""
    key = (ctx.root, ctx.doc_json)
    if key not in CONTEXTS:
        CONTEXTS.clear()
        CONTEXTS[key] = Loaded(ctx)
    return CONTEXTS[key]


def swept_fields(design) -> list[pa.Field]:
    """One column per swept path: ``planner.margin_deg`` -> ``planner_margin_deg``
    (``param_<name>`` where that clashes with a table's column); int64 when
    every value is an integer, float64 for numbers, else string (JSON)."""
    fixed = set()
    for s in TABLE_SCHEMAS.values():
        fixed.update(s.names)
    out = []
    for path in design.paths:
        name = path.replace(".", "_")
        if name in fixed:
            name = "param_" + name
        vals = [p[path] for p in design.points]
        if all(isinstance(v, int) and not isinstance(v, bool) for v in vals):
            typ = pa.int64()
        elif all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in vals):
            typ = pa.float64()
        else:
            typ = pa.string()
        out.append(pa.field(name, typ))
    return out


def _column_value(v, typ):
    if typ == pa.string():
        return v if isinstance(v, str) else json.dumps(v)
    return v


#: The most units of work (sample blocks and summaries) a study may have; each is a file.
MAX_UNITS = 1_000_000


def block_size(cfg) -> int:
    """Samples per block of a configuration: its ``chunk_samples``, else what its
    model evaluates in about half a minute (:func:`robustness.block_samples`: a
    MuJoCo block holds 32-128 samples, a quasi-static one 65,536), never more
    than its ``samples``."""
    from robustness import block_samples

    return cfg.chunk_samples or min(cfg.samples, block_samples(cfg.kind, cfg.model,
                                                               cfg.friction.support))


def _whole(cfg, n_tasks: int) -> bool:
    """Whether a configuration is one unit of work (:data:`CONFIGURATION_SAMPLES`)."""
    size = block_size(cfg)
    return cfg.samples <= size and n_tasks * cfg.samples <= CONFIGURATION_SAMPLES


def count_units(design) -> int:
    """The number of units of work of a study (each configuration's tasks times
    its sample blocks of ``chunk_samples``, plus one summary per configuration;
    or the configuration as one unit), counted from the configs without listing
    or sampling them."""
    total = 0
    for cfg in design.configs:
        n_tasks = len(cfg.tasks) if isinstance(cfg.tasks, list) else cfg.tasks.sample.n
        size = block_size(cfg)
        blocks = 0 if _whole(cfg, n_tasks) else n_tasks * -(-cfg.samples // size)
        total += blocks + n_tasks * _designs(cfg) + 1
    return total


def check_units(design) -> None:
    """Refuse a study of more than :data:`MAX_UNITS` units of work (one line).

    Raises:
      ConfigError: naming ``chunk_samples`` and the fix.
    """
    from sweeps.config import ConfigError

    n = count_units(design)
    if n > MAX_UNITS:
        raise ConfigError(f"{design.path}: chunk_samples: the study has {n:,} units of work "
                          f"(sample chunks of chunk_samples samples per configuration and task, "
                          f"and a summary per configuration), more than the limit of "
                          f"{MAX_UNITS:,}; raise chunk_samples, or sweep fewer configurations "
                          "or tasks")


def plan_units(design, done: dict) -> tuple[list[Unit], list[Unit]]:
    """The units of a study that sample (whole configurations, sample blocks) and
    the configurations' summaries (of the configurations of blocks), those not
    yet in ``done``."""
    blocks, summaries = [], []
    for cid, cfg in enumerate(design.configs):
        size = block_size(cfg)
        n_tasks = len(design.tasks(cid))
        if _whole(cfg, n_tasks):
            units = [Unit(cid, -1, CONFIGURATION, 0, cfg.samples, n_tasks=n_tasks)]
        else:
            units = [Unit(cid, ti, b, lo, min(cfg.samples, lo + size)) for ti in range(n_tasks)
                     for b, lo in enumerate(range(0, cfg.samples, size))]
            units.append(Unit(cid, -1, SUMMARY))
        for u in units:
            if u.key not in done:
                (summaries if u.block == SUMMARY else blocks).append(u)
    return blocks, summaries


def check_layout(done: dict, root, design) -> None:
    """Refuse to resume a run folder whose log names units this study does not
    have: one written by an earlier nudge that split the work into other files
    (a summary file per task, or sample blocks where a configuration is now one
    unit); resuming it would write rows a second time.

    Raises:
      RunError: naming the folder and the fix.
    """
    from sweeps.store import RunError

    if not done:     # a fresh run: nothing to check
        return
    blocks, summaries = plan_units(design, {})
    known = {u.key for u in blocks + summaries + design_units(design, {})}
    if not set(done) <= known:
        raise RunError(f"{root}: was written by an earlier nudge (its files split the work "
                       "another way) and cannot be resumed; choose another --out, or delete the "
                       "folder to start over")


def _designs(cfg) -> bool:
    return cfg.design is not None and cfg.design.enabled


def design_units(design, done: dict) -> list[Unit]:
    """The tolerance-design units (one per task of a configuration with an
    enabled ``design:`` section) not yet in ``done``."""
    out = []
    for cid, cfg in enumerate(design.configs):
        if _designs(cfg):
            for ti in range(len(design.tasks(cid))):
                u = Unit(cid, ti, DESIGN)
                if u.key not in done:
                    out.append(u)
    return out


def with_stats(design, store, summaries: list, records: dict) -> list:
    """The summary units with their blocks' statistics attached (per task, in
    block order): from ``records`` (``{unit key: record}`` of the blocks this run
    finished), else read back from the blocks' files
    (:func:`sweeps.blocks.block_stats`)."""
    blocks, _ = plan_units(design, {})
    of: dict = {}
    for b in blocks:
        if b.block >= 0:
            of.setdefault(b.config_id, {}).setdefault(b.task_index, []).append(b)
    return [dataclasses.replace(u, stats=tuple(
        tuple(_block_stats(store, b, records) for b in of.get(u.config_id, {}).get(ti, ()))
        for ti in range(len(design.tasks(u.config_id))))) for u in summaries]


def _recording(fn):
    """Run a unit with its warnings recorded (returned in the record's
    ``warnings``, one line each) instead of printed by the worker.  A
    :class:`~robustness.BoundViolation` is not a warning: the summary row's
    ``bound_violated`` / ``paper_bound_violated`` columns carry it (the
    record's ``findings``)."""
    import functools
    import warnings

    from robustness import BoundViolation

    @functools.wraps(fn)
    def wrapper(ctx, unit):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            rec = fn(ctx, unit)
        lines = list(rec.get("warnings", ()))
        lines += [" ".join(str(w.message).split()) for w in caught
                  if not issubclass(w.category, BoundViolation)]
        rec["warnings"] = list(dict.fromkeys(lines))
        return rec

    return wrapper


def _sample(L: Loaded, unit: Unit, task_index: int, block: int):
    """``(Block or None, plan, warnings)``: samples ``unit.lo..unit.hi-1`` of a
    task of the unit's configuration, drawn with the key
    ``fold_in(fold_in(key(seed), task), block)`` (None without a plan)."""
    import jax

    from sweeps.blocks import sample_block

    cfg, (name, _, _), (plan, _, warns) = L.task(unit, task_index)
    if plan is None:
        return None, plan, warns
    key = jax.random.fold_in(jax.random.fold_in(jax.random.key(cfg.seed), task_index), block)
    b = sample_block(plan, cfg, cfg.physics_run(L.design.part(unit.config_id)), name,
                     unit.hi - unit.lo, key, lo=unit.lo, run_id=L.store.run_id,
                     schema=L.schema("samples"), columns=L.columns(unit.config_id))
    return b, plan, warns


@_recording
def run_block(ctx: Context, unit: Unit) -> dict:
    """Evaluate one sample block and write its files; returns the log record
    (its ``stats`` feed the task's summary, :func:`with_stats`).  A whole
    configuration's unit runs :func:`run_configuration`."""
    if unit.block == CONFIGURATION:
        return run_configuration(ctx, unit)
    t0 = time.perf_counter()
    L = loaded(ctx)
    b, plan, warns = _sample(L, unit, unit.task_index, unit.block)
    files = [] if b is None else [L.store.write("samples", unit.config_id, block_name(unit),
                                                b.table, L.schema("samples"))]
    return {"key": unit.key, "files": files, "rows": 0 if b is None else b.n,
            "seconds": time.perf_counter() - t0, "warnings": list(warns),
            "no_plan": plan is None, "stats": None if b is None else b.stats}


def run_configuration(ctx: Context, unit: Unit) -> dict:
    """A whole configuration: every task's samples (one block each, its key's
    block ``0``) and the configuration's ``plans`` and ``summary`` rows, a file
    per table, a task after the other; returns the log record."""
    import pyarrow as pa

    t0 = time.perf_counter()
    L = loaded(ctx)
    blocks, warns = [], []
    for ti in range(unit.n_tasks):
        b, _, w = _sample(L, unit, ti, 0)
        blocks.append(b)
        warns += w
    files = []
    samples = [b.table for b in blocks if b is not None]
    if samples:
        files.append(L.store.write("samples", unit.config_id, "tasks", pa.concat_tables(samples),
                                   L.schema("samples")))
    rec = _summarise(L, unit, [() if b is None else (b.stats,) for b in blocks])
    return {**rec, "key": unit.key, "files": files + rec["files"],
            "rows": sum(b.n for b in blocks if b is not None),
            "seconds": time.perf_counter() - t0, "warnings": warns}


def block_name(unit: Unit) -> str:
    """The file stem of a sample block in its configuration's folder."""
    from sweeps.blocks import block_stem

    return block_stem(unit.task_index, unit.block)


def _block_stats(store, unit: Unit, records: dict) -> Optional[dict]:
    """The statistics of a finished block: the record it returned in this run,
    else (a block of an earlier run) read from its file; ``None`` without a plan."""
    from sweeps.blocks import block_stats

    rec = records.get(unit.key)
    if rec is not None:
        return rec["stats"]
    path = store.table_path("samples", unit.config_id, block_name(unit))
    return block_stats(path) if path.exists() else None


@_recording
def run_summary(ctx: Context, unit: Unit) -> dict:
    """Summarise each task of a configuration from its blocks (all finished;
    their statistics in ``unit.stats``) and write the configuration's ``plans``
    and ``summary`` rows (a row per task, in task order)."""
    t0 = time.perf_counter()
    rec = _summarise(loaded(ctx), unit, unit.stats or ())
    return {**rec, "seconds": time.perf_counter() - t0}


def _summarise(L: Loaded, unit: Unit, stats) -> dict:
    """Write a configuration's ``plans`` and ``summary`` rows, each task's
    summary merged from its blocks' statistics (``stats``: per task, in task
    order); the log record without its ``seconds``."""
    from robustness import empty_summary
    from sweeps.blocks import summarise_blocks
    from sweeps.tasks import plan_row

    part = L.design.part(unit.config_id)
    plans, summaries = [], []
    for ti, stats in enumerate(stats):
        cfg, (name, start, goal), (plan, reason, _) = L.task(unit, ti)
        plans.append(plan_row(part, name, start, goal, plan, reason))
        if plan is None:
            kind = cfg.kind
            summaries.append(empty_summary(name, kind, model_for(cfg.model, kind), cfg.dtype,
                                           cfg.eps, cfg.required.confidence))
        else:
            summaries.append(summarise_blocks([b for b in stats if b is not None], plan, cfg,
                                              name, bound=cfg.bounds))
    files = [L.write_rows("plans", unit, plans), L.write_rows("summary", unit, summaries)]
    return {"key": unit.key, "files": files, "rows": len(summaries),
            "findings": [f for s in summaries for f in findings(s)]}


@_recording
def run_design(ctx: Context, unit: Unit) -> dict:
    """The tolerance design of a task's plan (:func:`sweeps.tasks.design_rows`, on
    the design draws of the task's key); writes its ``design`` rows."""
    import jax

    from sweeps.tasks import design_rows

    t0 = time.perf_counter()
    L = loaded(ctx)
    cfg, (name, _, _), (plan, _, _) = L.task(unit)
    files, rows = [], []
    if plan is not None:
        rows, _ = design_rows(cfg, L.design.part(unit.config_id), plan, name,
                              jax.random.fold_in(jax.random.key(cfg.seed), unit.task_index))
        files.append(L.write_rows("design", unit, rows))
    return {"key": unit.key, "files": files, "rows": len(rows),
            "seconds": time.perf_counter() - t0}


#: The summary's finding columns: ``(column, kind, the bound's columns)``.
FINDINGS = (("bound_violated", "bound violated", ("bound_position_m", "bound_theta_rad")),
            ("paper_bound_violated",
             "paper bound violated (Marigo & Bicchi's eqs. 5-6 as printed, evaluated in metres: "
             "they raise lengths to powers, so their value depends on the unit of length)",
             ("paper_bound_position_m", "paper_bound_theta_rad")))


def findings(s: dict) -> list:
    """``[(kind, one line)]`` of a summary row's findings, read from its columns
    (a bound the Monte-Carlo maximum inside the bound's model exceeds)."""
    out = []
    for col, kind, (bp, bt) in FINDINGS:
        if s.get(col):
            out.append((kind, f"task {s['task']!r}: the Monte-Carlo maximum "
                              f"{s['emp_max_pos_in_model_m']:.6g} m / "
                              f"{s['emp_max_theta_in_model_rad']:.6g} rad over "
                              f"{s['n_in_bound_model']} samples inside the bound's model, bound "
                              f"{s[bp]:.6g} m / {s[bt]:.6g} rad"))
    return out
