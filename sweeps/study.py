"""Parameter-study configs: the schema, loading with ``--set`` overrides, tasks,
and the design (one validated config per configuration id).

A study (YAML; unknown keys are errors; units metres and radians, angles may
carry ``deg``, lengths a unit: ``tau_v: 0.05 mm``, :mod:`sweeps.units`)::

    study: margins                      # results/<study>/<run-id>/ (default: file stem)
    kind: push                          # push | tumble (must match the part)
    part: nice_stable                   # bundled name, a path (a part file, or a CAD file:
                                        # plate.dxf, bracket.stl), or an inline part (the
                                        # part-file keys: vertices, or mesh / outline /
                                        # footprint with units: mm, sweeps.partfile)
    tasks:                              # explicit list, or sampled goals:
      sample: {n: 6, annulus: [0.05, 0.15], heading: [-180deg, 180deg]}
    # an explicit push task may start unknown (sensorless posing, issue 40):
    #   - {name: feed, start: {heading: any, region: [0, 0.04, 0, 0.04]}, goal: [...]}
    # (heading: [lo, hi] for a known interval; its samples start uniformly there)
    planner: {margin_deg: 7, safety_factor: 1.15}   # + objective, strategy (search | paper),
                                        # support_c [lo, hi] m, min_fence_mu, workspace
                                        # [xmin, xmax, ymin, ymax] m, max_reorients (24),
                                        # extra_steps (3); tumble_eps, tumble_tau_v, tau_g
    tolerances: {tau_v: 2.0e-5}         # robustness.GeometryTolerance
    friction: {mu_f: [0.5, 0.8]}        # robustness.FrictionRange
    execution: {start_xy: 5.0e-4}       # robustness.ExecutionTolerance
    eps: {pos_eps_m: 0.002, theta_eps_rad: 0.035}
    model: quasistatic                  # quasistatic | exact | mujoco (physics rollouts)
    physics: {backend: c, stroke: planned, cell: {timestep: 0.004}}   # model: mujoco only
    samples: 200                        # Monte-Carlo samples per (configuration, task)
    chunk_samples: 200                  # samples per unit of work (resume granularity; default:
                                        # about 30 s of work, robustness.block_samples)
    seed: 0
    executor: local                     # local | dask | {kind: dask, workers: 2, address: ...}
    params:                             # the swept axes (sweeps.design; at most
                                        # 100,000 configurations, counted first)
      planner.margin_deg: [3, 7, 12]
      friction.mu_f: {linspace: [0.3, 0.9, 3]}
"""
from __future__ import annotations

import copy
import json
import math
import pathlib
from typing import Annotated, Any, Literal, Optional, Union

import numpy as np
from pydantic import Discriminator, Field, StrictBool, Tag, model_validator

from robustness import KINDS, kind_for_part
from robustness.physics import check_pad_friction

from sweeps import catalog
from sweeps.config import (Angle, ConfigError, Design as DesignSection, Evaluation, PartInline,
                           Strict, Synthesize, Task, TaskPoses, check_sensorless, explicit_tasks,
                           parse_angle, parse_pose, validate)
from sweeps.design import expand, parse_overrides, set_path
from sweeps.plausible import check_design, wrap
from sweeps.store import run_id
from sweeps.units import at_path
from sweeps.yamlio import dump_yaml, read_yaml

#: the study kind of each part kind (the dispatch table's ``part_kind``, robustness.KINDS:
#: the first row of a part kind, its known-start plans; a sensorless task is a push study's)
KIND_OF_PART = {pk: kind_for_part(pk) for pk in {k.part_kind for k in KINDS.values()}}

#: Keys that say where and how a study runs, not what it computes.
OPERATIONAL = ("executor", "output", "report")


class GoalSampling(Strict):
    """Sampled tasks: ``n`` goals around a start (seeded from the study's seed)."""

    n: int = Field(ge=1, le=100_000)
    start: Optional[list[Angle]] = None
    annulus: Optional[tuple[float, float]] = None      # radii (m) about the start position
    box: Optional[tuple[tuple[float, float], tuple[float, float]]] = None  # [[x0, x1], [y0, y1]] m
    heading: tuple[Angle, Angle] = ("-180deg", "180deg")   # goal orientation range
    faces: Optional[list[int]] = None                  # tumble studies: goal faces (default all)

    @model_validator(mode="after")
    def _one_region(self):
        if (self.annulus is None) == (self.box is None):
            raise ValueError("give exactly one goal region: annulus: [r_min, r_max] (metres "
                             "about the start) or box: [[x_min, x_max], [y_min, y_max]]")
        if self.annulus is not None and not 0 <= self.annulus[0] <= self.annulus[1]:
            raise ValueError(f"annulus: expected 0 <= r_min <= r_max (m), got {list(self.annulus)}")
        if self.box is not None and any(lo > hi for lo, hi in self.box):
            raise ValueError(f"box: expected [[x_min, x_max], [y_min, y_max]] with min <= max, "
                             f"got {[list(b) for b in self.box]}")
        return self


