"""Part files: the one place that reads a part description from YAML.

Format (one part per file; keys other than these are rejected)::

    name: triangle          # optional string, default: the file's stem
    kind: polygon           # polygon | polyhedron; optional, default from the geometry
    vertices: [[x, y], ...] # the part's corners, caller's frame; [x, y, z] rows for a polyhedron
    com: [x, y]             # optional centre of mass (same frame); default: centroid
    description: "..."      # optional free text
    thickness: 0.003        # a polygon's extrusion (default 3 mm; a footprint's: the mesh's height)
    density: 7800           # kg/m^3 (or mass: kg); defaults: 7800 (polygon), 500 (polyhedron)
    units: mm               # m | cm | mm | um | in: the unit of every length in this file

Instead of ``vertices``, CAD geometry (:mod:`sweeps.cad`; a path relative to
this file)::

    mesh: bracket.stl       # a polyhedron: the mesh's convex hull, com the mesh's own
    outline: plate.dxf      # a polygon: the DXF's closed loop (holes move the com)
    layer: OUTLINE          #   (outline) the outline's layer (holes: loops inside it, any layer)
    chord_tolerance: 0.05   #   (outline) arcs flattened to this, in the file's units (0.05 mm)
    footprint: bracket.stl  # a polygon: the mesh seen from above, resting on a face
    face: -z                #   (footprint) -z (default), +z, -x, ... or a hull face number

Units: a plain number is in the part's unit: ``units:`` when given, else the
CAD file's own (a DXF's ``$INSUNITS``), else metres; ``thickness``,
``chord_tolerance`` and the ``com`` entries also take a unit string
(``"5 mm"``).  Inside nudge everything is metres (:mod:`sweeps.units`).

This module checks the *file*: YAML syntax, allowed keys, types, shapes and
finiteness, and reads the CAD geometry.  Geometry (convexity, zero area or volume, a centre of mass
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
from sweeps.units import UNITS, UnitMissingError, parse_length, unit_factor
from sweeps.yamlio import YamlError, read_yaml

KINDS = ("polygon", "polyhedron")
DIMS = {"polygon": 2, "polyhedron": 3}
MIN_VERTICES = {"polygon": 3, "polyhedron": 4}

Number = Union[StrictInt, StrictFloat]


class PartFileError(UserError):
    """A part file that cannot be read; the one-line message names the file and the field.
    ``missing_unit``: the cause is a CAD file with no unit and an implausible size
    (:class:`sweeps.units.UnitMissingError`), for a caller to name its own fix."""

    missing_unit = False


class _PartSchema(BaseModel):
    """The raw YAML document (validated with pydantic v2)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=True)

    name: Optional[str] = None
    kind: Optional[Literal["polygon", "polyhedron"]] = None
    vertices: Optional[list[list[Number]]] = None
    mesh: Optional[str] = None
    outline: Optional[str] = None
    footprint: Optional[str] = None
    face: Optional[Union[StrictInt, str]] = None
    layer: Optional[str] = None
    chord_tolerance: Optional[Union[Number, str]] = None
    units: Optional[str] = None
    com: Optional[list[Union[Number, str]]] = None
    thickness: Optional[Union[Number, str]] = None
    density: Optional[Number] = None
    mass: Optional[Number] = None
    description: Optional[str] = None


ALLOWED_KEYS = tuple(_PartSchema.model_fields)


def part_fields() -> dict:
    """``{key: (type, default)}`` of a part document: the one list of a part's keys,
    which an inline part of a config (:class:`sweeps.config.PartInline`) declares too."""
    return {k: (f.annotation, f.default) for k, f in _PartSchema.model_fields.items()}


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
      units: the unit the part's lengths were read in (``m``, ``mm``, ...);
        units_from: where it came from (the part file, the CAD file, the default).
      cad: the :class:`sweeps.cad.CadGeometry` of a part given as CAD geometry
        (``mesh``, ``outline``, ``footprint``), else ``None``.  Its ``vertices``
        are the hull's, ``com`` the solid's own unless the file gives one, and
        ``density`` the one the hull (prism) needs to carry the real solid's mass.
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
    units: str = "m"
    units_from: str = "the default (metres)"
    cad: Optional[object] = None

    @property
    def source(self) -> pathlib.Path:
        """The file the geometry came from: the CAD file, else the part file."""
        return self.cad.source if self.cad is not None else self.path

    @property
    def loops(self) -> tuple:
        """The real outline's loops (m, the vertices' frame; outer first, then
        holes) of a CAD polygon, else ``()`` (the hull is the outline)."""
        return self.cad.loops if self.cad is not None else ()

    @property
    def warnings(self) -> tuple:
        """What reading the CAD file found (lines naming the file), else ``()``."""
        return self.cad.warnings if self.cad is not None else ()

    @property
    def source_label(self) -> str:
        """The geometry's file name, its unit and where the unit came from (reports)."""
        return f"{self.source.name} ({self.units}, {self.units_from})"

    @property
    def source_text(self) -> str:
        """One line: the geometry's file, its unit and where the unit came from."""
        head = f"{self.source} ({self.units}, {self.units_from})"
        return head + (f": {self.cad.description}" if self.cad is not None else "")

    @property
    def dim(self) -> int:
        """2 for a polygon, 3 for a polyhedron."""
        return DIMS[self.kind]

    def to_dict(self) -> dict:
        """Plain dict in the file format (lists of floats, metres: a CAD part's
        hull as a vertex list)."""
        d = {"name": self.name, "kind": self.kind, "vertices": self.vertices.tolist()}
        if self.com is not None:
            d["com"] = self.com.tolist()
        if self.description is not None:
            d["description"] = self.description
        for k in self.material_given:
            d[k] = float(getattr(self, k))
        if self.cad is not None:   # the hull with the real part's extrusion and mass
            d.pop("mass", None)
            d["density"] = float(self.density)
            if self.thickness is not None:
                d["thickness"] = float(self.thickness)
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


