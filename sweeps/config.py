"""Config files of nudge (pydantic v2): the sections shared by certification
configs and parameter studies, and the error messages a user reads.

The config layer only validates and converts: tolerances are the robustness
layer's own types (:class:`~robustness.GeometryTolerance`,
:class:`~robustness.FrictionRange`, :class:`~robustness.ExecutionTolerance`, and
the success criterion ``eps:`` :class:`~robustness.SuccessCriterion`,
stdlib dataclasses that pydantic validates field by field and whose
``__post_init__`` checks the values), so a tolerance is defined once.

Every mistake becomes one line naming its dotted field path and the fix
(:func:`describe`).  Units: metres, radians; an angle may be written with a
``deg`` suffix (``90deg``), a length with a unit (``0.05 mm``, :mod:`sweeps.units`).
"""
from __future__ import annotations

import dataclasses
import math
import typing
from typing import Any, Literal, Optional, Union

from pydantic import (BaseModel, ConfigDict, Field, StrictBool, StrictInt, ValidationError,
                      create_model, field_validator, model_validator)

from kernels import (FAMILY, PLAN_SUPPORTS, PLANNED_FAMILIES, REALISABLE_SUPPORTS,
                     SUPPORT_FAMILIES)
from robustness.physics import PhysicsSettings
from planning import OBJECTIVES, STRATEGIES, PushOptions
from robustness import (GRID_MARGINS_DEG, GRID_SAFETY_FACTORS, GRID_STRATEGIES, ExecutionTolerance,
                        FrictionRange, GeometryTolerance, SuccessCriterion, CONFIDENCE, DEFAULT_MODEL,
                        REQUIRED_PROBABILITY)
from sweeps.budget import MAX_SAMPLES
from sweeps.errors import UserError
from sweeps.partfile import part_fields
from sweeps.plausible import wrap
from sweeps.terminal import EFFORT_BOUNDS, angle_value

#: The push planner's defaults (their one home is planning.PushOptions).
PUSH_DEFAULTS = PushOptions()


class ConfigError(UserError):
    """A config that cannot be used (``lines``: one message per mistake, each
    names the field and the fix)."""


def _admits_bool(annotation) -> bool:
    """Whether a field's type takes ``true``/``false`` anywhere in it (``bool``,
    ``StrictBool``, ``Any``, or a union, list, mapping or annotation holding one)."""
    if annotation is bool or annotation is Any:
        return True
    return any(_admits_bool(a) for a in typing.get_args(annotation))


def _integral(annotation) -> bool:
    """Whether a field's type is an integer (``int``, ``StrictInt``, optional or not)."""
    if annotation is int:
        return True
    args = [a for a in typing.get_args(annotation) if a is not type(None)]
    if typing.get_origin(annotation) is typing.Annotated:
        args = args[:1]
    return bool(args) and all(_integral(a) for a in args)


def _bool_at(value, annotation):
    """The dotted path inside ``value`` of a ``true``/``false`` that its type
    reads as a number (``""``: the value itself), or None.  Looks into lists and
    into the mappings of the robustness layer's dataclasses (tolerances)."""
    if _admits_bool(annotation):
        return None
    if isinstance(value, bool):
        return ""
    if isinstance(value, (list, tuple)):
        return "" if any(_bool_at(v, float) is not None for v in value) else None
    if isinstance(value, dict):
        for cls in (annotation, *typing.get_args(annotation)):
            if dataclasses.is_dataclass(cls):
                hints = typing.get_type_hints(cls)
                for key, v in value.items():
                    if key in hints and (sub := _bool_at(v, hints[key])) is not None:
                        return f".{key}{sub}"
    return None


