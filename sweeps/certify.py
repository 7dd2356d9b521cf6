"""Certify plans against part tolerances, friction and robot errors.

Usage::

    python -m sweeps.certify CONFIG.yaml [--out DIR] [--n-samples N] [--seed S] [--quiet]

For every task of the config: plan it (the Akella-Mason pose planner for a
polygon part, the Marigo-Bicchi tumble planner for a polyhedron), evaluate the
plan on ``n_samples`` perturbed samples (:func:`robustness.evaluation.evaluate`),
and give a verdict:

* ``certified (analytic bound)``: the first-order bound of
  :mod:`robustness.bounds` is within eps (position AND orientation), the
  Monte Carlo did not violate it, and no sample failed by a mode the bound
  does not model (slip, incomplete reorientation, a wrong edge or face, a
  changed hull);
* ``certified (empirical)``: otherwise, when the lower end of the two-sided
  Clopper-Pearson interval of the success probability (at ``confidence``) is
  at least the required probability;
* ``not certified``: otherwise, with the dominant failure mode (or
  ``no_plan`` when the planner found none).

A short table is printed; ``samples.parquet``, ``summary.parquet`` and
``certificates.parquet`` (schemas in :mod:`robustness.tables`, columns in
``results/README.md``) are written under DIR (default
``results/certify-<config file stem>``).  With a ``margin_search`` section, a
push task that is not certified is re-planned over a small grid of margin
angles and safety factors (smallest margin first, then smallest factor) and
the first setting that certifies is recommended.

Config (YAML; unknown keys are errors, every number is checked)::

    part: ../examples/biplus_stable.yaml   # path relative to this file, or an inline part mapping
    tolerances: {tau_v: 2.0e-5, tau_com: 1.0e-4, distribution: uniform, com_shape: disc}
    friction: {mu_f: [0.4, 0.8], mu_s: [0.3, 0.6], support_points: 16}
    execution: {start_xy: 5.0e-4, start_theta: 0.01, fence_angle: 0.002,
                distance_abs: 1.0e-4, distance_rel: 0.005}
    planner: {margin_deg: 7, safety_factor: 1.15, objective: distance}
    eps: {pos_eps_m: 0.002, theta_eps_rad: 0.035}
    required: {probability: 0.9, confidence: 0.95}
    n_samples: 300
    seed: 0
    model: quasistatic            # or exact (push tasks; tumbling is always exact)
    tasks:
      - {name: turn, start: [0, 0, 0], goal: [0.1, 0.05, 60deg]}

Angles in poses may be given in degrees with a ``deg`` suffix.  Exit status:
0 every task certified, 1 some task not certified, 2 bad input (one line
``error: ...`` naming the field and the fix), 3 internal error.
"""
import argparse
import math
import os
import pathlib
import sys
import time
import warnings
from typing import Literal, Optional, Union

import yaml
from pydantic import (BaseModel, ConfigDict, Field, StrictBool, ValidationError, field_validator,
                      model_validator)

from sweeps.terminal import Parser, angle_value, fail, run_main

EXIT_OK, EXIT_NOT_CERTIFIED, EXIT_INPUT, EXIT_INTERNAL = 0, 1, 2, 3



class ConfigError(ValueError):
    """A config that cannot be used; the one-line message names the field and the fix."""


# --------------------------------------------------------------------------
# Config schema (pydantic v2)
# --------------------------------------------------------------------------
NonNeg = Field(ge=0)


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class Tolerances(_Strict):
    """Part tolerances (metres)."""

    tau_v: float = Field(0.0, ge=0)
    tau_com: float = Field(0.0, ge=0)
    distribution: Literal["uniform", "gaussian"] = "uniform"
    sigma_v: Optional[float] = Field(None, ge=0)
    com_shape: Literal["disc", "box"] = "disc"


def _check_range(v, name):
    if v is None:
        return v
    if len(v) != 2:
        raise ValueError(f"expected a range [low, high], got {len(v)} numbers")
    if v[0] > v[1]:
        raise ValueError(f"low {v[0]} is above high {v[1]}; give [low, high]")
    return (float(v[0]), float(v[1]))


