"""Parameter designs of a study: the ``params:`` section and ``--set`` overrides.

``params`` maps dotted field paths of the study config (``planner.margin_deg``,
``friction.mu_f``, ``tolerances.tau_v``, ``samples``...) to axes:

* a number or a string: one fixed value;
* a list ``[a, b, c]``: a grid axis, crossed with the other axes;
* ``{linspace: [a, b, n]}``: ``n`` evenly spaced values from ``a`` to ``b``;
* ``{range: [start, stop, step]}``: ``start, start + step, ...`` below ``stop``;
* ``{uniform: [lo, hi], n: k}`` / ``{loguniform: [lo, hi], n: k}``: ``k`` seeded
  random draws (from the study's seed and the axis's path, so adding an axis
  leaves the others' draws as they were);

and the special key ``zip: [[path_a, path_b], ...]`` makes the named axes step
together (equal lengths) instead of being crossed.  A scalar value swept on a
range field (``friction.mu_f: [0.3, 0.8]`` is a range) sets both ends, so
``params: {friction.mu_f: [0.3, 0.5, 0.8]}`` sweeps the fence friction.

A design has at most :data:`MAX_CONFIGS` (100,000) configurations: the size is
counted from the axes' lengths (zipped axes once) before any value is drawn, and
a larger design is refused with one line (``params: ...``), under ``--dry-run``
too; sweep fewer values, zip axes that step together, or split the study.

Command-line overrides in the habit of Hydra: ``--set planner.margin_deg=5,7,9``
(a comma list becomes a grid axis) and ``--set samples=2000`` (one value sets
the field, and replaces any axis on it).
"""
from __future__ import annotations

import hashlib
import itertools
import math
from typing import Annotated, Any, Optional, Union

import numpy as np
from pydantic import BaseModel, ConfigDict, Discriminator, Field, Tag, ValidationError

from sweeps.config import ConfigError
from sweeps.yamlio import YamlError, parse_yaml

AXIS_FORMS = "a number, a list, {linspace: [a, b, n]}, {range: [start, stop, step]}, " \
             "{uniform: [lo, hi], n: k} or {loguniform: [lo, hi], n: k}"