class Strict(BaseModel):
    """Base of every config section: unknown keys are errors, numbers finite,
    and ``true``/``false`` is never read as the number 1 or 0 (pydantic's lax
    mode would make ``samples: true`` one sample)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    @field_validator("*", mode="before")
    @classmethod
    def _no_bool_numbers(cls, value, info):
        field = cls.model_fields.get(info.field_name)
        where = None if field is None else _bool_at(value, field.annotation)
        if where is not None:
            kind = "an integer" if where == "" and _integral(field.annotation) else "a number"
            raise ValueError(f"{where[1:] + ': ' if where else ''}expected {kind}, not true/false")
        return value


Angle = Union[float, str]


#: An inline part: the part-file format of :mod:`sweeps.partfile`, its keys and types
#: declared there once (vertices, or mesh / outline / footprint with units, ...)
PartInline = create_model("PartInline", __base__=Strict, __module__=__name__, **part_fields())
PartInline.__doc__ = "An inline part (the part-file format of :mod:`sweeps.partfile`)."


class Planner(Strict):
    """Planner settings: pushing (margin, safety factor, objective; the search
    strategy, the distances' support: ``support`` ``any`` (Peshkin's bound, valid
    for every support), ``rigid``, ``uniform``, ``ring`` (valid for every ``c`` the
    family gives the part) or a ratio range ``support_c`` ``[lo, hi]`` (m), slip-aware plans for a fence friction of at least
    ``min_fence_mu``, a ``workspace`` ``[xmin, xmax, ymin, ymax]`` (m, world), the
    search's effort: at most ``max_reorients`` reorient pushes, ``extra_steps``
    more steps than the fewest per run) and tumbling (the planner's accuracy and
    tolerances)."""

    @model_validator(mode="after")
    def _push_options(self):
        if self.support_c is not None and not 0 < self.support_c[0] <= self.support_c[1]:
            raise ValueError(f"support_c: expected [lo, hi] with 0 < lo <= hi (m), got "
                             f"{list(self.support_c)}")
        if self.support_c is not None and self.support != "any":
            raise ValueError(f"support: the distances assume either a support family "
                             f"(support: {self.support}) or a c range (support_c), not both")
        if self.min_fence_mu is not None and self.support_c is None and self.support == "any":
            raise ValueError("min_fence_mu: slip-aware plans need the support's range too; "
                             "add planner.support_c: [lo, hi] (m) or planner.support: rigid "
                             "(uniform, ring)")
        self.push_options()   # the planner's own checks (planning.PushOptions), before any work
        return self

    def push_options(self):
        """The :class:`planning.PushOptions` these settings give (the section
        validates into it: a setting it refuses is refused by the config)."""
        values = {f.name: getattr(self, f.name) for f in dataclasses.fields(PushOptions)
                  if f.name in type(self).model_fields}     # all but the solver (its default)
        if self.support_c is not None:
            values["support"] = {"c": list(self.support_c)}
        return PushOptions(**values)

    # margin_deg, safety_factor, min_fence_mu, workspace: bounds checked by PushOptions
    margin_deg: float = PUSH_DEFAULTS.margin_deg
    safety_factor: float = PUSH_DEFAULTS.safety_factor
    objective: Literal[OBJECTIVES] = PUSH_DEFAULTS.objective
    strategy: Literal[STRATEGIES] = PUSH_DEFAULTS.strategy
    support_c: Optional[tuple[float, float]] = None
    support: Literal[PLAN_SUPPORTS] = PUSH_DEFAULTS.support.family
    min_fence_mu: Optional[float] = None
    workspace: Optional[tuple[float, float, float, float]] = None
    max_reorients: StrictInt = Field(PUSH_DEFAULTS.max_reorients,
                                     ge=EFFORT_BOUNDS["max_reorients"][0],
                                     le=EFFORT_BOUNDS["max_reorients"][1])
    extra_steps: StrictInt = Field(PUSH_DEFAULTS.extra_steps, ge=EFFORT_BOUNDS["extra_steps"][0],
                                   le=EFFORT_BOUNDS["extra_steps"][1])
    tumble_eps: Optional[float] = Field(None, gt=0)
    tumble_tau_v: float = Field(0.0, ge=0)
    tau_g: Optional[float] = Field(None, ge=0)


class Synthesize(Strict):
    """Robust plan synthesis (:mod:`robustness.synthesis`): the candidate grid
    (push tasks: margins, safety factors, strategies, distance rules; tumble
    tasks: accuracies and the length slack), the selection draws and the
    objective."""

    enabled: bool = True
    n_samples: StrictInt = Field(1000, ge=10, le=1_000_000)
    objective: Literal["max_lower_bound", "shortest_certifying"] = "max_lower_bound"
    margins_deg: list[float] = Field(default_factory=lambda: list(GRID_MARGINS_DEG), min_length=1)
    safety_factors: list[float] = Field(default_factory=lambda: list(GRID_SAFETY_FACTORS),
                                        min_length=1)
    strategies: list[Literal[STRATEGIES]] = Field(
        default_factory=lambda: list(GRID_STRATEGIES), min_length=1)
    model_distances: bool = True
    slip_aware: bool = True
    per_setting: StrictInt = Field(3, ge=1, le=32)
    max_candidates: StrictInt = Field(64, ge=1, le=1024)
    eps_factors: list[float] = Field(default_factory=lambda: [1.0, 0.5, 0.25], min_length=1)
    slack: StrictInt = Field(2, ge=0, le=100)
    physics_samples: StrictInt = Field(0, ge=0, le=10_000)     # MuJoCo tie-break (push tasks)
    physics_candidates: StrictInt = Field(4, ge=2, le=64)
    # the chosen plan and the default one rolled out in MuJoCo on common draws: physics
    # contradicting the choice keeps the default plan (push tasks, robustness.physics_veto)
    veto_samples: StrictInt = Field(24, ge=0, le=10_000)
    # the chosen plan rolled out in MuJoCo on fresh draws, beside its certificate (push tasks)
    confirm_samples: StrictInt = Field(24, ge=0, le=10_000)

    @model_validator(mode="after")
    def _grid(self):
        if any(not (0 < m < 90) for m in self.margins_deg):
            raise ValueError("margins_deg: give margin angles in degrees, 0 < margin < 90")
        if any(sf < 1 for sf in self.safety_factors):
            raise ValueError("safety_factors: give safety factors >= 1")
        if any(not (0 < f <= 1) for f in self.eps_factors):
            raise ValueError("eps_factors: give factors of the tumble planner's eps, 0 < f <= 1")
        return self

    def tumble_grid(self, eps: float, tau_v: float, tau_g) -> dict:
        """The keywords of :func:`robustness.synthesis.tumble_candidates` for a
        tumble planner with accuracy ``eps``, tolerance ``tau_v`` and ``tau_g``."""
        return dict(eps=float(eps), tau_v=float(tau_v), tau_g=tau_g,
                    eps_factors=tuple(self.eps_factors), slack=self.slack,
                    per_setting=self.per_setting, limit=self.max_candidates)

    def grid(self, friction) -> dict:
        """The keywords of :func:`robustness.synthesis.push_candidates` for a
        cell with ``friction`` (a :class:`~robustness.FrictionRange`): the
        distance rules are Peshkin's and, with ``model_distances``, those of the
        support family drawn (a named family other than ``any``); slip-aware
        variants at the range's lowest fence friction."""
        fam = friction.support
        supports = [None] + ([fam] if self.model_distances and fam in PLANNED_FAMILIES else [])
        return dict(margins_deg=tuple(self.margins_deg), safety_factors=tuple(self.safety_factors),
                    strategies=tuple(self.strategies), supports=tuple(supports),
                    min_fence_mu=float(friction.mu_f[0]) if self.slip_aware else None,
                    per_setting=self.per_setting, limit=self.max_candidates)