class Friction(_Strict):
    """Friction ranges (uniform)."""

    mu_f: tuple[float, float] = (0.5, 0.5)
    mu_s: tuple[float, float] = (0.5, 0.5)
    support_points: int = Field(16, ge=1, le=4096)
    weight_concentration: int = Field(1, ge=1, le=64)
    c: Optional[tuple[float, float]] = None

    @field_validator("mu_f", "mu_s")
    @classmethod
    def _coef(cls, v):
        if v[0] < 0:
            raise ValueError(f"friction coefficients must be >= 0, got {list(v)}")
        return _check_range(v, "")

    @field_validator("c")
    @classmethod
    def _c(cls, v):
        if v is not None and v[0] <= 0:
            raise ValueError(f"the limit-surface ratio c must be > 0 m, got {list(v)}")
        return _check_range(v, "")


class Execution(_Strict):
    """Robot execution errors (half-widths; m, rad, fraction)."""

    start_xy: float = Field(0.0, ge=0)
    start_theta: float = Field(0.0, ge=0)
    fence_angle: float = Field(0.0, ge=0)
    distance_abs: float = Field(0.0, ge=0)
    distance_rel: float = Field(0.0, ge=0)
    tumble_slip_xy: float = Field(0.0, ge=0)
    tumble_slip_theta: float = Field(0.0, ge=0)
    distribution: Literal["uniform", "gaussian"] = "uniform"


class Planner(_Strict):
    """Planner settings."""

    margin_deg: float = Field(7.0, ge=0, lt=90)
    safety_factor: float = Field(1.15, ge=1)
    objective: Literal["distance", "pushes"] = "distance"
    tumble_eps: Optional[float] = Field(None, gt=0)
    tumble_tau_v: float = Field(0.0, ge=0)
    tau_g: Optional[float] = Field(None, ge=0)


class Eps(_Strict):
    """Success tolerances."""

    pos_eps_m: float = Field(gt=0)
    theta_eps_rad: float = Field(gt=0)


class Required(_Strict):
    """Required success probability and the confidence of its certificate."""

    probability: float = Field(0.9, gt=0, lt=1)
    confidence: float = Field(0.95, gt=0, lt=1)


class MarginSearch(_Strict):
    """Grid for the margin recommendation (push tasks)."""

    margins_deg: list[float] = Field(default_factory=lambda: [3.0, 7.0, 12.0, 20.0])
    safety_factors: list[float] = Field(default_factory=lambda: [1.15, 1.5, 2.0])
    n_samples: int = Field(200, ge=1, le=10_000_000)
    enabled: StrictBool = True

    @field_validator("margins_deg")
    @classmethod
    def _m(cls, v):
        if not v or any(not (0 <= x < 90) for x in v):
            raise ValueError("give margin angles in degrees, 0 <= margin < 90")
        return sorted(v)

    @field_validator("safety_factors")
    @classmethod
    def _s(cls, v):
        if not v or any(x < 1 for x in v):
            raise ValueError("give safety factors >= 1")
        return sorted(v)


Angle = Union[float, str]


class Task(_Strict):
    """One task: a start and a goal pose (push) or configuration (tumble)."""

    name: str = Field(min_length=1)
    start: Optional[list[Angle]] = None
    goal: list[Angle]


class PartInline(_Strict):
    """An inline part (the part-file format)."""

    name: Optional[str] = None
    kind: Optional[Literal["polygon", "polyhedron"]] = None
    vertices: list[list[float]]
    com: Optional[list[float]] = None
    description: Optional[str] = None


