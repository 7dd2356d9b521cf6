"""CAD geometry for parts: meshes (trimesh) and DXF outlines (ezdxf), read into metres.

Three ways a part file (:mod:`sweeps.partfile`) names CAD geometry:

- ``mesh: bracket.stl`` (any format trimesh reads: STL, OBJ, PLY, OFF, GLB, ...):
  a polyhedron, the mesh's convex hull, its centre of mass the **mesh's own**
  (a solid of uniform density: :func:`read_mesh`);
- ``outline: plate.dxf``: a polygon, the DXF's closed loop (a closed LWPOLYLINE
  or POLYLINE, a CIRCLE, or LINE / ARC / open polyline pieces that chain into a
  loop), arcs flattened to a chord tolerance; loops inside the outline are
  holes, which move the plate's centre of mass (:func:`read_outline`);
- ``footprint: bracket.stl``: a polygon, the mesh seen from above when it rests
  on a named hull face (``face: -z`` or a face number as ``nudge plan-tumble``
  numbers them): the convex hull of the mesh's projection, its height the
  extrusion (:func:`read_footprint`).

Units (:mod:`sweeps.units`): the part file's ``units:`` when given, else the
file's own (a DXF's ``$INSUNITS``, a mesh format's unit metadata when trimesh
reads one), else metres; a file with no unit whose size is implausible in
metres (outside 0.1 mm .. 5 m) is refused, with the fix.  Every reader returns
a :class:`CadGeometry` in metres and the lines a user should read
(:attr:`CadGeometry.warnings`: an open mesh, a non-convex outline and the area
its hull adds, units that disagree, pieces that are not part of a loop).
Errors are ``ValueError``s with one line naming the file (and the DXF
entities' handles and layers) and the fix.
"""
from __future__ import annotations

import dataclasses
import hashlib
import math
import pathlib
from typing import Optional, Union

import numpy as np

from sweeps.units import UNIT_NAMES, UNITS, UnitMissingError, parse_length, unit_factor

MESH_SUFFIXES = (".stl", ".obj", ".ply", ".off", ".glb", ".gltf", ".3mf", ".dae")
OUTLINE_SUFFIXES = (".dxf",)
CAD_SUFFIXES = MESH_SUFFIXES + OUTLINE_SUFFIXES

#: Default chord tolerance of flattened arcs: the flattened outline is within this of the arc, m
DEFAULT_CHORD_TOL_M = 5e-5

#: Chord tolerance of the flattening the plate's area, centre of mass and holes come from, m
MASS_CHORD_TOL_M = 1e-6

#: A non-convex outline whose hull adds less than this fraction of its area is convex (round-off)
CONVEX_AREA_TOL = 1e-6

#: Sizes (largest extent, m) believable for a part whose file gives no unit (kernels.errors)
PLAUSIBLE_SIZE_M = (1e-4, 5.0)

#: DXF $INSUNITS codes nudge reads, and their unit names (0: unitless)
DXF_UNITS = {1: "in", 4: "mm", 5: "cm", 6: "m", 13: "um"}

AXES = {"-x": (-1, 0, 0), "+x": (1, 0, 0), "-y": (0, -1, 0), "+y": (0, 1, 0),
        "-z": (0, 0, -1), "+z": (0, 0, 1)}


@dataclasses.dataclass(frozen=True, eq=False)
class CadGeometry:
    """A part's geometry read from a CAD file, in metres.

    Attributes:
      kind: ``"polygon"`` (outline, footprint) or ``"polyhedron"`` (mesh).
      vertices: (m, 2) or (m, 3) convex hull vertices, m (the file's frame,
        scaled; a footprint's in the frame of the face it rests on).
      com: the solid's centre of mass, m, same frame; ``None`` when the file
        does not define one (an open mesh: the hull's centroid is used).
      volume: m^3 of the solid (mesh) or m^2 of the plate (outline, holes
        removed); ``None`` when undefined (open mesh).
      height: a footprint's extent along the face normal (m), else ``None``.
      loops: the real outline's closed loops in the vertices' frame, m, the
        outer one first then the holes (outline), or the hull (footprint);
        empty for a mesh.  For figures.
      source: the CAD file; sha256: its content's digest.
      units: the unit the file was read in; units_from: where that came from
        (``"the part file"``, ``"the file"``, ``"no unit given: metres"``).
      description: one line: what was read (``"mesh of 884 triangles,
        watertight; hull of 12 vertices"``).
      warnings: lines to show the user (each names the file).
    """

    kind: str
    vertices: np.ndarray
    com: Optional[np.ndarray]
    volume: Optional[float]
    height: Optional[float]
    loops: tuple
    source: pathlib.Path
    sha256: str
    units: str
    units_from: str
    description: str
    warnings: tuple = ()


#: Hull corners that turn less than this (deg: twice the push planner's default margin) are
#: flattened curves: a reorient push pivots on one corner and cannot turn past them
SMALL_TURN_DEG = 14.0