class Design(Strict):
    """Tolerance design (:mod:`robustness.tolerance_design`): the design draws
    and the bisection's precision."""

    enabled: bool = True
    n_samples: StrictInt = Field(1000, ge=10, le=1_000_000)
    rel_tol: float = Field(0.05, gt=0, le=1)
    axes: Optional[list[Literal["tau_v", "tau_com", "start", "fence_angle", "push_distance",
                                "fence_friction", "tumble_slip"]]] = None


class Required(Strict):
    """Required success probability and the confidence of its claim (defaults:
    :data:`robustness.REQUIRED_PROBABILITY`, :data:`robustness.CONFIDENCE`)."""

    probability: float = Field(REQUIRED_PROBABILITY, gt=0, lt=1)
    confidence: float = Field(CONFIDENCE, gt=0, lt=1)


class Task(Strict):
    """One task: start and goal pose ``[x, y, theta]`` (push) or configuration
    ``[x, y, theta, face]`` (tumble; the start defaults to ``[0, 0, 0, 0]``).  A
    push task's start may be unknown (sensorless posing, issue 40): ``{heading:
    any, region: [xmin, xmax, ymin, ymax]}`` (m, world), or ``heading: [lo, hi]``
    (rad or ``deg``) for a known interval (:class:`SensorlessStart`)."""

    name: str = Field(min_length=1)
    start: Optional[Union[list[Angle], dict[str, Any]]] = None
    goal: list[Angle]