def parse_part(doc, path: Union[str, pathlib.Path] = "<part>", units_field: str = "units") -> PartFile:
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
        return _parse(doc, path, units_field)
    except ValueError as exc:
        err = PartFileError(f"{path}: {exc}")
        err.missing_unit = isinstance(exc, UnitMissingError)
        raise err from None


def _parse(doc, path: pathlib.Path, units_field: str = "units") -> PartFile:
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

    sources = [k for k in SOURCES if getattr(raw, k) is not None]
    if not sources:
        raise ValueError("vertices: required key is missing; give vertices: [[x, y], ...], or the "
                         "part's CAD file as mesh:, outline: or footprint:")
    if len(sources) > 1:
        raise ValueError(f"{sources[1]}: give the part's geometry once: one of "
                         f"{', '.join(SOURCES)} (got {' and '.join(sources)})")
    src = sources[0]
    for key, owner in OPTION_OF.items():
        if getattr(raw, key) is not None and src != owner:
            raise ValueError(f"{key}: only with {owner}: (the {owner} file's option); drop it")
    if raw.units is not None:
        unit_factor(raw.units, "units")
    cad = None
    if src == "vertices":
        kind, vertices, units = _vertex_list(raw)
        units_from = "the part file" if raw.units is not None else "the default (metres)"
    else:
        want = "polyhedron" if src == "mesh" else "polygon"
        if raw.kind is not None and raw.kind != want:
            hint = "footprint: (the mesh seen from above)" if want == "polyhedron" else "mesh:"
            raise ValueError(f"kind: {src}: gives a {want}, not a {raw.kind} (for a {raw.kind} "
                             f"use {hint})")
        cad = _read_cad(raw, src, path, units_field)
        kind, vertices, units, units_from = want, cad.vertices.copy(), cad.units, cad.units_from
    k = UNITS[units]
    dim = DIMS[kind]
    com = None
    if raw.com is not None:
        if len(raw.com) != dim:
            want = "[x, y]" if dim == 2 else "[x, y, z]"
            raise ValueError(f"com: a {kind} needs {want} ({dim} numbers), got {len(raw.com)}")
        com = np.array([parse_length(v, f"com[{i}]", k) for i, v in enumerate(raw.com)],
                       dtype=np.float64)
        _finite_rows(com, "com")
    elif cad is not None and cad.com is not None:
        com = np.asarray(cad.com, np.float64).copy()
    name = raw.name if raw.name is not None else (
        cad.source.stem if cad is not None and path.name == INLINE else path.stem)
    thickness, density, given = _material(raw, kind, vertices, k, cad)
    vertices.setflags(write=False)
    if com is not None:
        com.setflags(write=False)
    return PartFile(name=name, kind=kind, vertices=vertices, com=com,
                    description=raw.description, path=path, thickness=thickness,
                    density=density, material_given=given, units=units, units_from=units_from,
                    cad=cad)


#: the file name an inline part (in a study or certify config) is read as
INLINE = "<inline part>"

#: where a part's geometry may come from (exactly one), and the options that belong to one
SOURCES = ("vertices", "mesh", "outline", "footprint")
OPTION_OF = {"face": "footprint", "layer": "outline", "chord_tolerance": "outline"}


def _vertex_list(raw) -> tuple[str, np.ndarray, str]:
    """``(kind, vertices in metres, unit)`` of a part given as a vertex list."""
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
    units = (raw.units or "m").strip().lower()
    if units != "m":
        vertices = vertices * UNITS[units]
    return kind, vertices, units