class CertifyConfig(_Strict):
    """The whole certification config."""

    part: Union[str, PartInline]
    tolerances: Tolerances = Field(default_factory=Tolerances)
    friction: Friction = Field(default_factory=Friction)
    execution: Execution = Field(default_factory=Execution)
    planner: Planner = Field(default_factory=Planner)
    eps: Eps
    required: Required = Field(default_factory=Required)
    n_samples: int = Field(400, ge=1, le=10_000_000)
    seed: int = Field(0, ge=0)
    model: Literal["quasistatic", "exact"] = "quasistatic"
    dtype: Literal["float64", "float32"] = "float64"
    n_steps: int = Field(64, ge=1, le=100_000)
    tasks: list[Task] = Field(min_length=1)
    margin_search: Optional[MarginSearch] = None

    @model_validator(mode="after")
    def _unique(self):
        names = [t.name for t in self.tasks]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"tasks: task names must be unique, {dup} repeated")
        return self


_HINTS = {
    "tau_v": "the half-width of each vertex coordinate's tolerance in metres (0 for none)",
    "tau_com": "the centre-of-mass tolerance in metres (0 for none)",
    "sigma_v": "the Gaussian standard deviation in metres",
    "start_xy": "the start position error half-width in metres (0 for none)",
    "start_theta": "the start orientation error half-width in radians (0 for none)",
    "fence_angle": "the fence angle error half-width in radians (0 for none)",
    "distance_abs": "the push-distance error half-width in metres (0 for none)",
    "distance_rel": "the relative push-distance error half-width, a fraction (0 for none)",
    "tumble_slip_xy": "the slip half-width after each tumble in metres (0 for none)",
    "tumble_slip_theta": "the rotational slip half-width after each tumble in radians (0 for none)",
    "pos_eps_m": "the position accuracy in metres, > 0",
    "theta_eps_rad": "the orientation accuracy in radians, > 0",
    "probability": "the required success probability, strictly between 0 and 1 (e.g. 0.95)",
    "confidence": "the confidence level, strictly between 0 and 1 (e.g. 0.95)",
    "n_samples": "a positive number of Monte-Carlo samples",
    "margin_deg": "the margin angle in degrees, 0 <= margin < 90 (paper: 7)",
    "tumble_eps": "the tumble planner's accuracy (m / rad), > 0",
    "tumble_tau_v": "the vertex tolerance the tumble planner plans for, m (0: the nominal part)",
    "safety_factor": "the Peshkin safety factor, >= 1 (paper: 1.15)",
    "mu_f": "a range [low, high] of fence friction coefficients >= 0",
    "mu_s": "a range [low, high] of support friction coefficients >= 0",
    "c": "a range [low, high] of limit-surface ratios in metres, > 0",
}


def _loc(loc) -> str:
    out = ""
    for p in loc:
        if isinstance(p, int):
            out += f"[{p}]"
        elif p in ("str", "float", "int", "PartInline", "list[union[float,str]]"):
            continue
        else:
            out += f".{p}" if out else str(p)
    return out or "(top level)"


def _describe(errs) -> str:
    """One line for a pydantic ValidationError's errors (the first that matters)."""
    extra = [e for e in errs if e["type"] == "extra_forbidden"]
    if extra:
        names = ", ".join(f"{_loc(e['loc'])!r}" for e in extra)
        e = extra[0]
        parent = _loc(e["loc"][:-1])
        allowed = _allowed_keys(e["loc"][:-1])
        where = "at the top level" if parent == "(top level)" else f"in {parent}"
        return (f"unknown key{'s' if len(extra) > 1 else ''} {names} {where}; allowed keys: "
                f"{', '.join(allowed)} (check the spelling)")
    # a Union[str, PartInline] part reports both branches: prefer the inline branch's error
    e = errs[0]
    field = _loc(e["loc"])
    last = next((p for p in reversed(e["loc"]) if isinstance(p, str)), "")
    hint = _HINTS.get(last)
    got = e.get("input")
    typ = e["type"]
    if typ == "missing":
        return f"{field}: required key is missing" + (f"; give {hint}" if hint else "")
    if typ == "finite_number":
        return f"{field}: must be a finite number, got {got!r}" + (f"; give {hint}" if hint else "")
    ops = {"greater_than_equal": (">=", "ge"), "greater_than": (">", "gt"),
           "less_than": ("<", "lt"), "less_than_equal": ("<=", "le")}
    if typ in ops:
        op, k = ops[typ]
        limit = (e.get("ctx") or {}).get(k, "")
        return (f"{field}: must be {op} {limit}, got {got!r}" + (f"; give {hint}" if hint else ""))
    msg = e["msg"]
    if msg.startswith("Value error, "):
        msg = msg[len("Value error, "):]
        return msg if field == "(top level)" else f"{field}: {msg}"
    return f"{field}: {msg}, got {got!r}" + (f"; give {hint}" if hint else "")