@dataclasses.dataclass(frozen=True)
class SensorlessStart:
    """An unknown start of a push task: any position of the centre of mass in
    ``region`` ``(xmin, xmax, ymin, ymax)`` (m, world) and any heading in
    ``heading`` ``(lo, hi)`` (rad, ``lo <= hi < lo + 2 pi``; None: any heading).
    Planned by :func:`planning.plan_sensorless`."""

    region: tuple[float, float, float, float]
    heading: Optional[tuple[float, float]] = None

    @property
    def reference(self) -> tuple[float, float, float]:
        """The pose a ``plans`` / ``certificates`` row names as the start: the
        region's centre and the heading interval's middle (0 for any heading);
        the samples' ``start_d*`` columns are offsets from it (m, m, rad)."""
        r, h = self.region, self.heading
        return (0.5 * (r[0] + r[1]), 0.5 * (r[2] + r[3]),
                0.0 if h is None else 0.5 * (h[0] + h[1]))


class TaskPoses(typing.NamedTuple):
    """A task resolved to poses, as every unit of a run and the certify command
    hand it on (a value: fields by name; unpacks as ``name, start, goal``).

    Attributes:
      name: the task's name (unique in its configuration).
      start: ``(x, y, theta)`` (push; m, m, rad, world), ``(x, y, theta, face)``
        (tumble), or a :class:`SensorlessStart` (a push from an unknown pose).
      goal: the goal pose or configuration, in the same form.
    """

    name: str
    start: Union[tuple, SensorlessStart]
    goal: tuple


def reference_start(start) -> tuple:
    """A task's start as a row names it: the pose itself, or a
    :class:`SensorlessStart`'s :attr:`~SensorlessStart.reference`."""
    return start.reference if isinstance(start, SensorlessStart) else start


def parse_sensorless_start(doc: dict, field: str, kind: str) -> SensorlessStart:
    """``{heading: any | [lo, hi], region: [xmin, xmax, ymin, ymax]}`` of a push
    task (:class:`SensorlessStart`); one line naming the field and the fix otherwise."""
    if kind != "polygon":
        raise ConfigError(f"{field}: heading: any / region: is sensorless posing of a pushed "
                          f"polygon; a tumble task needs a start configuration [x, y, theta, "
                          "face] (or none: [0, 0, 0, 0])")
    extra = sorted(set(doc) - {"heading", "region"})
    if extra:
        raise ConfigError(f"{field}: unknown key {extra[0]!r}; allowed keys: heading, region "
                          "(check the spelling)")
    if "region" not in doc:
        raise ConfigError(f"{field}.region: required with an unknown start: [xmin, xmax, ymin, "
                          "ymax] (m, world), where the centre of mass may start")
    if "heading" not in doc:
        raise ConfigError(f"{field}.heading: required with a region: any (an unknown heading) "
                          "or [lo, hi] (rad or ...deg), the headings the part may start at")
    reg = doc["region"]
    if not isinstance(reg, (list, tuple)) or len(reg) != 4:
        raise ConfigError(f"{field}.region: expected [xmin, xmax, ymin, ymax] (m, world), got "
                          f"{reg!r}")
    region = tuple(_length(v, f"{field}.region[{i}]") for i, v in enumerate(reg))
    if region[0] > region[1] or region[2] > region[3]:
        raise ConfigError(f"{field}.region: needs xmin <= xmax and ymin <= ymax (m), got "
                          f"{list(region)}; swap the bounds")
    h = doc["heading"]
    if isinstance(h, str) and h.strip().lower() == "any":
        return SensorlessStart(region, None)
    if not isinstance(h, (list, tuple)) or len(h) != 2:
        raise ConfigError(f"{field}.heading: expected any or [lo, hi] (rad or ...deg), got {h!r}")
    lo, hi = (parse_angle(v, f"{field}.heading[{i}]") for i, v in enumerate(h))
    if not lo <= hi < lo + 2 * math.pi:
        raise ConfigError(f"{field}.heading: needs lo <= hi < lo + 2 pi, got [{lo:.6g}, "
                          f"{hi:.6g}] rad; swap the bounds, or give heading: any for every "
                          "heading")
    return SensorlessStart(region, (lo, hi))