class _Spec(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class Linspace(_Spec):
    linspace: tuple[float, float, int]


class Range(_Spec):
    range: tuple[float, float, float]


class Uniform(_Spec):
    uniform: tuple[float, float]
    n: int = Field(ge=1, le=100_000)


class LogUniform(_Spec):
    loguniform: tuple[float, float]
    n: int = Field(ge=1, le=100_000)


def _axis_kind(v) -> Optional[str]:
    if isinstance(v, list):
        return "grid"
    if isinstance(v, dict):
        for k in ("linspace", "range", "uniform", "loguniform"):
            if k in v:
                return k
        return None
    if isinstance(v, (int, float, str)) and not isinstance(v, bool):
        return "value"
    return None


Axis = Annotated[
    Union[Annotated[list[Any], Tag("grid")], Annotated[Union[float, str], Tag("value")],
          Annotated[Linspace, Tag("linspace")], Annotated[Range, Tag("range")],
          Annotated[Uniform, Tag("uniform")], Annotated[LogUniform, Tag("loguniform")]],
    Discriminator(_axis_kind, custom_error_type="axis",
                  custom_error_message=f"expected {AXIS_FORMS}")]


#: The most configurations a study's design may have (counted before it is expanded).
MAX_CONFIGS = 100_000


class _AxisModel(BaseModel):
    axis: Axis


def _axis(path: str, spec):
    """The validated axis spec (errors name ``params.<path>``)."""
    try:
        return _AxisModel.model_validate({"axis": spec}).axis
    except ValidationError as exc:
        e = exc.errors()[0]
        msg = e["msg"] if e["type"] == "axis" else f"{e['msg']} ({AXIS_FORMS})"
        raise ConfigError(f"params.{path}: {msg}, got {spec!r}") from None


def axis_length(path: str, spec) -> int:
    """The number of values of one axis, counted without drawing them (validated;
    errors name ``params.<path>``)."""
    a = _axis(path, spec)
    if isinstance(a, list):
        if not a:
            raise ConfigError(f"params.{path}: the list is empty; give at least one value")
        return len(a)
    if isinstance(a, Linspace):
        n = a.linspace[2]
        if n < 1:
            raise ConfigError(f"params.{path}: linspace needs n >= 1, got {n}")
        return n
    if isinstance(a, Range):
        start, stop, step = a.range
        if step == 0 or (stop - start) / step < 0:
            raise ConfigError(f"params.{path}: range [start, stop, step] needs a step of the "
                              f"sign of stop - start, got {list(a.range)}")
        n = (stop - start) / step - 1e-12
        return int(math.ceil(n)) if n < 1e18 else 10 ** 18
    if isinstance(a, (Uniform, LogUniform)):
        return a.n
    return 1


def axis_values(path: str, spec, seed: int) -> list:
    """The values of one axis (validated; errors name ``params.<path>``)."""
    n = axis_length(path, spec)
    a = _axis(path, spec)
    if isinstance(a, list):
        return list(a)
    if isinstance(a, Linspace):
        lo, hi, _ = a.linspace
        return [float(x) for x in np.linspace(lo, hi, n)]
    if isinstance(a, Range):
        start, _, step = a.range
        return [float(start + i * step) for i in range(n)]
    if isinstance(a, (Uniform, LogUniform)):
        lo, hi = a.uniform if isinstance(a, Uniform) else a.loguniform
        if hi < lo:
            raise ConfigError(f"params.{path}: low {lo} is above high {hi}")
        digest = hashlib.sha256(path.encode()).digest()
        rng = np.random.default_rng([int(seed), int.from_bytes(digest[:8], "little")])
        u = rng.random(a.n)
        if isinstance(a, Uniform):
            return [float(lo + x * (hi - lo)) for x in u]
        if lo <= 0:
            raise ConfigError(f"params.{path}: loguniform needs 0 < low, got {lo}")
        return [float(math.exp(math.log(lo) + x * (math.log(hi) - math.log(lo)))) for x in u]
    return [a]


def expand(params: dict, seed: int) -> tuple[list[str], list[dict]]:
    """The design points of a ``params`` section.

    Returns:
      ``(paths, points)``: the swept paths in order, and one dict
      ``{path: value}`` per configuration (config id = list index; the last
      axis varies fastest; zipped axes step together at the position of their
      first member).
    """
    params = dict(params or {})
    zips = params.pop("zip", []) or []
    if not isinstance(zips, list) or not all(isinstance(z, list) and z for z in zips):
        raise ConfigError("params.zip: expected a list of lists of parameter paths, e.g. "
                          "zip: [[planner.margin_deg, planner.safety_factor]]")
    sizes = {p: axis_length(p, s) for p, s in params.items()}
    used: set = set()
    for gi, z in enumerate(zips):
        for p in z:
            if p not in sizes:
                raise ConfigError(f"params.zip[{gi}]: {p!r} is not a swept parameter; zip names "
                                  f"axes of params ({', '.join(sizes) or 'none'})")
            if p in used:
                raise ConfigError(f"params.zip[{gi}]: {p!r} is zipped twice")
            used.add(p)
        lens = {sizes[p] for p in z}
        if len(lens) != 1:
            raise ConfigError(f"params.zip[{gi}]: zipped axes need equal lengths, got "
                              + ", ".join(f"{p}: {sizes[p]}" for p in z))
    order = []
    for p in sizes:
        if p in used:
            z = next(z for z in zips if p in z)
            if z not in order:
                order.append(z)
        else:
            order.append([p])
    _check_size(order, sizes)
    axes = {p: axis_values(p, s, seed) for p, s in params.items()}
    groups = [[dict(zip(g, vals)) for vals in zip(*(axes[p] for p in g))] for g in order]
    points = [dict(kv for part in combo for kv in part.items()) for combo in itertools.product(*groups)]
    return list(axes), points


def _check_size(order: list, sizes: dict) -> None:
    """Refuse a design of more than :data:`MAX_CONFIGS` configurations (one line)."""
    total = math.prod(sizes[g[0]] for g in order)
    if total <= MAX_CONFIGS:
        return
    factors = " x ".join(f"{' = '.join(g)} ({sizes[g[0]]})" for g in order if sizes[g[0]] > 1)
    raise ConfigError(f"params: the design has {total:,} configurations ({factors}), more than "
                      f"the limit of {MAX_CONFIGS:,}; sweep fewer values, zip axes that step "
                      "together (zip: [[a, b]]), or split the study")


def parse_overrides(items) -> dict:
    """``--set path=value`` items -> ``{path: (value, is_axis)}``.

    Values are read as YAML (``1e-5`` is a number, ``[0.3, 0.8]`` a list).  A
    bare comma list ``5,7,9`` is a grid axis (``is_axis``): each value is one
    configuration, so ``--set friction.mu_f=0.3,0.8`` sweeps two fence
    frictions while ``--set friction.mu_f=[0.3,0.8]`` sets the range."""
    out: dict = {}
    for item in items or ():
        for tok in (str(item),):
            if "=" not in tok:
                raise ConfigError(f"--set {tok}: expected path=value (e.g. --set samples=2000 or "
                                  "--set planner.margin_deg=5,7,9)")
            path, text = tok.split("=", 1)
            if not path or not all(part.isidentifier() for part in path.split(".")):
                raise ConfigError(f"--set {tok}: {path!r} is not a dotted field path")
            axis = "," in text and not text.startswith(("[", "{"))
            try:
                value = parse_yaml(f"[{text}]" if axis else text)
            except YamlError as exc:
                raise ConfigError(f"--set {tok}: {exc}") from None
            out[path] = (value, axis)
    return out


def set_path(doc: dict, path: str, value) -> None:
    """Set a dotted path of a nested dict, creating mappings on the way."""
    parts = path.split(".")
    cur = doc
    for part in parts[:-1]:
        nxt = cur.get(part)
        if nxt is None:
            nxt = cur[part] = {}
        if not isinstance(nxt, dict):
            raise ConfigError(f"{path}: {part!r} holds {nxt!r}, not a section")
        cur = nxt
    cur[parts[-1]] = value