class SampledTasks(Strict):
    sample: GoalSampling


class Executor(Strict):
    """Where the units of work run: in this process, or on Dask distributed."""

    kind: Literal["local", "dask"] = "local"
    workers: int = Field(2, ge=1, le=1024)          # LocalCluster processes
    threads_per_worker: int = Field(1, ge=1, le=64)
    address: Optional[str] = None                   # an existing cluster, e.g. tcp://10.0.0.5:8786
    dashboard: StrictBool = False                   # LocalCluster's dashboard (off by default)


def _tasks_kind(v) -> str:
    return "list" if isinstance(v, list) else "sample"


def _executor_kind(v) -> str:
    return "name" if isinstance(v, str) else "spec"


class Study(Evaluation):
    """One configuration of a study (``params`` already applied)."""

    study: Optional[str] = Field(None, pattern=r"^[A-Za-z0-9_.-]+$")
    kind: Literal["push", "tumble"]
    part: Union[str, PartInline]
    tasks: Annotated[Union[Annotated[list[Task], Tag("list")],
                           Annotated[SampledTasks, Tag("sample")]],
                     Discriminator(_tasks_kind)]
    samples: int = Field(200, ge=1, le=100_000_000)
    chunk_samples: Optional[int] = Field(None, ge=1, le=100_000_000)
    params: dict[str, Any] = Field(default_factory=dict)
    executor: Annotated[Union[Annotated[Literal["local", "dask"], Tag("name")],
                              Annotated[Executor, Tag("spec")]],
                        Discriminator(_executor_kind)] = "local"
    output: str = "results"
    bounds: StrictBool = True        # the analytic bounds in the summary (one compile per plan shape)
    synthesize: Optional[Synthesize] = None   # robust synthesis of every task's plan
    design: Optional[DesignSection] = None    # tolerance design of every task's plan
    report: StrictBool = True        # report.html at the end

    @property
    def executor_spec(self) -> Executor:
        return Executor(kind=self.executor) if isinstance(self.executor, str) else self.executor


# --------------------------------------------------------------------------
# The resolved study
# --------------------------------------------------------------------------
class Design:
    """A study as it will run: the resolved config text, the swept paths and one
    validated :class:`Study` per configuration id, their parts and tasks.

    Attributes:
      path: the config file; base: its folder (part paths are relative to it).
      doc: the resolved document (``--set`` applied); text: its YAML (stored in
        every file's metadata and in the manifest).
      name: the study's name; run_id: ``r`` + 10 hex digits of the resolved
        config's hash (the same command resumes the same run).
      paths: swept dotted paths; points: their values per configuration.
      configs: one :class:`Study` per configuration.
    """

    def __init__(self, path: pathlib.Path, doc: dict):
        self.path = pathlib.Path(path)
        self.base = self.path.parent
        self.doc = doc
        self.text = dump_yaml(doc)
        self.name = doc.get("study") or self.path.stem
        # the run's identity leaves out where and how it runs: the same study resumes on
        # another executor
        ident = {k: v for k, v in doc.items() if k not in OPERATIONAL}
        self.identity = dump_yaml(ident)
        self.run_id = run_id(doc, OPERATIONAL)
        top = validate(Study, doc)
        self.paths, self.points = expand(doc.get("params") or {}, top.seed)
        try:   # swept lengths with a unit ('0.05 mm') in metres: numeric columns in the tables
            self.points = [{p: at_path(p, v) for p, v in pt.items()} for pt in self.points]
        except ValueError as exc:
            raise ConfigError(f"params.{exc}") from None
        self.configs = []
        for i, point in enumerate(self.points):
            d = copy.deepcopy(doc)
            d.pop("params", None)
            for p, v in point.items():
                _apply(d, p, v)
            try:
                self.configs.append(validate(Study, d))
            except ConfigError as exc:
                where = ", ".join(f"{p}={v!r}" for p, v in point.items())
                lines = [f"params: configuration {i} ({where}): {ln}" for ln in exc.lines]
                raise ConfigError(lines[0], lines) from None
        self._parts: dict = {}
        self._tasks: dict = {}
        self.warnings: list = []   # plausibility warnings (sweeps.plausible), by load_design

    @property
    def top(self) -> Study:
        return self.configs[0]

    def part(self, config_id: int):
        """The :class:`~sweeps.partfile.PartFile` of a configuration (cached)."""
        cfg = self.configs[config_id]
        key = _part_key(cfg) + cfg.kind   # a mesh named directly: footprint (push) or hull
        if key not in self._parts:
            self._parts[key] = load_part_ref(cfg.part, self.base,
                                             KINDS[cfg.kind].part_kind)
        return self._parts[key]

    def parts(self) -> list:
        """The distinct parts of the configurations, in order of first use."""
        seen = {}
        for cid in range(len(self.configs)):
            part = self.part(cid)
            seen.setdefault(id(part), part)
        return list(seen.values())

    def tasks(self, config_id: int) -> list[TaskPoses]:
        """The :class:`~sweeps.config.TaskPoses` of a configuration's tasks (derived once per
        distinct part, task list and seed: every unit of a run asks)."""
        cfg = self.configs[config_id]
        part = self.part(config_id)
        key = (_part_key(cfg), repr(cfg.tasks), cfg.seed)
        if key not in self._tasks:
            self._tasks[key] = tuple(explicit_tasks(cfg.tasks, part.kind)
                                     if isinstance(cfg.tasks, list)
                                     else sample_tasks(cfg.tasks.sample, part, cfg.seed))
        return list(self._tasks[key])