def _check_tripod(friction, part) -> None:
    """A tripod's feet must fit inside the polygon's outline (``kernels.support``)."""
    if friction is None or part.kind != "polygon" or friction.support != "tripod":
        return
    import warnings

    import jax
    import numpy as np

    from kernels import FOOT_INSET, make_polygon, tripod_fit

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        body = make_polygon(part.vertices, part.com).body
    with jax.enable_x64(True):
        fit = float(tripod_fit(np.asarray(body, np.float64)))
    if friction.c[1] > fit:
        raise ValueError(f"friction.c: a tripod of c {friction.c[1] * 1e3:.3g} mm does not fit "
                         f"inside {part.name} (its feet stay {FOOT_INSET * 1e3:g} mm inside the "
                         f"outline: c <= {fit * 1e3:.3g} mm); lower c or use support: any")


class Physics(Strict):
    """``model: mujoco``: how plans are rolled out in MuJoCo (:mod:`robustness.physics`).

    ``backend``: ``auto`` (MJX on an accelerator, else the C engine), ``c`` or ``mjx``;
    ``stroke``: ``planned`` (open loop, each fence stroke from the planned pose) or
    ``contact`` (from where the part is); ``cell``: the cell and engine settings
    (:class:`~robustness.physics.PhysicsSettings`, each default documented there).
    """

    backend: Literal["auto", "c", "mjx"] = "auto"
    stroke: Literal["planned", "contact"] = "planned"
    cell: PhysicsSettings = Field(default_factory=PhysicsSettings)

    @model_validator(mode="after")
    def _engine(self):
        from robustness.physics import check_contact_model

        check_contact_model(self.backend, self.cell)
        return self

    def run(self, part=None, friction=None):
        """The :class:`~robustness.physics.PhysicsRun`, the part's material (its
        file's thickness and density) in the cell settings; a tripod support of
        ``friction`` checked against the part's outline."""
        import dataclasses as dc

        from robustness.physics import PhysicsRun

        cell = self.cell
        if part is not None:
            _check_tripod(friction, part)
            d = PhysicsSettings()
            if part.kind == "polygon":
                for key, field in (("thickness", "part_thickness"), ("density", "part_density")):
                    if getattr(cell, field) != getattr(d, field):
                        raise ValueError(f"physics.cell.{field}: the part's {key} is a part-file "
                                         f"field; set {key}: in {part.path.name} instead")
                cell = dc.replace(cell, part_thickness=float(part.thickness),
                                  part_density=float(part.density))
            else:
                if cell.polyhedron_density != d.polyhedron_density:
                    raise ValueError(f"physics.cell.polyhedron_density: the part's density is a "
                                     f"part-file field; set density: in {part.path.name} instead")
                cell = dc.replace(cell, polyhedron_density=float(part.density))
        return PhysicsRun(backend=self.backend, stroke=self.stroke, settings=cell)


class Evaluation(Strict):
    """The Monte-Carlo sections shared by certify configs and studies."""

    tolerances: GeometryTolerance = Field(default_factory=GeometryTolerance)
    friction: FrictionRange = Field(default_factory=FrictionRange)
    execution: ExecutionTolerance = Field(default_factory=ExecutionTolerance)
    planner: Planner = Field(default_factory=Planner)
    eps: SuccessCriterion = Field(default_factory=SuccessCriterion)
    required: Required = Field(default_factory=Required)
    seed: int = Field(0, ge=0)
    model: Literal["quasistatic", "limit_surface", "exact", "mujoco"] = DEFAULT_MODEL
    dtype: Literal["float64", "float32"] = "float64"
    physics: Physics = Field(default_factory=Physics)

    def sampler(self):
        """The :class:`~robustness.Sampler` of these tolerances."""
        from robustness import Sampler

        return Sampler(self.tolerances, self.friction, self.execution)

    @model_validator(mode="after")
    def _support_in_physics(self):
        if self.model == "mujoco" and self.friction.support not in REALISABLE_SUPPORTS:
            from robustness.physics import POINTS_NOT_REALISABLE

            raise ValueError(f"friction.{POINTS_NOT_REALISABLE}")
        return self

    def physics_run(self, part=None):
        """The :class:`~robustness.physics.PhysicsRun` of ``model: mujoco`` (else
        None), with ``part``'s material (:class:`sweeps.partfile.PartFile`)."""
        return self.physics.run(part, self.friction) if self.model == "mujoco" else None

    def model_spec(self, model: Optional[str] = None, physics=None):
        """The :class:`~robustness.Model` these sections evaluate with: ``model``
        (default ``model:``) in ``dtype:``, rolled out with ``physics`` (a
        :class:`~robustness.physics.PhysicsRun`, :meth:`physics_run`)."""
        from robustness import Model

        return Model(model or self.model, dtype=self.dtype, physics=physics)

    def requirement(self):
        """The :class:`~robustness.Requirement` of ``required:`` and ``eps:``."""
        from robustness import Requirement

        return Requirement(self.required.probability, self.required.confidence, self.eps)


