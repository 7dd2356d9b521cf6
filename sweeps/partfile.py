"""Part files: the one place that reads a part description from YAML.

Format (one part per file; keys other than these are rejected)::

    name: triangle          # optional string, default: the file's stem
    kind: polygon           # polygon | polyhedron; optional, default from the row length
    vertices: [[x, y], ...] # metres, caller's frame; [x, y, z] rows for a polyhedron
    com: [x, y]             # optional centre of mass (same frame); default: centroid
    description: "..."      # optional free text

This module checks the *file*: YAML syntax, allowed keys, types, shapes and
finiteness.  Geometry (convexity, zero area or volume, a centre of mass
outside the part) is checked by :func:`kernels.polygon.make_polygon` and
:func:`kernels.polyhedron.make_polyhedron` when the part is used, and by
:func:`check_geometry` (the same functions) where a config names a part, so
that a degenerate part is a config error before any work.  Every failure
raises :class:`PartFileError` (a ``ValueError``) with a one-line message that
starts with the file's path and names the offending field.
"""
from __future__ import annotations

import dataclasses
import pathlib
from typing import Literal, Optional, Union

import numpy as np
from pydantic import BaseModel, ConfigDict, StrictFloat, StrictInt, ValidationError

from sweeps.errors import UserError
from sweeps.yamlio import YamlError, read_yaml

KINDS = ("polygon", "polyhedron")
DIMS = {"polygon": 2, "polyhedron": 3}
MIN_VERTICES = {"polygon": 3, "polyhedron": 4}

Number = Union[StrictInt, StrictFloat]


class PartFileError(UserError):
    """A part file that cannot be read; the one-line message names the file and the field."""