def _allowed_keys(loc) -> list:
    model = CertifyConfig
    for p in loc:
        if isinstance(p, int) or model is None:
            continue
        f = model.model_fields.get(p)
        if f is None:
            if p[:1].isupper() or p in ("str", "float", "int"):  # a union branch's tag
                continue
            return []
        ann = f.annotation
        model = None
        for cand in (Tolerances, Friction, Execution, Planner, Eps, Required, MarginSearch, Task,
                     PartInline):
            if ann is cand or cand in getattr(ann, "__args__", ()) or any(
                    cand in getattr(a, "__args__", ()) for a in getattr(ann, "__args__", ())):
                model = cand
                break
    return list(model.model_fields) if model is not None else []


def parse_angle(v, field: str) -> float:
    """A number (radians) or a string ``'<number>deg'`` / ``'<number>rad'``."""
    if isinstance(v, bool):
        raise ConfigError(f"{field}: expected a number, got {v!r}")
    if isinstance(v, (int, float)):
        x = float(v)
    else:
        x = angle_value(str(v))
        if x is None:
            raise ConfigError(f"{field}: expected an angle in radians or with a 'deg' suffix "
                              f"(e.g. 1.57 or 90deg), got {v!r}")
    if not math.isfinite(x):
        raise ConfigError(f"{field}: must be finite, got {v!r}")
    return x


def _length(v, field: str) -> float:
    if isinstance(v, str) or isinstance(v, bool):
        raise ConfigError(f"{field}: expected a number in metres, got {v!r}")
    x = float(v)
    if not math.isfinite(x):
        raise ConfigError(f"{field}: must be a finite number in metres, got {v!r}")
    return x


def parse_pose(values, field: str, kind: str) -> tuple:
    """``[x, y, theta]`` (push) or ``[x, y, theta, face]`` (tumble)."""
    want = 3 if kind == "polygon" else 4
    form = "[x, y, theta]" if want == 3 else "[x, y, theta, face]"
    if len(values) != want:
        raise ConfigError(f"{field}: a {kind} task needs {form} (metres, radians"
                          f"{', face number' if want == 4 else ''}), got {len(values)} values")
    x = _length(values[0], f"{field}[0]")
    y = _length(values[1], f"{field}[1]")
    th = parse_angle(values[2], f"{field}[2]")
    if want == 3:
        return (x, y, th)
    f = values[3]
    if isinstance(f, bool) or not (isinstance(f, int) or (isinstance(f, float) and f.is_integer())):
        raise ConfigError(f"{field}[3]: the face must be an integer face number, got {f!r}")
    return (x, y, th, int(f))


def load_config(path) -> tuple[CertifyConfig, str]:
    """Read and validate a config file; returns ``(config, yaml_text)``.

    Raises:
      ConfigError: one line naming the file, the field and the fix.
    """
    path = pathlib.Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such config file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{path}: cannot read the config ({exc})") from None
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark else ""
        raise ConfigError(f"{path}: YAML syntax error: "
                          f"{' '.join(str(getattr(exc, 'problem', exc)).split())}{where}") from None
    if not isinstance(doc, dict):
        raise ConfigError(f"{path}: expected a mapping with keys "
                          f"{', '.join(CertifyConfig.model_fields)}, got {type(doc).__name__}")
    # a part given as a mapping validates against the inline model only
    try:
        cfg = CertifyConfig.model_validate(doc)
    except ValidationError as exc:
        errs = exc.errors()
        if isinstance(doc.get("part"), dict):
            errs = [e for e in errs if not (e["loc"][:1] == ("part",) and e["loc"][1:2] == ("str",))]
        raise ConfigError(f"{path}: {_describe(errs)}") from None
    return cfg, text