HINTS = {
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
    "slip_fraction": "the fraction of pos_eps_m a failed sample's slip must reach to fail by slip, >= 0",
    "probability": "the required success probability, strictly between 0 and 1 (e.g. 0.95)",
    "confidence": "the confidence level, strictly between 0 and 1 (e.g. 0.95)",
    "n_samples": "a positive number of Monte-Carlo samples",
    "samples": "a positive number of Monte-Carlo samples per configuration",
    "margin_deg": "the margin angle in degrees, 0 < margin < 90 (paper: 7)",
    "tumble_eps": "the tumble planner's accuracy (m / rad), > 0",
    "tumble_tau_v": "the vertex tolerance the tumble planner plans for, m (0: the nominal part)",
    "safety_factor": "the Peshkin safety factor, >= 1 (paper: 1.15)",
    "max_reorients": "the most reorient pushes a plan may have, an integer 1..10000 (default 24)",
    "extra_steps": "how many more steps than the fewest the push search tries per reorientation "
                   "run, an integer 0..100 (default 3)",
    "mu_f": "a range [low, high] of fence friction coefficients >= 0",
    "mu_s": "a range [low, high] of support friction coefficients >= 0",
    "c": "a range [low, high] of limit-surface ratios in metres, > 0",
    "support_points": "an integer number of support points >= 1",
    "weight_concentration": "an integer Dirichlet concentration in 1..64",
    "support": "one of " + ", ".join(
        n + (" (with c: [lo, hi])" if n in FAMILY and FAMILY[n].c_given else "")
        for n in SUPPORT_FAMILIES),
    # the planner's support is a family its distances hold for, fewer than the sampler's
    "planner.support": (f"one of {', '.join(PLAN_SUPPORTS)} (the family the plan's push distances "
                        f"hold for; {' and '.join(n for n in FAMILY if n not in PLAN_SUPPORTS)} "
                        "are families of friction.support, the sampler's)"),
    "seed": "an integer >= 0",
}

# pydantic appends these tags (union branches, dataclass names) to error locations
_TAGS = {"str", "float", "int", "bool", "list", "dict", "function-after", "function-plain"}


def _loc(loc) -> str:
    out = ""
    for p in loc:
        if isinstance(p, int):
            out += f"[{p}]"
        elif p in _TAGS or (isinstance(p, str) and (p[:1].isupper() or p.startswith(("list[", "tuple[", "union[")))):
            continue
        else:
            out += f".{p}" if out else str(p)
    return out or "(top level)"


def _model_at(model, loc):
    """The pydantic model (or dataclass) at location ``loc`` of ``model``, or None."""
    for p in loc:
        if isinstance(p, int) or p in _TAGS or (isinstance(p, str) and p[:1].isupper()):
            continue
        fields = _fields(model)
        if p not in fields:
            return None
        model = _inner_type(fields[p])
        if model is None:
            return None
    return model


def _fields(model) -> dict:
    if dataclasses.is_dataclass(model):
        import typing

        hints = typing.get_type_hints(model)
        return {f.name: hints.get(f.name) for f in dataclasses.fields(model)}
    if isinstance(model, type) and issubclass(model, BaseModel):
        return {k: f.annotation for k, f in model.model_fields.items()}
    return {}


def _inner_type(ann):
    """The model or dataclass inside an annotation (through Optional / list / Union)."""
    if isinstance(ann, type) and (dataclasses.is_dataclass(ann) or issubclass(ann, BaseModel)):
        return ann
    for a in getattr(ann, "__args__", ()) or ():
        got = _inner_type(a)
        if got is not None:
            return got
    return None


def allowed_keys(model, loc) -> list:
    """The keys allowed at ``loc`` of ``model``."""
    m = _model_at(model, loc)
    return list(_fields(m)) if m is not None else []