def _read_cad(raw, src: str, path: pathlib.Path, units_field: str = "units"):
    """The :class:`sweeps.cad.CadGeometry` a part file's ``mesh`` / ``outline`` /
    ``footprint`` names (relative to the part file's folder)."""
    from sweeps import cad

    ref = pathlib.Path(getattr(raw, src)).expanduser()
    file = ref if ref.is_absolute() else path.parent / ref
    names = dict(field=src, units_field=units_field)
    if src == "mesh":
        return cad.read_mesh(file, raw.units, **names)
    if src == "footprint":
        return cad.read_footprint(file, "-z" if raw.face is None else raw.face, raw.units, **names)
    return cad.read_outline(file, raw.units, raw.layer, raw.chord_tolerance, **names)


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


def _material(raw, kind: str, vertices: np.ndarray, k: float = 1.0, cad=None):
    """``(thickness, density, given)`` from a part document's material keys
    (``k``: metres per unit of the part's lengths).  ``density`` is the one the
    modelled solid (the hull, or a polygon's hull extruded) gets so that its
    mass is the real part's: a CAD part's solid (the mesh, the plate with its
    holes) is smaller than its hull, so its material density is scaled by the
    solid's volume over the hull's."""
    given = tuple(k_ for k_ in ("thickness", "density", "mass") if getattr(raw, k_) is not None)
    thickness_m = None
    if raw.thickness is not None:
        thickness_m = parse_length(raw.thickness, "thickness", k)
    for key in given:
        v = thickness_m if key == "thickness" else float(getattr(raw, key))
        if not (np.isfinite(v) and v > 0):
            unit = {"thickness": "m", "density": "kg/m^3", "mass": "kg"}[key]
            raise ValueError(f"{key}: must be a finite number > 0 ({unit}), got {getattr(raw, key)!r}")
    if "density" in given and "mass" in given:
        raise ValueError("mass: give the part's density or its mass, not both")
    if kind == "polyhedron" and "thickness" in given:
        raise ValueError("thickness: a polyhedron's size is its vertices; thickness is a "
                         "polygon's extrusion (drop it)")
    thickness = None
    if kind == "polygon":
        height = getattr(cad, "height", None)
        thickness = thickness_m if thickness_m is not None else (
            height if height is not None else DEFAULT_THICKNESS)
    size = _solid_volume(vertices, kind, thickness)
    solid = None   # the real solid's volume, m^3, when it differs from the modelled hull's
    if cad is not None and cad.volume is not None:
        solid = cad.volume * (thickness if cad.height is None and kind == "polygon" else 1.0)
    density = float(raw.density) if raw.density is not None else DEFAULT_DENSITY[kind]
    if solid is not None and size > 0:
        density *= solid / size
    if raw.mass is not None:
        if not size > 0:
            raise ValueError("mass: the part has no area (volume) to spread its mass over")
        density = float(raw.mass) / size
    return thickness, density, given


def geometry_identity(parts) -> str:
    """Lines for a run's identity naming the content of the CAD files its parts
    were read from (``# part geometry: bracket.stl sha256 ...``), so that a run
    folder refuses to resume on an edited CAD file; ``""`` when no part comes
    from CAD (the identity of such runs is their config alone)."""
    seen = {}
    for part in parts:
        if part.cad is not None:
            seen[str(part.cad.source)] = f"# part geometry: {part.cad.source.name} sha256 {part.cad.sha256}"
    return "".join(line + "\n" for line in seen.values())


def load_part(path: Union[str, pathlib.Path], kind: Optional[str] = None,
              units: Optional[str] = None, face=None, units_field: str = "units") -> PartFile:
    """Read and validate a part file, or a CAD file given directly.

    Args:
      path: a YAML file in the format of this module's docstring, or a CAD
        file (:data:`sweeps.cad.CAD_SUFFIXES`): a DXF is an ``outline``; a mesh
        is a ``mesh`` (a polyhedron), or its ``footprint`` when ``kind`` is
        ``"polygon"`` (a command that pushes).
      kind, units, face: for a CAD file given directly: the kind wanted, its
        unit (``units:``) and a footprint's face; ``units_field`` names the
        unit's flag in messages (``--units``).

    Returns:
      A :class:`PartFile` (vertices and com as read-only float64 arrays, metres).

    Raises:
      PartFileError: missing or unreadable file, YAML syntax error, unknown
        or missing key, wrong type or shape, NaN or inf, bad CAD geometry; one
        line, starting with the path and naming the field.
    """
    from sweeps.cad import cad_kind

    what = cad_kind(path)
    if what is not None:
        key = "outline" if what == "outline" else ("footprint" if kind == "polygon" else "mesh")
        doc = {key: pathlib.Path(path).name}
        if units is not None:
            doc["units"] = units
        if face is not None and key == "footprint":
            doc["face"] = face
        return parse_part(doc, path, units_field=units_field)
    if units is not None:
        raise PartFileError(f"{path}: {units_field}: only for a CAD file given directly; a part "
                            f"file says its unit with units:")
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