# --------------------------------------------------------------------------
# Running
# --------------------------------------------------------------------------
def _sampler(cfg: CertifyConfig):
    from robustness.samplers import Sampler
    from robustness.tolerances import ExecutionTolerance, FrictionRange, GeometryTolerance

    t, f, e = cfg.tolerances, cfg.friction, cfg.execution
    return Sampler(
        geometry=GeometryTolerance(tau_v=t.tau_v, tau_com=t.tau_com, distribution=t.distribution,
                                   sigma_v=t.sigma_v, com_shape=t.com_shape),
        friction=FrictionRange(mu_f=f.mu_f, mu_s=f.mu_s, support_points=f.support_points,
                               weight_concentration=f.weight_concentration, c=f.c),
        execution=ExecutionTolerance(**e.model_dump()))


def _load_part(cfg: CertifyConfig, config_path: pathlib.Path):
    from sweeps.partfile import load_part, parse_part

    if isinstance(cfg.part, str):
        p = pathlib.Path(cfg.part)
        if not p.is_absolute():
            p = config_path.parent / p
        return load_part(p)
    return parse_part(cfg.part.model_dump(exclude_none=True), config_path)


def _verdict(summary: dict, bound_ok: bool, required: float):
    """(verdict, dominant failure mode, note)."""
    uncovered = sum(summary[f"n_{m}"] for m in ("incomplete_reorientation", "wrong_edge", "slip",
                                                  "hull_changed", "wrong_face",
                                                  "combinatorics_changed"))
    n_fail = summary["n"] - summary["n_success"]
    note = ""
    if bound_ok and not summary["bound_violated"] and n_fail == 0:
        return "certified (analytic bound)", "none", note
    if bound_ok:
        if summary["bound_violated"]:
            note = "analytic bound within eps but violated by the Monte Carlo (a finding); "
        elif uncovered:
            note = (f"analytic bound within eps, but {uncovered} samples failed by modes the "
                    "bound does not model; ")
    if summary["ci_low"] >= required:
        return "certified (empirical)", summary["dominant_failure_mode"], note.rstrip("; ")
    note += (f"Clopper-Pearson lower bound {summary['ci_low']:.4f} < required {required:g}")
    return "not certified", summary["dominant_failure_mode"], note


def _plan_push(part, task_start, task_goal, cfg, margin_deg=None, safety_factor=None):
    from planning.pushing.planner import plan_pose

    return plan_pose(part.vertices, task_start, task_goal, com=part.com,
                     margin_deg=cfg.planner.margin_deg if margin_deg is None else margin_deg,
                     safety_factor=cfg.planner.safety_factor if safety_factor is None else safety_factor,
                     objective=cfg.planner.objective)


def _plan_tumble(part, start, goal, cfg):
    from planning.tumbling.planner import plan_tumble

    eps = cfg.planner.tumble_eps
    if eps is None:
        eps = 0.5 * min(cfg.eps.pos_eps_m, cfg.eps.theta_eps_rad)
    # The plan is made for the nominal part (tau_v = planner.tumble_tau_v, default 0): its
    # robustness to the config's tolerances is what the Monte Carlo and the first-order
    # bound measure.  The paper's worst-case tau_v analysis (eqs. 5, 6) is far looser and
    # would declare most goals not solvable.
    return plan_tumble(part.vertices, goal, start=start, com=part.com, eps=eps,
                       tau_v=cfg.planner.tumble_tau_v, tau_g=cfg.planner.tau_g)


def _no_plan_fields(reason: str) -> dict:
    """Certificate fields of a task the planner could not serve (nothing sampled)."""
    return dict(n_samples=0, success_rate=math.nan, ci_low=math.nan, ci_high=math.nan,
                bound_position_m=math.nan, bound_theta_rad=math.nan, bound_within_eps=False,
                bound_violated=None, verdict="not certified", dominant_failure_mode="no_plan",
                note=f"planner: {reason}")