def _one(e: dict, model) -> str:
    typ, loc = e["type"], tuple(e["loc"])
    got = e.get("input")
    if typ in ("extra_forbidden", "unexpected_keyword_argument"):
        parent = _loc(loc[:-1])
        where = "at the top level" if parent == "(top level)" else f"in {parent}"
        keys = allowed_keys(model, loc[:-1])
        return (f"{_loc(loc)}: unknown key {loc[-1]!r} {where}"
                + (f"; allowed keys: {', '.join(keys)}" if keys else "") + " (check the spelling)")
    field = _loc(loc)
    last = next((p for p in reversed(loc) if isinstance(p, str) and p not in _TAGS), "")
    hint = HINTS.get(field, HINTS.get(last))
    tail = f"; give {hint}" if hint else ""
    if typ == "missing":
        return f"{field}: required key is missing{tail}"
    if typ == "finite_number":
        return f"{field}: must be a finite number, got {got!r}{tail}"
    ops = {"greater_than_equal": (">=", "ge"), "greater_than": (">", "gt"),
           "less_than": ("<", "lt"), "less_than_equal": ("<=", "le")}
    if typ in ops:
        op, k = ops[typ]
        return f"{field}: must be {op} {(e.get('ctx') or {}).get(k, '')}, got {got!r}{tail}"
    msg = e["msg"]
    if msg.startswith("Value error, "):
        msg = msg[len("Value error, "):]
        # a dataclass's own check names its field first ('tau_v: must be ...'): join the paths
        head, sep, rest = msg.partition(": ")
        if sep and head in _fields(_model_at(model, loc)):
            path = _loc(loc + (head,))
            hint = None if "; " in rest else HINTS.get(path, HINTS.get(head))   # its own wins
            return f"{path}: {rest}" + (f"; give {hint}" if hint else "")
        return msg if field == "(top level)" else f"{field}: {msg}"
    return f"{field}: {msg}, got {got!r}{tail}"


def describe(exc: ValidationError, model, prefix: str = "") -> ConfigError:
    """A :class:`ConfigError` with one line per mistake of a pydantic error."""
    lines, seen = [], set()
    # unknown keys first: a misspelt key is the likeliest cause of the other errors
    errs = sorted(exc.errors(), key=lambda e: e["type"] not in ("extra_forbidden",
                                                                "unexpected_keyword_argument"))
    for e in errs:
        line = _one(e, model)
        if line not in seen:
            seen.add(line)
            lines.append(prefix + line)
    return ConfigError(lines[0], lines)


def validate(model, doc, prefix: str = ""):
    """``model.model_validate(doc)`` with errors as a :class:`ConfigError`."""
    from sweeps.units import lengths_to_metres

    if not isinstance(doc, dict):
        raise ConfigError(f"{prefix}expected a mapping with keys {', '.join(_fields(model))}, "
                          f"got {type(doc).__name__}")
    try:
        doc = lengths_to_metres(doc)   # '0.05 mm' -> 5e-05 (sweeps.units), once, at the edge
    except ValueError as exc:
        raise ConfigError(prefix + str(exc)) from None
    try:
        return model.model_validate(doc)
    except ValidationError as exc:
        raise describe(exc, model, prefix) from None


# --------------------------------------------------------------------------
# Values inside configs
# --------------------------------------------------------------------------
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
    """A number (metres) or a length with a unit (``'100 mm'``, :mod:`sweeps.units`)."""
    from sweeps.units import is_length_string, parse_length

    if is_length_string(v):
        try:
            return parse_length(v, field)
        except ValueError as exc:
            raise ConfigError(str(exc)) from None
    if isinstance(v, (str, bool)) or not isinstance(v, (int, float)):
        raise ConfigError(f"{field}: expected a number in metres, got {v!r}")
    x = float(v)
    if not math.isfinite(x):
        raise ConfigError(f"{field}: must be a finite number in metres, got {v!r}")
    return x