def _turn_warning(ring: np.ndarray, field: str, path: pathlib.Path, how: str) -> list:
    """A warning when a polygon's hull corners turn less than :data:`SMALL_TURN_DEG`
    (``ring``: the hull's vertices counter-clockwise, as scipy's 2-D hull gives them)."""
    e = np.roll(ring, -1, axis=0) - ring
    ang = np.arctan2(e[:, 1], e[:, 0])
    turn = np.degrees(np.mod(np.roll(ang, -1) - ang, 2 * np.pi))
    small = int(np.sum(turn < SMALL_TURN_DEG))
    if not small:
        return []
    fix = "; a coarser chord_tolerance gives fewer, sharper corners" if "flattened" in how else ""
    return [f"{field}: {path.name}: {small} of the hull's {len(ring)} corners turn less than "
            f"{SMALL_TURN_DEG:g} deg (the smallest {turn.min():.3g} deg: {how}); a reorient push "
            f"turns the part about one corner, so plans need many short pushes or none{fix}"]


def _has_curves(entities) -> bool:
    """Whether DXF entities hold arcs or curves (not only straight segments)."""
    for e in entities:
        t = e.dxftype()
        if t in ("ARC", "CIRCLE", "ELLIPSE", "SPLINE"):
            return True
        if t == "LWPOLYLINE" and any(abs(p[0]) > 0 for p in e.get_points("b")):
            return True
        if t == "POLYLINE" and any(abs(v.dxf.get("bulge", 0)) > 0 for v in e.vertices):
            return True
    return False


def cad_kind(path: Union[str, pathlib.Path]) -> Optional[str]:
    """``"mesh"``, ``"outline"`` or ``None`` from a file name's suffix."""
    suffix = pathlib.Path(path).suffix.lower()
    if suffix in MESH_SUFFIXES:
        return "mesh"
    if suffix in OUTLINE_SUFFIXES:
        return "outline"
    return None