def run(cfg: CertifyConfig, config_path: pathlib.Path, config_text: str, out: pathlib.Path,
        quiet: bool = False) -> tuple[int, list]:
    """Run a certification; returns (exit status, certificate rows)."""
    import jax
    import jax.numpy as jnp
    import pandas as pd

    from kernels.polygon import PartError
    from planning.pushing.planner import PlanningError
    from robustness import tables
    from sweeps import parquet
    from robustness.evaluation import BoundViolation, evaluate

    part = _load_part(cfg, config_path)
    sampler = _sampler(cfg)
    dtype = jnp.float64 if cfg.dtype == "float64" else jnp.float32
    key = jax.random.key(cfg.seed)
    req, conf = cfg.required.probability, cfg.required.confidence
    pe, te = cfg.eps.pos_eps_m, cfg.eps.theta_eps_rad
    sample_frames, summaries, certs = [], [], []
    all_params: list = []

    def log(msg):
        if not quiet:
            sys.stderr.write(msg + "\n")
            sys.stderr.flush()

    for ti, task in enumerate(cfg.tasks):
        t0 = time.perf_counter()
        goal = parse_pose(task.goal, f"tasks[{ti}].goal", part.kind)
        if task.start is None:
            if part.kind == "polygon":
                raise ConfigError(f"tasks[{ti}].start: a push task needs a start pose [x, y, theta]")
            start = (0.0, 0.0, 0.0, 0)
        else:
            start = parse_pose(task.start, f"tasks[{ti}].start", part.kind)
        row = dict(task=task.name, kind="push" if part.kind == "polygon" else "tumble",
                   part=part.name, model=cfg.model if part.kind == "polygon" else "exact",
                   start_x_m=start[0], start_y_m=start[1], start_theta_rad=start[2],
                   start_face=start[3] if len(start) == 4 else -1,
                   goal_x_m=goal[0], goal_y_m=goal[1], goal_theta_rad=goal[2],
                   goal_face=goal[3] if len(goal) == 4 else -1,
                   margin_deg=cfg.planner.margin_deg if part.kind == "polygon" else math.nan,
                   safety_factor=cfg.planner.safety_factor if part.kind == "polygon" else math.nan,
                   pos_eps_m=pe, theta_eps_rad=te, required_probability=req, confidence=conf,
                   n_samples=cfg.n_samples, recommended_margin_deg=math.nan,
                   recommended_safety_factor=math.nan)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                plan = (_plan_push(part, start, goal, cfg) if part.kind == "polygon"
                        else _plan_tumble(part, start, goal, cfg))
        except (PlanningError, PartError, ValueError, ArithmeticError) as exc:
            reason = " ".join(str(exc).split())
            if isinstance(exc, (PartError,)) or (isinstance(exc, ValueError)
                                                 and not isinstance(exc, PlanningError)):
                raise ConfigError(f"tasks[{ti}] ({task.name}): {reason}") from None
            row.update(plan_steps=0, plan_distance_m=math.nan, plan_verdict="no_plan",
                       **_no_plan_fields(reason))
            certs.append(row)
            log(f"[{task.name}] no plan: {reason}")
            continue
        if part.kind == "polygon":
            row.update(plan_steps=plan.n_pushes, plan_distance_m=plan.total_distance,
                       plan_verdict="solved")
        else:
            row.update(plan_steps=plan.n_tumbles, plan_distance_m=math.nan,
                       plan_verdict=plan.verdict)
            if plan.verdict != "solved":
                reason = " ".join(str(plan.reason).split())
                row.update(**_no_plan_fields(reason))
                certs.append(row)
                log(f"[{task.name}] not solvable: {reason}")
                continue
        tkey = jax.random.fold_in(key, ti)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", BoundViolation)
            ev = evaluate(plan, sampler, cfg.n_samples, tkey, model=cfg.model, dtype=dtype,
                          pos_eps_m=pe, theta_eps_rad=te, confidence=conf, n_steps=cfg.n_steps,
                          task=task.name)
        for w in caught:
            if issubclass(w.category, BoundViolation):
                sys.stderr.write(f"WARNING: {' '.join(str(w.message).split())}\n")
        s = ev.summary
        bp, bt = s["bound_position_m"], s["bound_theta_rad"]
        bound_ok = bool(math.isfinite(bp) and math.isfinite(bt) and bp <= pe and bt <= te)
        verdict, dominant, note = _verdict(s, bound_ok, req)
        row.update(success_rate=s["success_rate"], ci_low=s["ci_low"], ci_high=s["ci_high"],
                   bound_position_m=bp, bound_theta_rad=bt, bound_within_eps=bound_ok,
                   bound_violated=s["bound_violated"], verdict=verdict,
                   dominant_failure_mode=dominant, note=note)
        if (verdict == "not certified" and part.kind == "polygon" and cfg.margin_search is not None
                and cfg.margin_search.enabled):
            rec = _margin_search(part, start, goal, cfg, sampler, tkey, dtype, log)
            if rec is not None:
                row.update(recommended_margin_deg=rec[0], recommended_safety_factor=rec[1])
                row["note"] = (row["note"] + f"; margin {rec[0]:g} deg, safety factor {rec[1]:g} "
                               "certifies").lstrip("; ")
            else:
                row["note"] = (row["note"] + "; no margin / safety factor of the grid certifies"
                               ).lstrip("; ")
        certs.append(row)
        sample_frames.append(ev.samples)
        all_params.append(ev.param_columns)
        summaries.append(s)
        log(f"[{task.name}] {verdict} ({time.perf_counter() - t0:.1f} s)")

    # ---- tables ----
    out.mkdir(parents=True, exist_ok=True)
    seen, cols = set(), []
    for pc in all_params:
        for c in pc:
            if c not in seen:
                seen.add(c)
                cols.append(c)
    schema = tables.samples_schema(cols)
    if sample_frames:
        samples = pd.concat(sample_frames, ignore_index=True, sort=False)
    else:
        samples = pd.DataFrame({f.name: [] for f in schema})
    for c in cols:
        if c not in samples:
            samples[c] = math.nan
    parquet.write_table(samples[schema.names], out / "samples.parquet", schema, config_text,
                       cfg.seed, "samples")
    parquet.write_table(tables.frame(summaries, tables.SUMMARY_SCHEMA), out / "summary.parquet",
                       tables.SUMMARY_SCHEMA, config_text, cfg.seed, "summary")
    parquet.write_table(tables.frame(certs, tables.CERTIFICATES_SCHEMA),
                       out / "certificates.parquet", tables.CERTIFICATES_SCHEMA, config_text,
                       cfg.seed, "certificates")
    return (EXIT_OK if all(c["verdict"].startswith("certified") for c in certs)
            else EXIT_NOT_CERTIFIED), certs