def parse_pose(values, field: str, kind: str) -> tuple:
    """``[x, y, theta]`` (polygon part) or ``[x, y, theta, face]`` (polyhedron)."""
    want = 3 if kind == "polygon" else 4
    form = "[x, y, theta]" if want == 3 else "[x, y, theta, face]"
    if not isinstance(values, (list, tuple)) or len(values) != want:
        n = len(values) if isinstance(values, (list, tuple)) else 1
        raise ConfigError(f"{field}: a {kind} task needs {form} (metres, radians"
                          f"{', face number' if want == 4 else ''}), got {n} value(s)")
    x = _length(values[0], f"{field}[0]")
    y = _length(values[1], f"{field}[1]")
    th = wrap(parse_angle(values[2], f"{field}[2]"))   # stored in (-pi, pi]
    if want == 3:
        return (x, y, th)
    f = values[3]
    if isinstance(f, bool) or not (isinstance(f, int) or (isinstance(f, float) and f.is_integer())) \
            or f < 0:
        raise ConfigError(f"{field}[3]: the face must be a face number (an integer >= 0), got {f!r}")
    return (x, y, th, int(f))


def explicit_tasks(tasks: list, kind: str) -> list[TaskPoses]:
    """The :class:`TaskPoses` of explicit tasks; a push task needs a start (a
    pose, or a :class:`SensorlessStart`)."""
    out = []
    names = [t.name for t in tasks]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ConfigError(f"tasks: task names must be unique, {dup} repeated")
    for i, t in enumerate(tasks):
        if isinstance(t.start, dict) and kind != "polygon":   # before the goal's form
            parse_sensorless_start(t.start, f"tasks[{i}].start", kind)
        goal = parse_pose(t.goal, f"tasks[{i}].goal", kind)
        if t.start is None:
            if kind == "polygon":
                raise ConfigError(f"tasks[{i}].start: a push task needs a start pose [x, y, theta]"
                                  " (or an unknown one: {heading: any, region: [xmin, xmax, "
                                  "ymin, ymax]})")
            start = (0.0, 0.0, 0.0, 0)
        elif isinstance(t.start, dict):
            start = parse_sensorless_start(t.start, f"tasks[{i}].start", kind)
        else:
            start = parse_pose(t.start, f"tasks[{i}].start", kind)
        out.append(TaskPoses(t.name, start, goal))
    return out


def check_sensorless(cfg, tasks) -> None:
    """Sensorless tasks (a :class:`SensorlessStart`) only where their Monte Carlo
    runs (:mod:`robustness.sensorless`, MuJoCo included): not under robust
    synthesis or tolerance design (each needs a known start); one line naming
    the field and the fix, before any work."""
    for i, (name, start, _) in enumerate(tasks):
        if not isinstance(start, SensorlessStart):
            continue
        which = f"tasks[{i}] ({name}) starts at an unknown pose (heading/region)"
        for sec, flag in (("synthesize", "--synthesize"), ("design", "--design")):
            v = getattr(cfg, sec, None)
            if v is not None and v.enabled:
                raise ConfigError(f"{sec}: needs a known start, and {which}; drop {flag} / "
                                  f"{sec}: or give that task a start [x, y, theta]")


# --------------------------------------------------------------------------
# nudge certify's config
# --------------------------------------------------------------------------
class MarginSearch(Strict):
    """Grid for the margin recommendation (push tasks)."""

    margins_deg: list[float] = Field(default_factory=lambda: list(GRID_MARGINS_DEG))
    safety_factors: list[float] = Field(default_factory=lambda: list(GRID_SAFETY_FACTORS))
    n_samples: int = Field(200, ge=1, le=10_000_000)
    enabled: StrictBool = True

    @field_validator("margins_deg")
    @classmethod
    def _m(cls, v):
        if not v or any(not (0 < x < 90) for x in v):
            raise ValueError("give margin angles in degrees, 0 < margin < 90")
        return sorted(v)

    @field_validator("safety_factors")
    @classmethod
    def _s(cls, v):
        if not v or any(x < 1 for x in v):
            raise ValueError("give safety factors >= 1")
        return sorted(v)


class CertifyConfig(Evaluation):
    """A certification config."""

    part: Union[str, PartInline]
    n_samples: Union[int, Literal["auto"]] = 400
    max_samples: int = Field(MAX_SAMPLES, ge=1, le=100_000_000)
    tasks: list[Task] = Field(min_length=1)
    margin_search: Optional[MarginSearch] = None
    synthesize: Optional[Synthesize] = None
    design: Optional[Design] = None

    @field_validator("n_samples")
    @classmethod
    def _n(cls, v):
        if isinstance(v, int) and v < 1:
            raise ValueError(f"must be >= 1 or auto, got {v}")
        return v