def _part_key(cfg) -> str:
    """What identifies a configuration's part (a file reference or an inline part)."""
    return json.dumps(cfg.part if isinstance(cfg.part, str) else cfg.part.model_dump(),
                      sort_keys=True)


def _apply(doc: dict, path: str, value) -> None:
    """Set a swept value; a scalar on a range field (``friction.mu_f``) sets both ends; a
    length with a unit (``'0.05 mm'``) on a length field is read as metres (:mod:`sweeps.units`)."""
    head, _, last = path.rpartition(".")
    try:
        value = at_path(path, value)
    except ValueError as exc:
        raise ConfigError(f"params.{exc}") from None
    try:
        cur = doc
        for p in head.split(".") if head else []:
            cur = cur.get(p, {}) if isinstance(cur, dict) else {}
        old = cur.get(last) if isinstance(cur, dict) else None
    except AttributeError:
        old = None
    if (isinstance(value, (int, float)) and not isinstance(value, bool)
            and (path in RANGE_FIELDS or (isinstance(old, list) and len(old) == 2))):
        value = [value, value]
    set_path(doc, path, value)


RANGE_FIELDS = ("friction.mu_f", "friction.mu_s", "friction.c")


def load_part_ref(ref, base: pathlib.Path, kind: Optional[str] = None):
    """A part given as a bundled name, a path (relative to ``base``: a part file,
    or a CAD file, read as ``kind`` ``polygon`` / ``polyhedron`` when a mesh) or
    inline, its geometry checked (:func:`sweeps.partfile.check_geometry`): a
    degenerate part is a config error (``part.vertices: ...`` inline), before
    any work."""
    from sweeps.partfile import INLINE, PartFileError, check_geometry, load_part, parse_part

    inline = base / INLINE
    try:
        if isinstance(ref, str):
            try:
                path = catalog.find_part(ref, base)
            except FileNotFoundError as exc:
                raise ConfigError(f"part: {ref!r}: {exc}") from None
            try:
                part = load_part(path, kind=kind)
            except PartFileError as exc:
                if not exc.missing_unit:
                    raise
                from sweeps.cad import cad_kind   # a CAD file named directly: the config's fix

                key = "outline" if cad_kind(path) == "outline" else (
                    "footprint" if kind == "polygon" else "mesh")
                raise PartFileError(f"{exc}; in a config: part: {{{key}: {ref}, units: mm}}") from None
        else:
            part = parse_part(ref.model_dump(exclude_none=True), inline)
        check_geometry(part)
        return part
    except PartFileError as exc:
        msg = str(exc)
        if not isinstance(ref, str) and msg.startswith(f"{inline}: "):
            raise ConfigError(f"part.{msg[len(str(inline)) + 2:]}") from None
        raise ConfigError(f"part: {msg}") from None