def _margin_search(part, start, goal, cfg, sampler, key, dtype, log):
    """Smallest (margin_deg, safety_factor) of the grid whose plan certifies
    empirically (or analytically); None if none does."""
    from planning.pushing.planner import PlanningError
    from robustness.evaluation import evaluate

    ms = cfg.margin_search
    for m in ms.margins_deg:
        for sf in ms.safety_factors:
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    plan = _plan_push(part, start, goal, cfg, margin_deg=m, safety_factor=sf)
            except (PlanningError, ValueError):
                continue
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ev = evaluate(plan, sampler, ms.n_samples, key, model=cfg.model, dtype=dtype,
                              pos_eps_m=cfg.eps.pos_eps_m, theta_eps_rad=cfg.eps.theta_eps_rad,
                              confidence=cfg.required.confidence, n_steps=cfg.n_steps,
                              bound=False)
            ok = ev.summary["ci_low"] >= cfg.required.probability
            log(f"    margin {m:g} deg, safety factor {sf:g}: success "
                f"{ev.summary['success_rate']:.3f} (CP low {ev.summary['ci_low']:.3f})"
                f"{' -> certifies' if ok else ''}")
            if ok:
                return (m, sf)
    return None


def format_table(certs: list) -> str:
    """The short verdict table printed on stdout."""
    hdr = (f"{'task':16s} {'kind':6s} {'steps':>5s} {'success':>8s} {'CP low':>10s} "
           f"{'bound mm':>9s} {'bound deg':>9s} {'verdict':28s} {'dominant failure':24s}")
    lines = [hdr, "-" * len(hdr)]
    for c in certs:
        def f(v, fmt):
            return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else format(v, fmt)
        lines.append(
            f"{c['task'][:16]:16s} {c['kind']:6s} {c.get('plan_steps', 0):5d} "
            f"{f(c.get('success_rate'), '.4f'):>8s} {f(c.get('ci_low'), '.4f'):>10s} "
            f"{f(None if c.get('bound_position_m') is None else c['bound_position_m'] * 1e3, '.3f'):>9s} "
            f"{f(None if c.get('bound_theta_rad') is None else math.degrees(c['bound_theta_rad']), '.3f'):>9s} "
            f"{c['verdict']:28s} {c['dominant_failure_mode']:24s}")
        if c.get("note"):
            lines.append(f"{'':16s} note: {c['note']}")
    return "\n".join(lines)