class _PartSchema(BaseModel):
    """The raw YAML document (validated with pydantic v2)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=True)

    name: Optional[str] = None
    kind: Optional[Literal["polygon", "polyhedron"]] = None
    vertices: list[list[Number]]
    com: Optional[list[Number]] = None
    thickness: Optional[Number] = None
    density: Optional[Number] = None
    mass: Optional[Number] = None
    description: Optional[str] = None


ALLOWED_KEYS = tuple(_PartSchema.model_fields)


@dataclasses.dataclass(frozen=True, eq=False)
class PartFile:
    """A part read from a YAML file.

    Attributes:
      name: the part's name (the file's stem when the file gives none).
      kind: ``"polygon"`` or ``"polyhedron"``.
      vertices: (m, 2) or (m, 3) float64 vertex coordinates, metres, as given.
      com: (2,) or (3,) float64 centre of mass, or ``None`` (the part's
        centroid is used).
      description: free text or ``None``.
      path: the file it was read from.
      thickness: a polygon's extrusion, m (the file's ``thickness``, default
        ``DEFAULT_THICKNESS`` 3 mm: a plate); ``None`` for a polyhedron.
      density: kg/m^3 (the file's ``density``, or its ``mass`` over the
        hull's volume; default ``DEFAULT_DENSITY``: 7800, steel, for a
        polygon, 500 for a polyhedron, the tumble cell's light block).
      material_given: which of thickness / density / mass the file gave.
    """

    name: str
    kind: str
    vertices: np.ndarray
    com: Optional[np.ndarray]
    description: Optional[str]
    path: pathlib.Path
    thickness: Optional[float] = None
    density: float = 7800.0
    material_given: tuple = ()

    @property
    def dim(self) -> int:
        """2 for a polygon, 3 for a polyhedron."""
        return DIMS[self.kind]

    def to_dict(self) -> dict:
        """Plain dict in the file format (lists of floats)."""
        d = {"name": self.name, "kind": self.kind, "vertices": self.vertices.tolist()}
        if self.com is not None:
            d["com"] = self.com.tolist()
        if self.description is not None:
            d["description"] = self.description
        for k in self.material_given:
            d[k] = float(getattr(self, k))
        return d

    @property
    def mass(self) -> float:
        """kg: density times the hull's area and thickness (polygon) or volume."""
        return float(self.density * _solid_volume(self.vertices, self.kind, self.thickness))


def _loc(loc) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out or "(top level)"


def _describe(err: dict) -> str:
    """One error of a pydantic ValidationError as 'field: message'."""
    typ, loc = err["type"], err["loc"]
    # drop the union-branch names pydantic appends to the location ('int', 'float')
    loc = tuple(p for p in loc if p not in ("int", "float"))
    field = _loc(loc)
    if typ == "extra_forbidden":
        return (f"unknown key {loc[-1]!r}; allowed keys: {', '.join(ALLOWED_KEYS)}")
    if typ == "missing":
        return f"{field}: required key is missing"
    if typ == "literal_error":
        return f"{field}: expected one of {', '.join(KINDS)}, got {err.get('input')!r}"
    if typ in ("int_type", "float_type"):
        return f"{field}: expected a number (metres), got {err.get('input')!r}"
    if typ == "list_type":
        top = loc[0] if loc else ""
        want = {"vertices": "a list of [x, y] (polygon) or [x, y, z] (polyhedron) rows",
                "com": "a list [x, y] or [x, y, z]"}.get(str(top), "a list")
        if len(loc) > 1:
            want = "a row [x, y] or [x, y, z]"
        return f"{field}: expected {want}, got {err.get('input')!r}"
    if typ == "string_type":
        return f"{field}: expected a string, got {err.get('input')!r}"
    return f"{field}: {err['msg']}"


def _finite_rows(arr: np.ndarray, field: str) -> None:
    bad = np.argwhere(~np.isfinite(arr))
    if len(bad):
        idx = "".join(f"[{int(i)}]" for i in bad[0])
        raise ValueError(f"{field}{idx}: must be a finite number (metres), got {arr[tuple(bad[0])]}")


def parse_part(doc, path: Union[str, pathlib.Path] = "<part>") -> PartFile:
    """Validate an already-parsed YAML document (a dict) as a part.

    Args:
      doc: the mapping read from the file.
      path: where it came from (used in messages and for the default name).

    Returns:
      A :class:`PartFile`.

    Raises:
      PartFileError: the message starts with ``path`` and names the field.
    """
    path = pathlib.Path(path)
    try:
        return _parse(doc, path)
    except ValueError as exc:
        raise PartFileError(f"{path}: {exc}") from None


def _parse(doc, path: pathlib.Path) -> PartFile:
    if doc is None:
        raise ValueError(f"the file is empty; expected a mapping with keys {', '.join(ALLOWED_KEYS)}")
    if not isinstance(doc, dict):
        raise ValueError(f"expected a mapping with keys {', '.join(ALLOWED_KEYS)}, "
                         f"got a {type(doc).__name__}")
    bad_keys = [k for k in doc if not isinstance(k, str)]
    if bad_keys:
        raise ValueError(f"unknown key {bad_keys[0]!r}; allowed keys: {', '.join(ALLOWED_KEYS)}")
    try:
        raw = _PartSchema.model_validate(doc)
    except ValidationError as exc:
        errs = exc.errors()
        extra = [e for e in errs if e["type"] == "extra_forbidden"]
        if extra:
            names = ", ".join(repr(e["loc"][-1]) for e in extra)
            raise ValueError(f"unknown key{'s' if len(extra) > 1 else ''} {names}; "
                             f"allowed keys: {', '.join(ALLOWED_KEYS)}") from None
        # a union of int and float reports each bad number twice: count locations
        locs = {tuple(p for p in e["loc"] if p not in ("int", "float")) for e in errs}
        msg = _describe(errs[0])
        if len(locs) > 1:
            msg += f" (and {len(locs) - 1} more error{'s' if len(locs) > 2 else ''})"
        raise ValueError(msg) from None

    rows = raw.vertices
    lengths = sorted({len(r) for r in rows})
    if not rows:
        raise ValueError("vertices: the list is empty; give one [x, y] (polygon) or [x, y, z] "
                         "(polyhedron) row per vertex")
    kind = raw.kind
    if kind is None:
        if lengths not in ([2], [3]):
            raise ValueError(f"vertices: rows must all have 2 numbers (polygon) or all 3 "
                             f"(polyhedron); got rows of length {lengths}")
        kind = "polygon" if lengths == [2] else "polyhedron"
    dim = DIMS[kind]
    for i, r in enumerate(rows):
        if len(r) != dim:
            want = "[x, y]" if dim == 2 else "[x, y, z]"
            raise ValueError(f"vertices[{i}]: a {kind} needs {want} rows ({dim} numbers), got "
                             f"{len(r)} numbers")
    if len(rows) < MIN_VERTICES[kind]:
        raise ValueError(f"vertices: a {kind} needs at least {MIN_VERTICES[kind]} vertices, "
                         f"got {len(rows)}")
    vertices = np.asarray(rows, dtype=np.float64)
    _finite_rows(vertices, "vertices")
    com = None
    if raw.com is not None:
        if len(raw.com) != dim:
            want = "[x, y]" if dim == 2 else "[x, y, z]"
            raise ValueError(f"com: a {kind} needs {want} ({dim} numbers), got {len(raw.com)}")
        com = np.asarray(raw.com, dtype=np.float64)
        _finite_rows(com, "com")
    name = raw.name if raw.name is not None else path.stem
    thickness, density, given = _material(raw, kind, vertices)
    vertices.setflags(write=False)
    if com is not None:
        com.setflags(write=False)
    return PartFile(name=name, kind=kind, vertices=vertices, com=com,
                    description=raw.description, path=path, thickness=thickness,
                    density=density, material_given=given)


#: a polygon's default extrusion (m) and the default densities (kg/m^3)
DEFAULT_THICKNESS = 0.003
DEFAULT_DENSITY = {"polygon": 7800.0, "polyhedron": 500.0}


def _solid_volume(vertices: np.ndarray, kind: str, thickness) -> float:
    """m^3 of the solid: the hull's area times ``thickness`` (polygon) or its
    volume (polyhedron); 0 for a degenerate hull."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        size = ConvexHull(np.asarray(vertices, np.float64)).volume
    except QhullError:
        return 0.0
    return float(size * (thickness if kind == "polygon" else 1.0))


def _material(raw, kind: str, vertices: np.ndarray):
    """``(thickness, density, given)`` from a part document's material keys."""
    given = tuple(k for k in ("thickness", "density", "mass") if getattr(raw, k) is not None)
    for k in given:
        v = float(getattr(raw, k))
        if not (np.isfinite(v) and v > 0):
            unit = {"thickness": "m", "density": "kg/m^3", "mass": "kg"}[k]
            raise ValueError(f"{k}: must be a finite number > 0 ({unit}), got {getattr(raw, k)!r}")
    if "density" in given and "mass" in given:
        raise ValueError("mass: give the part's density or its mass, not both")
    if kind == "polyhedron" and "thickness" in given:
        raise ValueError("thickness: a polyhedron's size is its vertices; thickness is a "
                         "polygon's extrusion (drop it)")
    thickness = (float(raw.thickness) if raw.thickness is not None else DEFAULT_THICKNESS) \
        if kind == "polygon" else None
    density = float(raw.density) if raw.density is not None else DEFAULT_DENSITY[kind]
    if raw.mass is not None:
        size = _solid_volume(vertices, kind, thickness)
        if not size > 0:
            raise ValueError("mass: the part has no area (volume) to spread its mass over")
        density = float(raw.mass) / size
    return thickness, density, given


def load_part(path: Union[str, pathlib.Path]) -> PartFile:
    """Read and validate a part file.

    Args:
      path: a YAML file in the format of this module's docstring.

    Returns:
      A :class:`PartFile` (vertices and com as read-only float64 arrays).

    Raises:
      PartFileError: missing or unreadable file, YAML syntax error, unknown
        or missing key, wrong type or shape, NaN or inf; one line, starting
        with the path and naming the field.
    """
    try:
        doc, _ = read_yaml(path, "part file")
    except YamlError as exc:
        raise PartFileError(str(exc)) from None
    return parse_part(doc, path)


def check_geometry(part: PartFile) -> None:
    """Check a part's geometry as the planners will, before any work: the
    kernels' own checks (:func:`kernels.polygon.make_polygon`,
    :func:`kernels.polyhedron.make_polyhedron`) of collinear or coincident
    points (no area), coplanar points (no volume) and a centre of mass that is
    not inside.  Their warnings (points that are not hull vertices, an
    implausible size) are not shown here: the planner raises them again when it
    uses the part.

    Raises:
      PartFileError: one line, the part's path and the field (``vertices`` or
        ``com``) with the fix.
    """
    import warnings

    if part.kind == "polygon":
        from kernels import make_polygon as make
    else:
        from kernels import make_polyhedron as make
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            make(part.vertices, part.com)
        except ValueError as exc:   # PartError or make_polyhedron's: bad input by contract
            raise PartFileError(f"{part.path}: {' '.join(str(exc).split())}") from None