def _digest(path: pathlib.Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _resolve_units(given: Optional[str], in_file: Optional[str], path: pathlib.Path,
                   units_field: str) -> tuple[str, str, list]:
    """``(unit, where it came from, warnings)`` of a CAD file."""
    warns = []
    if given is not None:
        unit_factor(given, units_field)
        given = given.strip().lower()
        if in_file is not None and in_file != given:
            warns.append(f"{units_field}: {path.name} says its unit is {in_file}, the part says "
                         f"{given}; read as {given} ({units_field} wins: drop it to use the file's)")
        return given, "the part file" if units_field == "units" else units_field, warns
    if in_file is not None:
        return in_file, f"the file ({path.suffix.lstrip('.').upper()} header)", warns
    return "m", "no unit given: metres", warns


def _check_size(points: np.ndarray, unit: str, units_from: str, path: pathlib.Path,
                units_field: str) -> None:
    """Refuse a file with no unit whose size is implausible in metres."""
    if not units_from.startswith("no unit"):
        return
    d = points.max(axis=0) - points.min(axis=0)
    size = float(np.linalg.norm(d))
    lo, hi = PLAUSIBLE_SIZE_M
    if lo <= size <= hi or size == 0:
        return
    hint = f"{units_field}: mm; one of {UNIT_NAMES}" if size > hi else \
        f"{units_field}: one of {UNIT_NAMES}"
    raise UnitMissingError(f"{units_field}: {path.name} carries no unit and is {size:.4g} across: "
                           f"read as metres that is a part {size:.4g} m across; give its unit "
                           f"({hint})")


def _hull(points: np.ndarray, what: str, path: pathlib.Path):
    from scipy.spatial import ConvexHull, QhullError

    try:
        return ConvexHull(points)
    except (QhullError, ValueError):
        dim = points.shape[1]
        raise ValueError(f"{path.name}: the {what} has no {'area' if dim == 2 else 'volume'} "
                         f"(its points are {'collinear' if dim == 2 else 'coplanar'})"
                         + ("; a flat part is pushed: use outline: or footprint:" if dim == 3
                            else "")) from None


# --------------------------------------------------------------------------
# Meshes
# --------------------------------------------------------------------------
#: the first bytes of files that are often given a mesh's name by mistake
_MAGIC = {b"\x89PNG": "a PNG image", b"\xff\xd8\xff": "a JPEG image", b"%PDF": "a PDF document",
          b"PK\x03\x04": "a ZIP archive (a 3MF or an office file?)", b"GIF8": "a GIF image",
          b"\x1f\x8b": "a gzip archive"}


def _check_stl(path: pathlib.Path, field: str) -> None:
    """An STL file's own consistency, before a mesh library guesses at it: ASCII
    (``solid`` ... ``facet``) or binary (an 80-byte header, a triangle count
    ``n``, then exactly ``50 n`` bytes).  A file of another kind, or a truncated
    one, is one line naming what it is."""
    size = path.stat().st_size
    with open(path, "rb") as fh:
        head = fh.read(84)
        if head.lstrip().startswith(b"solid") and b"facet" in head + fh.read(4096):
            return                                             # ASCII STL
    for magic, what in _MAGIC.items():
        if head.startswith(magic):
            raise ValueError(f"{field}: {path.name} is {what}, not an STL mesh (its first bytes "
                             "say so); export the part as STL, OBJ or PLY")
    if size < 84:
        raise ValueError(f"{field}: {path.name} is not an STL mesh: {size} bytes, fewer than a "
                         "binary STL's 84-byte header")
    n = int.from_bytes(head[80:84], "little")
    if size != 84 + 50 * n:
        raise ValueError(f"{field}: {path.name} is not a whole binary STL: its header promises {n} "
                         f"triangles ({84 + 50 * n} bytes), the file has {size} bytes "
                         "(truncated, or not an STL); export it again")


def _load_mesh(path: pathlib.Path, field: str):
    import trimesh

    if not path.is_file():
        raise ValueError(f"{field}: no such file {str(path)!r}")
    if path.suffix.lower() == ".stl":
        _check_stl(path, field)
    try:   # unprocessed first: processing drops non-finite vertices without a word
        mesh = trimesh.load(str(path), force="mesh", process=False)
    except Exception as exc:   # noqa: BLE001 - trimesh raises many types for a bad file
        raise ValueError(f"{field}: {path.name} cannot be read as a mesh "
                         f"({type(exc).__name__}: {' '.join(str(exc).split())[:160]})") from None
    faces = getattr(mesh, "faces", None)
    n_tri = 0 if faces is None else len(faces)
    if n_tri == 0:
        raise ValueError(f"{field}: {path.name} holds no triangles (an empty or unreadable mesh)")
    _check_finite(np.asarray(mesh.vertices), path, field)
    mesh.process()
    if n_tri < 4 or len(mesh.vertices) < 4:
        raise ValueError(f"{field}: {path.name} holds {n_tri} triangle{'s' if n_tri != 1 else ''} "
                         f"on {len(mesh.vertices)} vertices: a solid needs a closed surface of at "
                         "least 4 triangles (a tetrahedron); export the whole part as a solid")
    return mesh


def _check_finite(vertices: np.ndarray, path: pathlib.Path, field: str) -> None:
    """Refuse a mesh with a vertex that is not a finite number (NaN, inf): a
    mesh library drops it and the faces that use it, and the part is planned
    with holes.  An STL's vertices are numbered by triangle; other formats'
    as the file lists them (from 1, as OBJ numbers them)."""
    bad = np.flatnonzero(~np.all(np.isfinite(vertices), axis=1))
    if not bad.size:
        return
    i = int(bad[0])
    xyz = ", ".join(f"{x:g}" for x in vertices[i])
    where = (f"triangle {i // 3 + 1}'s vertex {i % 3 + 1}" if path.suffix.lower() == ".stl"
             else f"vertex {i + 1}")
    more = f" (and {bad.size - 1} more)" if bad.size > 1 else ""
    raise ValueError(f"{field}: {path.name}: {where} is not a finite number ({xyz}){more}; fix "
                     "the coordinates or export the mesh again")


def _mesh_units(mesh) -> Optional[str]:
    u = getattr(mesh, "units", None)
    if not u:
        return None
    u = str(u).strip().lower()
    return {"millimeters": "mm", "millimeter": "mm", "meters": "m", "meter": "m",
            "inches": "in", "inch": "in", "centimeters": "cm", "centimeter": "cm",
            "micrometers": "um", "microns": "um"}.get(u, u if u in UNITS else None)


def _solid(mesh, path: pathlib.Path, field: str) -> tuple[Optional[np.ndarray], Optional[float], str, list]:
    """The mesh's centre of mass and volume in its own unit, a description, warnings."""
    warns = []
    n_tri = len(mesh.faces)
    if mesh.is_watertight:
        volume = float(mesh.volume)
        if volume < 0:   # inward normals: the same solid
            mesh = mesh.copy()
            mesh.invert()
            volume = -volume
        if mesh.is_winding_consistent and volume > 0:
            return (np.asarray(mesh.center_mass, np.float64), volume,
                    f"mesh of {n_tri} triangles, closed", warns)
    edges = mesh.edges_sorted
    _, counts = np.unique(edges, axis=0, return_counts=True)
    open_edges = int(np.sum(counts == 1))
    shared = int(np.sum(counts > 2))
    what = ", ".join(x for x in (f"{open_edges} open edges" if open_edges else "",
                                 f"{shared} edges shared by more than two faces" if shared else "",
                                 "inconsistent winding" if not mesh.is_winding_consistent else "")
                     if x) or "not a closed volume"
    warns.append(f"{field}: {path.name} is not a closed, manifold mesh ({what}): its convex hull "
                 f"is still defined and is used, but the solid's centre of mass and volume are "
                 f"not: the hull's are used (give com: and mass: for the real part)")
    return None, None, f"mesh of {n_tri} triangles, open", warns


def read_mesh(path: Union[str, pathlib.Path], units: Optional[str] = None, *,
              field: str = "mesh", units_field: str = "units") -> CadGeometry:
    """A polyhedron from a mesh file: its convex hull and the mesh's own centre
    of mass (a solid of uniform density), in metres.

    Args:
      path: a mesh file trimesh reads (STL, OBJ, PLY, ...).
      units: the part file's ``units:`` (one of :data:`sweeps.units.UNITS`), or
        ``None``: the file's unit if it carries one, else metres.
      field, units_field: the part-file keys named in messages.

    Raises:
      ValueError: one line: unreadable, empty, flat, or no unit with an
        implausible size.
    """
    return _read_mesh(path, units, field, units_field)[0]


def _read_mesh(path, units, field: str, units_field: str):
    """:func:`read_mesh`'s geometry and the kernel's polyhedron of its hull (``None``
    when the kernel refuses it: the planner says why when the part is used)."""
    path = pathlib.Path(path)
    mesh = _load_mesh(path, field)
    unit, units_from, warns = _resolve_units(units, _mesh_units(mesh), path, units_field)
    pts = np.asarray(mesh.vertices, np.float64)
    _check_size(pts, unit, units_from, path, units_field)
    k = UNITS[unit]
    hull = _hull(pts * k, "mesh", path)
    _check_hull_size(hull, len(mesh.faces), path, field)
    com, volume, desc, more = _solid(mesh, path, field)
    warns += more
    bodies = int(mesh.body_count)
    if bodies > 1:
        warns.append(f"{field}: {path.name} holds {bodies} separate bodies (unconnected pieces): "
                     f"nudge plans one rigid part, the hull of all of them with their joint "
                     f"centre of mass; keep one part per file")
    verts = np.ascontiguousarray(hull.points[hull.vertices])
    com = None if com is None else com * k
    poly = _polyhedron(verts, com)
    warns += _sliver_warning(poly, verts, field, path)
    geo = CadGeometry(kind="polyhedron", vertices=verts, com=com,
                      volume=None if volume is None else volume * k ** 3, height=None, loops=(),
                      source=path, sha256=_digest(path), units=unit, units_from=units_from,
                      description=f"{desc}; convex hull of {len(verts)} vertices",
                      warnings=tuple(warns))
    return geo, poly


#: The most convex-hull vertices a mesh may have: the hull's faces are a tumble's
#: resting faces, merged and checked one by one (kernels.make_polyhedron: about 1 s
#: at 2,000 vertices, minutes at 100,000: a finely tessellated sphere of 200,000
#: triangles)
MAX_HULL_VERTICES = 2000


def _check_hull_size(hull, n_tri: int, path: pathlib.Path, field: str) -> None:
    """Refuse a mesh whose convex hull has more than :data:`MAX_HULL_VERTICES`
    vertices (a curved surface finely tessellated), before the hull's faces
    are worked out."""
    n = len(hull.vertices)
    if n <= MAX_HULL_VERTICES:
        return
    raise ValueError(f"{field}: {path.name}: its convex hull has {n:,} vertices ({n_tri:,} "
                     f"triangles in the mesh: a curved surface finely tessellated); nudge takes "
                     f"hulls of at most {MAX_HULL_VERTICES:,} vertices - decimate the mesh (e.g. "
                     f"trimesh's simplify_quadric_decimation, MeshLab's Quadric Edge Collapse) or "
                     f"export it with a coarser chord tolerance")


def _polyhedron(verts: np.ndarray, com, raise_errors: bool = False):
    """The kernel's polyhedron of a hull (:func:`kernels.make_polyhedron`, its warnings
    muted: the planner raises them again); ``None`` when it refuses the hull, unless
    ``raise_errors``."""
    import warnings

    from kernels import make_polyhedron

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            return make_polyhedron(verts, com)
        except ValueError:
            if raise_errors:
                raise
            return None


#: Hull faces meeting at less than this from flat (rad, 1 deg) are CAD noise on one face
SLIVER_RAD = math.radians(1.0)


def _sliver_warning(poly, verts: np.ndarray, field: str, path: pathlib.Path) -> list:
    """A warning when hull faces meet nearly flat (tessellation noise: a face of the
    part split in several for the tumble planner), beyond what the kernel merges
    or warns about itself (:data:`kernels.polyhedron.NEARLY_FLAT_RAD`); ``poly``
    the hull's polyhedron (``None``: nothing to say here)."""
    from kernels import NEARLY_FLAT_RAD, TOLERANCE_MERGE_FACTOR

    if poly is None:
        return []
    bend = math.pi - np.asarray(poly.dihedral_angles, np.float64)
    near = np.flatnonzero((bend < SLIVER_RAD) & (bend > NEARLY_FLAT_RAD))
    if not len(near):
        return []
    worst = float(bend[near].min())
    size = float(np.ptp(verts, axis=0).max())
    edges = "1 hull edge joins" if len(near) == 1 else f"{len(near)} hull edges join"
    return [f"{field}: {path.name}: {edges} faces within "
            f"{math.degrees(worst):.2g} deg of flat (edges {[poly.edges[i] for i in near[:4]]}): "
            f"tessellation noise splits a face for the tumble planner (long plans, sliver faces); "
            f"a vertex tolerance merges them (--tau-v / planner.tumble_tau_v of about "
            f"{worst * size / TOLERANCE_MERGE_FACTOR:.2g} m or more) or fix the mesh"]


def _face_normal(face, poly, path: pathlib.Path, field: str) -> tuple[np.ndarray, str]:
    """The outward normal of the hull face (of the polyhedron ``poly``) the part
    rests on, and its name."""
    normals = np.asarray(poly.normals, np.float64)
    normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    if isinstance(face, str) and face.strip().lower() in AXES:
        n = np.asarray(AXES[face.strip().lower()], np.float64)
        j = int(np.argmax(normals @ n))
        if normals[j] @ n < 1 - 1e-9:
            raise ValueError(f"{field}: face {face}: {path.name} has no flat face facing {face} "
                             f"(its {face} side is an edge or a corner); name a face number "
                             f"0..{len(normals) - 1} (nudge plan-tumble numbers them)")
        name = face.strip().lower()
    elif isinstance(face, int) and not isinstance(face, bool) and 0 <= face < len(normals):
        j, name = face, f"face {face}"
    else:
        raise ValueError(f"{field}: face: expected one of {', '.join(AXES)} or a face number "
                         f"0..{len(normals) - 1}, got {face!r}")
    # the part must rest on that face: its centre of mass above the face
    c = np.asarray(poly.com, np.float64)
    corners = np.asarray(poly.vertices)[list(poly.faces[j])]
    if not _above(c, corners, normals[j]):
        raise ValueError(f"{field}: face {face}: {path.name} does not rest on that face (its centre "
                         f"of mass is not above it: the part tips onto another face); choose a "
                         f"stable face")
    return normals[j], name


def _above(c: np.ndarray, corners: np.ndarray, n: np.ndarray) -> bool:
    """Whether ``c`` projects strictly inside the convex face ``corners`` (normal ``n``)."""
    e1, e2 = _plane_frame(n)
    q = (corners - c) @ np.stack([e1, e2]).T
    from scipy.spatial import ConvexHull

    h = ConvexHull(q)
    return bool(np.all(h.equations[:, 2] < -1e-12 * max(1.0, float(np.ptp(q)))))


def _plane_frame(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(e1, e2)``: in-plane axes of the table when the part rests on a face of
    outward normal ``n`` (up = -n), right-handed about up; e1 the mesh's x
    axis projected (its y when x is vertical)."""
    up = -n / np.linalg.norm(n)
    ref = np.array([1.0, 0.0, 0.0]) if abs(up[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = ref - (ref @ up) * up
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(up, e1)
    return e1, e2


def read_footprint(path: Union[str, pathlib.Path], face="-z", units: Optional[str] = None, *,
                   field: str = "footprint", units_field: str = "units") -> CadGeometry:
    """A polygon from a mesh resting on one of its hull faces: the convex hull of
    the mesh projected onto the table (what a fence touches), in the table
    frame of that face (x: the mesh's x axis projected, y: up x x), metres; the
    mesh's centre of mass projected; ``height`` the mesh's extent along the
    face normal (the extrusion the physics cell uses).

    Args:
      face: ``-z`` (default: the mesh lying as drawn), ``+z``, ``-x`` ... or a
        hull face number as :func:`kernels.make_polyhedron` numbers them.

    Raises:
      ValueError: as :func:`read_mesh`; a face that does not exist or that the
        part does not rest on.
    """
    geo, poly = _read_mesh(path, units, field, units_field)
    if poly is None:   # the kernel's own message for a hull it refuses
        poly = _polyhedron(geo.vertices, geo.com, raise_errors=True)
    n, name = _face_normal(face, poly, geo.source, field)
    e1, e2 = _plane_frame(n)
    basis = np.stack([e1, e2]).T
    pts2 = geo.vertices @ basis
    hull = _hull(pts2, "footprint", geo.source)
    verts = np.ascontiguousarray(pts2[hull.vertices])
    height = float(np.ptp(geo.vertices @ n))
    turns = _turn_warning(verts, field, geo.source, "curved faces seen from above")
    com = None if geo.com is None else geo.com @ basis
    return dataclasses.replace(
        geo, kind="polygon", vertices=verts, com=com, height=height, loops=(verts,),
        warnings=geo.warnings + tuple(turns),
        description=f"{geo.description}; footprint on {name}: {len(verts)} vertices, "
                    f"{height * 1e3:.4g} mm high")


# --------------------------------------------------------------------------
# DXF outlines
# --------------------------------------------------------------------------
def _entity_name(e) -> str:
    layer = e.dxf.get("layer", "0")
    return f"{e.dxftype()} #{e.dxf.handle} (layer {layer})"


def _points_of(e, chord: float) -> np.ndarray:
    """An entity flattened to (k, 2) points in the WCS xy-plane (chord: file units)."""
    from ezdxf import path as dxfpath

    p = dxfpath.make_path(e)
    pts = np.array([(v.x, v.y) for v in p.flattening(distance=chord, segments=1)], np.float64)
    return pts


def _shoelace(loop: np.ndarray) -> tuple[float, np.ndarray]:
    """Signed area and centroid of a closed polygon (last point != first)."""
    x, y = loop[:, 0], loop[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    a = 0.5 * float(np.sum(cross))
    if a == 0:
        return 0.0, loop.mean(axis=0)
    cx = float(np.sum((x + xn) * cross)) / (6 * a)
    cy = float(np.sum((y + yn) * cross)) / (6 * a)
    return a, np.array([cx, cy])


def _inside(pts: np.ndarray, loop: np.ndarray) -> np.ndarray:
    from matplotlib.path import Path

    return Path(loop).contains_points(pts)


def _dedupe(pts: np.ndarray, tol: float) -> np.ndarray:
    """Drop consecutive points within ``tol`` and a closing point equal to the first."""
    keep = [pts[0]]
    for p in pts[1:]:
        if np.linalg.norm(p - keep[-1]) > tol:
            keep.append(p)
    if len(keep) > 1 and np.linalg.norm(keep[-1] - keep[0]) <= tol:
        keep.pop()
    return np.asarray(keep)


def _crossing(loop: np.ndarray) -> Optional[np.ndarray]:
    """Where a closed polygon ``loop`` ((k, 2), last point != first) crosses
    itself: the point where two of its sides that share no corner cross
    properly, or None.  A sweep over the sides sorted by their left end: a side
    is tested only against the sides that overlap it in x (all at once)."""
    a = loop
    b = np.roll(loop, -1, axis=0)
    n = len(a)
    if n < 4:
        return None
    lo, hi = np.minimum(a[:, 0], b[:, 0]), np.maximum(a[:, 0], b[:, 0])
    order = np.argsort(lo, kind="stable")
    stop = np.searchsorted(lo[order], hi[order], side="right")   # sides starting before i ends
    count = np.maximum(stop - np.arange(n) - 1, 0)
    scale = float(np.ptp(loop, axis=0).max())

    def cross(o, p, q):
        return (p[:, 0] - o[:, 0]) * (q[:, 1] - o[:, 1]) - (p[:, 1] - o[:, 1]) * (q[:, 0] - o[:, 0])

    for first in range(0, n, 4096):   # blocks of sides: bounded memory
        c = count[first:first + 4096]
        if not c.sum():
            continue
        rows = np.repeat(np.arange(first, first + len(c)), c)
        offs = np.arange(len(rows)) - np.repeat(np.cumsum(c) - c, c)
        i, j = order[rows], order[rows + 1 + offs]
        near = (np.abs(i - j) == 1) | (np.abs(i - j) == n - 1)        # neighbours share a corner
        i, j = i[~near], j[~near]
        d1, d2 = cross(a[i], b[i], a[j]), cross(a[i], b[i], b[j])
        d3, d4 = cross(a[j], b[j], a[i]), cross(a[j], b[j], b[i])
        eps = 1e-12 * scale * scale
        hit = np.flatnonzero((d1 * d2 < 0) & (d3 * d4 < 0) & (np.abs(d1 - d2) > eps)
                             & (np.minimum(np.abs(d1), np.abs(d2)) > eps)
                             & (np.minimum(np.abs(d3), np.abs(d4)) > eps))
        if hit.size:
            h = hit[0]
            t = d3[h] / (d3[h] - d4[h])
            return a[i[h]] + t * (b[i[h]] - a[i[h]])
    return None


def _chain(pieces: list, tol: float) -> tuple[list, list]:
    """Closed loops from open pieces joined end to end (``tol``: gap, file units).

    Returns ``(loops, leftovers)``: loops as ``(points, [entities])``, leftovers
    the entities that close no loop."""
    from scipy.spatial import cKDTree

    ends = np.array([p[0][[0, -1]] for p in pieces]).reshape(-1, 2)
    tree = cKDTree(ends)
    node = np.arange(len(ends))
    for i, j in sorted(tree.query_pairs(tol)):   # union-find of coincident ends
        a, b = i, j
        while node[a] != a:
            a = node[a]
        while node[b] != b:
            b = node[b]
        node[max(a, b)] = min(a, b)
    for i in range(len(node)):
        r = i
        while node[r] != r:
            r = node[r]
        node[i] = r
    start, end = node[0::2], node[1::2]
    incident: dict = {}
    for k, (s, e) in enumerate(zip(start, end)):
        incident.setdefault(s, []).append(k)
        incident.setdefault(e, []).append(k)
    used = np.zeros(len(pieces), bool)
    loops, leftovers = [], []
    for k0 in range(len(pieces)):
        if used[k0]:
            continue
        # walk from piece k0 along degree-2 nodes until it closes or breaks
        chain, pts = [k0], [pieces[k0][0]]
        used[k0] = True
        head, at = start[k0], end[k0]
        ok = True
        while at != head:
            nxt = [k for k in incident.get(at, []) if not used[k]]
            if len(incident.get(at, [])) != 2 or len(nxt) != 1:
                ok = False
                break
            k = nxt[0]
            used[k] = True
            seg = pieces[k][0] if start[k] == at else pieces[k][0][::-1]
            at = end[k] if start[k] == at else start[k]
            chain.append(k)
            pts.append(seg)
        if ok and len(incident.get(head, [])) == 2:
            loops.append((np.concatenate(pts), [pieces[k][1] for k in chain]))
        else:
            # mark every piece reachable from this one as left over
            leftovers += [pieces[k][1] for k in chain]
    return loops, leftovers


def read_outline(path: Union[str, pathlib.Path], units: Optional[str] = None,
                 layer: Optional[str] = None, chord_tolerance=None, *,
                 field: str = "outline", units_field: str = "units") -> CadGeometry:
    """A polygon from a DXF outline: the convex hull of its one closed loop, the
    plate's centre of mass with the loops inside it (holes) removed, metres.

    Args:
      path: a DXF file.  Its model space's LINE, ARC, CIRCLE, ELLIPSE, SPLINE,
        LWPOLYLINE and POLYLINE entities are read; closed ones are loops, open
        ones are joined end to end (gap: 1e-6 of the drawing's size) into
        loops.  The outline is the largest loop (on ``layer``, when given);
        every other loop (on that layer) must lie inside it; the loops inside
        it (on any layer) are holes.
      units: the part's unit (else the DXF's ``$INSUNITS``, else metres).
      chord_tolerance: arcs and curves are flattened so that no point of the
        curve is farther than this from the polyline: a number in the part's
        unit (the one resolved here) or a length string (``'0.02 mm'``);
        default :data:`DEFAULT_CHORD_TOL_M`, 0.05 mm.

    Raises:
      ValueError: one line: unreadable file, no closed loop (naming the open
        entities), several loops side by side (naming them), an unknown
        ``$INSUNITS``, no unit with an implausible size.
    """
    import ezdxf

    path = pathlib.Path(path)
    if not path.is_file():
        raise ValueError(f"{field}: no such file {str(path)!r}")
    try:
        doc = ezdxf.readfile(str(path))
    except (OSError, ezdxf.DXFError, UnicodeDecodeError, ValueError) as exc:
        raise ValueError(f"{field}: {path.name} cannot be read as a DXF drawing "
                         f"({' '.join(str(exc).split())[:160] or type(exc).__name__})") from None
    code = int(doc.header.get("$INSUNITS", 0) or 0)
    if code and code not in DXF_UNITS and units is None:
        from ezdxf.units import unit_name

        raise ValueError(f"{units_field}: {path.name} is drawn in {unit_name(code)} ($INSUNITS "
                         f"{code}), which nudge does not read; give units: ({UNIT_NAMES})")
    unit, units_from, warns = _resolve_units(units, DXF_UNITS.get(code), path, units_field)
    k = UNITS[unit]
    chord_m = DEFAULT_CHORD_TOL_M if chord_tolerance is None else \
        parse_length(chord_tolerance, "chord_tolerance", k)
    if not chord_m > 0:
        raise ValueError(f"chord_tolerance: must be > 0, got {chord_tolerance!r}")
    chord = chord_m / k

    kinds = ("LINE", "ARC", "CIRCLE", "ELLIPSE", "SPLINE", "LWPOLYLINE", "POLYLINE")
    msp = doc.modelspace()
    entities = [e for e in msp if e.dxftype() in kinds]
    layers = sorted({e.dxf.get("layer", "0") for e in entities})
    if not entities:
        inserts = sum(1 for e in msp if e.dxftype() == "INSERT")
        raise ValueError(f"{field}: {path.name} has no lines or curves in its model space"
                         + (f" ({inserts} block references: explode them in the CAD tool)"
                            if inserts else ""))
    if layer is not None and layer not in layers:
        raise ValueError(f"layer: {path.name} has no lines or curves on layer {layer!r} "
                         f"(layers with some: {', '.join(layers)})")
    from ezdxf.edgesmith import is_closed_entity

    # loops, holes and the plate's mass properties from a fine flattening (1 um chords:
    # area and centre of mass within ~1e-4 and ~1 um of the curves'); the hull's vertices
    # from the chord tolerance asked for
    fine = min(chord, MASS_CHORD_TOL_M / k)
    closed, pieces, skipped = [], [], []
    for e in entities:
        try:
            pts = _points_of(e, fine)
        except Exception:   # noqa: BLE001 - a 3D or mesh polyline ezdxf cannot flatten
            skipped.append(e)
            continue
        if len(pts) < 2:
            continue
        if is_closed_entity(e) or e.dxftype() == "CIRCLE":
            closed.append((pts, [e]))
        else:
            pieces.append((pts, e))
    if skipped:
        warns.append(f"{field}: {path.name}: {len(skipped)} entities cannot be flattened into the "
                     f"drawing's plane and are ignored ({', '.join(map(_entity_name, skipped[:4]))})")
    if not closed and not pieces:
        raise ValueError(f"{field}: {path.name} has no lines or curves nudge can read in its "
                         f"model space")
    allpts = np.concatenate([c[0] for c in closed] + [p[0] for p in pieces])
    _check_size(allpts, unit, units_from, path, units_field)
    gap = 1e-6 * float(np.linalg.norm(allpts.max(axis=0) - allpts.min(axis=0)))
    loops, leftovers = _chain(pieces, gap) if pieces else ([], [])
    loops = closed + loops
    loops = [(_dedupe(pts, gap), ents) for pts, ents in loops]
    for pts, ents in loops:
        if layer is not None and ents[0].dxf.get("layer", "0") != layer:
            continue
        at = _crossing(pts)
        if at is not None:
            names = ", ".join(_entity_name(e) for e in ents[:4]) + (" ..." if len(ents) > 4 else "")
            raise ValueError(f"{field}: {path.name}: the loop {names} crosses itself at "
                             f"({at[0]:.4g}, {at[1]:.4g}) {unit} (a figure of eight or a bow tie: "
                             f"its inside is not defined); redraw it as one loop that does not "
                             f"cross itself")
    loops = [(pts, ents) for pts, ents in loops if len(pts) >= 3 and abs(_shoelace(pts)[0]) > 0]
    on_layer = [lp for lp in loops if layer is None or lp[1][0].dxf.get("layer", "0") == layer]
    if not on_layer:
        bad = [e for e in leftovers if layer is None or e.dxf.get("layer", "0") == layer]
        names = ", ".join(_entity_name(e) for e in bad[:6])
        more = f" and {len(bad) - 6} more" if len(bad) > 6 else ""
        raise ValueError(f"{field}: {path.name} has no closed loop"
                         + (f" on layer {layer!r}" if layer is not None else "")
                         + (f": {names}{more} do not join end to end into one" if bad else "")
                         + " (close the outline in the CAD tool)")
    if leftovers:
        names = ", ".join(_entity_name(e) for e in leftovers[:4])
        warns.append(f"{field}: {path.name}: {len(leftovers)} entities close no loop and are "
                     f"ignored ({names}{' ...' if len(leftovers) > 4 else ''})")

    def area(lp):
        return abs(_shoelace(lp[0])[0])

    def say(lp):
        pts, ents = lp
        ext = (pts.max(axis=0) - pts.min(axis=0)) * k * 1e3
        return (f"{_entity_name(ents[0])}{' +' if len(ents) > 1 else ''} ({ext[0]:.3g} x "
                f"{ext[1]:.3g} mm)")

    on_layer.sort(key=area, reverse=True)
    outer_pts, outer_ents = outer = on_layer[0]
    apart = [lp for lp in on_layer[1:] if not np.all(_inside(lp[0], outer_pts))]
    if apart:
        named = "; ".join(say(lp) for lp in [outer] + apart[:3])
        raise ValueError(f"{field}: {path.name} has {len(apart) + 1} closed outlines side by side: "
                         f"{named}; keep one part per file, or name its layer with layer:")
    # holes: the loops inside the outline (on any layer when the outline's layer is named)
    holes = [lp for lp in (loops if layer is not None else on_layer)
             if lp is not outer and lp[0] is not outer_pts and np.all(_inside(lp[0], outer_pts))]
    nested = [(a, b) for a in holes for b in holes if a is not b and np.all(_inside(a[0], b[0]))]
    if nested:
        a, b = nested[0]
        raise ValueError(f"{field}: {path.name}: {say(a)} lies inside {say(b)}, inside the outline "
                         f"{say(outer)}: nested loops (a border drawn around the part, or an "
                         f"island in a hole); name the part's layer with layer:")
    if sum(area(h) for h in holes) > 0.5 * area(outer):
        raise ValueError(f"{field}: {path.name}: the loops inside {say(outer)} cover more than half "
                         f"of it: is it a drawing border around the part? name the part's layer "
                         f"with layer:")
    a_out, c_out = _shoelace(outer_pts)
    a_out = abs(a_out)
    solid_area = a_out - sum(abs(_shoelace(h[0])[0]) for h in holes)
    moment = a_out * c_out - sum(abs(_shoelace(h[0])[0]) * _shoelace(h[0])[1] for h in holes)
    com = moment / solid_area
    added = float(_hull(outer_pts, "outline", path).volume) - a_out
    coarse = np.concatenate([_points_of(e, chord) for e in outer_ents])
    hull = _hull(coarse, "outline", path)
    if added > CONVEX_AREA_TOL * a_out:
        warns.append(f"{field}: {path.name}'s outline is not convex: nudge plans for its convex "
                     f"hull, which adds {added * k * k * 1e6:.4g} mm^2 ({100 * added / a_out:.3g}% "
                     f"of its area); a fence touches only the hull")
    verts = np.ascontiguousarray(coarse[hull.vertices] * k)
    warns += _turn_warning(verts, field, path,
                           f"arcs flattened to {chord * k * 1e3:.3g} mm" if _has_curves(outer_ents)
                           else "corners of the drawing")
    ccw = [outer_pts if _shoelace(outer_pts)[0] > 0 else outer_pts[::-1]]
    loops_m = tuple(np.ascontiguousarray(lp * k) for lp in ccw + [h[0] for h in holes])
    hole_text = f", {len(holes)} hole{'s' if len(holes) != 1 else ''}" if holes else ""
    return CadGeometry(
        kind="polygon", vertices=verts, com=com * k, volume=solid_area * k * k, height=None,
        loops=loops_m, source=path, sha256=_digest(path), units=unit, units_from=units_from,
        description=(f"DXF outline {_entity_name(outer_ents[0])}"
                     f"{f' + {len(outer_ents) - 1} more' if len(outer_ents) > 1 else ''}"
                     f"{hole_text}; arcs to {chord * k * 1e3:.3g} mm; convex hull of "
                     f"{len(verts)} vertices"),
        warnings=tuple(warns))