def sample_tasks(s: GoalSampling, part, seed: int) -> list[TaskPoses]:
    """``n`` goals in the annulus or box with headings uniform in the range
    (faces uniform among ``faces`` for a polyhedron), seeded by ``seed``."""
    kind = part.kind
    start = parse_pose(s.start, "tasks.sample.start", kind) if s.start is not None else \
        ((0.0, 0.0, 0.0) if kind == "polygon" else (0.0, 0.0, 0.0, 0))
    h0 = parse_angle(s.heading[0], "tasks.sample.heading[0]")
    h1 = parse_angle(s.heading[1], "tasks.sample.heading[1]")
    if h1 < h0:
        raise ConfigError(f"tasks.sample.heading: expected [low, high], got {list(s.heading)}")
    rng = np.random.default_rng([int(seed), 0x7a5c])
    faces = None
    if kind == "polyhedron":
        from kernels import make_polyhedron

        n_faces = make_polyhedron(part.vertices, part.com).n_faces
        faces = s.faces if s.faces is not None else list(range(n_faces))
        bad = [f for f in faces if not 0 <= f < n_faces]
        if bad:
            raise ConfigError(f"tasks.sample.faces: faces {bad} do not exist; the part has faces "
                              f"0..{n_faces - 1}")
    elif s.faces is not None:
        raise ConfigError("tasks.sample.faces: applies to polyhedra only (tumble studies)")
    out = []
    for i in range(s.n):
        if s.annulus is not None:
            r0, r1 = s.annulus
            r = math.sqrt(r0 * r0 + rng.random() * (r1 * r1 - r0 * r0))  # uniform in area
            a = rng.random() * 2 * math.pi
            x, y = start[0] + r * math.cos(a), start[1] + r * math.sin(a)
        else:
            (x0, x1), (y0, y1) = s.box
            x, y = x0 + rng.random() * (x1 - x0), y0 + rng.random() * (y1 - y0)
        th = wrap(h0 + rng.random() * (h1 - h0))    # stored in (-pi, pi]
        goal = (x, y, th) if faces is None else (x, y, th, int(faces[rng.integers(len(faces))]))
        out.append(TaskPoses(f"goal{i:03d}", start, goal))
    return out


# --------------------------------------------------------------------------
# Loading
# --------------------------------------------------------------------------
def load_design(ref, overrides=()) -> Design:
    """Read a study (a path, or a bundled study's name), apply ``--set``
    overrides, validate every configuration, resolve parts and tasks, and
    check the values' plausibility (:mod:`sweeps.plausible`; its warning lines
    in ``design.warnings``, for the caller to show).

    Raises:
      UserError: one line per mistake (``lines``: a ``ConfigError``, or the
        file's ``YamlError``), naming the field path and the fix.
    """
    try:
        path = catalog.find_study(ref)
    except FileNotFoundError as exc:
        raise ConfigError(f"{ref}: {exc}") from None
    doc, _ = read_yaml(path, "study config")   # a YamlError names the file
    if not isinstance(doc, dict):
        raise ConfigError(f"{path}: expected a mapping with keys {', '.join(Study.model_fields)}")
    doc = copy.deepcopy(doc)
    for p, (v, is_axis) in parse_overrides(overrides).items():
        axis = p[len("params."):] if p.startswith("params.") else (p if is_axis else None)
        if not isinstance(doc.get("params"), dict):
            doc["params"] = {}
        if axis is not None:
            doc["params"][axis] = v
        else:
            doc["params"].pop(p, None)
            _apply(doc, p, v)
    if not doc.get("params"):
        doc.pop("params", None)
    _check_param_paths(doc)
    try:
        design = Design(path, doc)
    except ConfigError as exc:
        raise exc.within(path) from None
    for cid in range(len(design.configs)):
        try:
            part = design.part(cid)
        except ConfigError as exc:
            raise ConfigError(f"{path}: {exc}") from None
        want = KIND_OF_PART[part.kind]
        if design.configs[cid].kind != want:
            raise ConfigError(f"{path}: kind: the part {part.name!r} is a {part.kind}, so the study "
                              f"kind must be {want}")
        tasks = design.tasks(cid)
        try:
            cfg = design.configs[cid]
            check_sensorless(cfg, tasks)
            cfg.physics_run(part)   # the part's material against physics.cell
            if cfg.model == "mujoco" and part.kind == "polyhedron":
                check_pad_friction(cfg.friction, "tumble", part_polyhedron(part),
                                   cfg.physics.cell.grip_ratio)
        except ValueError as exc:
            raise ConfigError(f"{path}: {exc}") from None
    try:
        design.warnings = check_design(design)
    except ConfigError as exc:
        raise exc.within(path) from None
    return design


def part_polyhedron(part):
    """The part file's polyhedron (:func:`kernels.make_polyhedron`), warnings muted."""
    import warnings

    from kernels import make_polyhedron

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return make_polyhedron(part.vertices, part.com)


def _check_param_paths(doc: dict) -> None:
    """Every swept path names a field of the study (before anything is expanded)."""
    from sweeps.config import allowed_keys

    params = doc.get("params") or {}
    if not isinstance(params, dict):
        raise ConfigError("params: expected a mapping of dotted field paths to axes")
    for p in params:
        if p == "zip":
            continue
        parts = p.split(".")
        if parts[0] in ("params", "study", "executor", "output", "report"):
            raise ConfigError(f"params.{p}: {parts[0]!r} cannot be swept")
        for i in range(len(parts)):
            keys = allowed_keys(Study, tuple(parts[:i]))
            if parts[i] not in keys:
                where = ".".join(parts[:i]) or "the top level"
                raise ConfigError(f"params.{p}: no field {parts[i]!r} in {where}; fields: "
                                  f"{', '.join(keys)}")