def build_parser() -> argparse.ArgumentParser:
    p = Parser(prog="python -m sweeps.certify",
                description="Certify push / tumble plans against tolerances (Monte Carlo + "
                            "analytic bounds); writes Parquet tables.")
    p.add_argument("config", help="certification config (YAML)")
    p.add_argument("--out", help="output folder (default results/certify-<config stem>)")
    p.add_argument("--n-samples", type=int, help="override n_samples")
    p.add_argument("--seed", type=int, help="override seed")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    return p


def _enable_compilation_cache() -> None:
    """Persist compiled kernels across runs (NUDGE_JAX_CACHE, default
    ~/.cache/nudge/jax; set it to an empty string to disable)."""
    d = os.environ.get("NUDGE_JAX_CACHE", str(pathlib.Path.home() / ".cache" / "nudge" / "jax"))
    if not d:
        return
    try:
        import jax

        pathlib.Path(d).mkdir(parents=True, exist_ok=True)
        jax.config.update("jax_compilation_cache_dir", d)
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)
    except Exception:  # noqa: BLE001 - a cache is an optimisation, never a failure
        pass


def main(argv=None) -> int:
    """Run the command line; returns the exit status."""
    args = build_parser().parse_args(sys.argv[1:] if argv is None else argv)
    path = pathlib.Path(args.config)
    try:
        cfg, text = load_config(path)
        upd = {}
        if args.n_samples is not None:
            if args.n_samples < 1:
                raise ConfigError(f"--n-samples: must be >= 1, got {args.n_samples}")
            upd["n_samples"] = args.n_samples
        if args.seed is not None:
            if args.seed < 0:
                raise ConfigError(f"--seed: must be >= 0, got {args.seed}")
            upd["seed"] = args.seed
        if upd:
            cfg = cfg.model_copy(update=upd)
        from sweeps.partfile import PartFileError
        try:
            part = _load_part(cfg, path)
        except PartFileError as exc:
            raise ConfigError(f"part: {exc}") from None
        for ti, task in enumerate(cfg.tasks):
            parse_pose(task.goal, f"tasks[{ti}].goal", part.kind)
            if task.start is not None:
                parse_pose(task.start, f"tasks[{ti}].start", part.kind)
            elif part.kind == "polygon":
                raise ConfigError(f"tasks[{ti}].start: a push task needs a start pose "
                                  "[x, y, theta]")
    except ConfigError as exc:
        return fail(str(exc))
    out = pathlib.Path(args.out) if args.out else pathlib.Path("results") / f"certify-{path.stem}"
    _enable_compilation_cache()
    try:
        code, certs = run(cfg, path, text, out, quiet=args.quiet)
    except ConfigError as exc:
        return fail(str(exc))
    sys.stdout.write(format_table(certs) + "\n")
    sys.stdout.write(f"wrote {out / 'samples.parquet'}, {out / 'summary.parquet'}, "
                     f"{out / 'certificates.parquet'}\n")
    return code


if __name__ == "__main__":
    run_main(main)
