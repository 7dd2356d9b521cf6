"""Generate the two CAD example parts shipped with nudge.

Running ``python examples/make_cad_parts.py`` (from any folder: the files are
written next to this script) produces:

``bracket.stl``
    A binary STL of an aluminium angle bracket, coordinates in MILLIMETRES:
    a base flange 60 x 40 x 5 mm (x = 0..60, y = 0..40, z = 0..5), an upright
    flange 5 x 40 x 45 mm (x = 0..5, y = 0..40, z = 0..45), a 4 mm triangular
    gusset rib centred at y = 20 in the inner corner (legs 25 mm along x and
    z from the inner corner), a 3 mm inner fillet along the inner corner, two
    6.5 mm through-holes in the base flange (x = 40, y = 10 and y = 30) and
    two in the upright (y = 10 and y = 30, z = 30).  The outer edges are
    sharp, so the convex hull is the clean 10-vertex, 7-face hull of the
    L-profile; the holes, the fillet and the gusset do not change it.  The
    part is uniform density; its centre of mass is trimesh's ``center_mass``
    (printed, in mm).  Convert to metres (x 1e-3) before handing the hull to
    :func:`kernels.make_polyhedron` or :func:`planning.plan_tumble`.

``plate.dxf``
    A DXF R2010 drawing of a flat steel plate, in MILLIMETRES
    (``$INSUNITS = 4``): the outline is one closed, convex LWPOLYLINE on
    layer ``OUTLINE`` (90 x 55 mm, corners rounded with radius 5 mm via bulge
    values, the top-right corner chamfered 12 x 12 mm instead), and three
    holes are CIRCLE entities on layer ``HOLES`` (diameters 10, 8 and 8 mm),
    placed off-centre so that the plate's centre of mass lies more than a
    millimetre away from its outline's centroid.

The script prints the figures of both parts (volume, centre of mass,
bounding box, triangle and hull-vertex counts; areas and centre of mass of
the plate) and asserts that the bracket is a watertight, valid volume and
that both outputs are deterministic (byte-identical on every run).

Requirements: trimesh, numpy and ezdxf, and ``manifold3d``
(``pip install manifold3d``) for trimesh's boolean operations.  The
generated files are committed to the repository, so users of nudge do not
need manifold3d (nor this script) unless they want to regenerate them.
"""

from __future__ import annotations

import hashlib
import io
import math
import os
from collections import OrderedDict

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
STL_PATH = os.path.join(HERE, "bracket.stl")
DXF_PATH = os.path.join(HERE, "plate.dxf")

# ----------------------------------------------------------------- bracket
BASE = (60.0, 40.0, 5.0)  # x, y, z extents of the base flange (mm)
UPRIGHT = (5.0, 40.0, 45.0)  # x, y, z extents of the upright flange (mm)
GUSSET_T = 4.0  # gusset thickness (along y), centred at y = 20
GUSSET_LEG = 25.0  # gusset legs along x and z, from the inner corner
FILLET_R = 3.0  # inner fillet radius along the inner corner (x = 5, z = 5)
HOLE_D = 6.5  # through-hole diameter
BASE_HOLES = ((40.0, 10.0), (40.0, 30.0))  # (x, y) of the base-flange holes
UPRIGHT_HOLES = ((10.0, 30.0), (30.0, 30.0))  # (y, z) of the upright holes
SECTIONS = 32  # cylinder segments
STL_HEADER = b"nudge example: aluminium angle bracket; units: mm"


def _box(x0, x1, y0, y1, z0, z1):
    import trimesh

    return trimesh.creation.box(bounds=[[x0, y0, z0], [x1, y1, z1]])


def _cylinder(radius, p0, p1, sections=SECTIONS):
    """A cylinder of ``radius`` with axis from ``p0`` to ``p1``."""
    import trimesh

    return trimesh.creation.cylinder(
        radius=radius, segment=[p0, p1], sections=sections)


def build_bracket():
    """The bracket as a trimesh.Trimesh (mm)."""
    import trimesh

    bx, by, bz = BASE
    ux, uy, uz = UPRIGHT
    base = _box(0.0, bx, 0.0, by, 0.0, bz)
    upright = _box(0.0, ux, 0.0, uy, 0.0, uz)

    # gusset: right-triangle prism in the inner corner, legs GUSSET_LEG from
    # (x, z) = (ux, bz); it overlaps the flanges by 1 mm so the union is clean.
    yc = by / 2.0
    tri = np.array([[ux - 1.0, bz - 1.0],
                    [ux + GUSSET_LEG, bz - 1.0],
                    [ux + GUSSET_LEG, bz],
                    [ux, bz + GUSSET_LEG],
                    [ux - 1.0, bz + GUSSET_LEG]])
    # the profile is convex: the prism is the convex hull of its two ends
    y0 = yc - GUSSET_T / 2.0
    corners = [[x, y, z] for y in (y0, y0 + GUSSET_T) for x, z in tri]
    gusset = trimesh.convex.convex_hull(np.array(corners))

    # inner fillet: a square prism in the corner minus a cylinder
    r = FILLET_R
    fillet_block = _box(ux - 0.5, ux + r, -1.0, by + 1.0, bz - 0.5, bz + r)
    fillet_cut = _cylinder(r, [ux + r, -2.0, bz + r], [ux + r, by + 2.0, bz + r],
                           sections=4 * SECTIONS)
    fillet = trimesh.boolean.difference([fillet_block, fillet_cut],
                                        engine="manifold")
    # trim the fillet to the part's width
    fillet = trimesh.boolean.intersection(
        [fillet, _box(0.0, bx, 0.0, by, 0.0, uz)], engine="manifold")

    solid = trimesh.boolean.union([base, upright, gusset, fillet],
                                  engine="manifold")

    rh = HOLE_D / 2.0
    cutters = [_cylinder(rh, [x, y, -1.0], [x, y, bz + 1.0])
               for x, y in BASE_HOLES]
    cutters += [_cylinder(rh, [-1.0, y, z], [ux + 1.0, y, z])
                for y, z in UPRIGHT_HOLES]
    part = trimesh.boolean.difference([solid] + cutters, engine="manifold")
    part.merge_vertices()
    part.remove_unreferenced_vertices()
    part.fix_normals()
    return part


def stl_bytes(mesh) -> bytes:
    data = bytearray(mesh.export(file_type="stl"))
    header = STL_HEADER.ljust(80, b"\0")
    data[:80] = header
    return bytes(data)


def report_bracket(mesh):
    from scipy.spatial import ConvexHull

    assert mesh.is_watertight, "bracket is not watertight"
    assert mesh.is_volume, "bracket is not a valid volume"
    assert mesh.volume > 0, "bracket has non-positive volume"
    hull = ConvexHull(mesh.vertices)
    print("bracket.stl (mm)")
    print(f"  volume          {mesh.volume:.3f} mm^3")
    c = mesh.center_mass
    print(f"  centre of mass  ({c[0]:.4f}, {c[1]:.4f}, {c[2]:.4f}) mm")
    lo, hi = mesh.bounds
    print(f"  bounding box    {lo.round(6).tolist()} .. {hi.round(6).tolist()}")
    print(f"  triangles       {len(mesh.faces)}")
    print(f"  hull vertices   {len(hull.vertices)}")
    # sharp outer edges: the hull is that of the L-profile (10 corners)
    assert len(hull.vertices) == 10, "outer hull is not the clean L-profile"


# ------------------------------------------------------------------- plate
PLATE_W, PLATE_H = 90.0, 55.0  # outline extents (mm), x = 0..90, y = 0..55
CORNER_R = 5.0  # corner rounding radius
CHAMFER = 12.0  # chamfer legs at the top-right corner
# holes: (x, y, diameter) in mm
HOLES = ((13.0, 27.5, 10.0), (11.0, 10.0, 8.0), (26.0, 45.0, 8.0))
FLATTEN_MM = 1e-5  # chord tolerance for flattening the outline
BEZIER_SEGMENTS = 16  # cubic Beziers per arc in make_path (arc error ~1e-10 mm)


def plate_outline_points():
    """LWPOLYLINE vertices (x, y, bulge), counter-clockwise."""
    w, h, r, c = PLATE_W, PLATE_H, CORNER_R, CHAMFER
    b = math.tan(math.pi / 8.0)  # 90-degree arc, counter-clockwise
    return [
        (r, 0.0, 0.0), (w - r, 0.0, b),  # bottom edge, arc to right edge
        (w, r, 0.0), (w, h - c, 0.0),  # right edge, chamfer
        (w - c, h, 0.0), (r, h, b),  # top edge, arc to left edge
        (0.0, h - r, 0.0), (0.0, r, b),  # left edge, arc to bottom edge
    ]


def build_plate():
    import ezdxf
    from ezdxf import units

    ezdxf.options.write_fixed_meta_data_for_testing = True  # deterministic
    doc = ezdxf.new("R2010", setup=False)
    doc.units = units.MM
    doc.header["$MEASUREMENT"] = 1  # metric
    doc.layers.add("OUTLINE", color=7)
    doc.layers.add("HOLES", color=1)
    msp = doc.modelspace()
    msp.add_lwpolyline(plate_outline_points(), format="xyb", close=True,
                       dxfattribs={"layer": "OUTLINE"})
    for x, y, d in HOLES:
        msp.add_circle((x, y), d / 2.0, dxfattribs={"layer": "HOLES"})
    return doc


def dxf_bytes(doc) -> bytes:
    # ezdxf registers the CLASS entries of the entity types in use in set
    # order (which varies with PYTHONHASHSEED); register them now and sort
    # them, so that the file is the same on every run (export adds no more).
    doc.classes.add_required_classes(doc.dxfversion)
    doc.classes.classes = OrderedDict(sorted(doc.classes.classes.items()))
    stream = io.StringIO()
    doc.write(stream)
    return stream.getvalue().encode("utf8")


def _shoelace(pts):
    """Signed area and centroid of a closed polygon (first point not repeated)."""
    x, y = pts[:, 0], pts[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    a = cross.sum() / 2.0
    cx = ((x + xn) * cross).sum() / (6.0 * a)
    cy = ((y + yn) * cross).sum() / (6.0 * a)
    return a, np.array([cx, cy])


def report_plate(doc):
    from ezdxf import path

    msp = doc.modelspace()
    (outline,) = msp.query('LWPOLYLINE[layer=="OUTLINE"]')
    assert outline.closed
    pts = np.array([(p.x, p.y) for p in
                    path.make_path(outline, segments=BEZIER_SEGMENTS)
                    .flattening(FLATTEN_MM)])
    if np.allclose(pts[0], pts[-1]):
        pts = pts[:-1]
    a_out, c_out = _shoelace(pts)
    assert a_out > 0, "outline is not counter-clockwise"
    # convexity: every turn is a left turn (or straight)
    d = np.roll(pts, -1, axis=0) - pts
    turn = d[:, 0] * np.roll(d, -1, axis=0)[:, 1] - d[:, 1] * np.roll(d, -1, axis=0)[:, 0]
    assert turn.min() > -1e-9, "outline is not convex"
    r, c = CORNER_R, CHAMFER
    exact = PLATE_W * PLATE_H - 3 * (r * r - math.pi * r * r / 4) - c * c / 2
    assert abs(a_out - exact) < 1e-3, (a_out, exact)

    holes = list(msp.query('CIRCLE[layer=="HOLES"]'))
    a_holes = sum(math.pi * h.dxf.radius ** 2 for h in holes)
    m_holes = sum(math.pi * h.dxf.radius ** 2 * np.array(h.dxf.center)[:2]
                  for h in holes)
    a_net = a_out - a_holes
    com = (a_out * c_out - m_holes) / a_net
    shift = float(np.linalg.norm(com - c_out))
    print("plate.dxf (mm)")
    print(f"  outline area           {a_out:.4f} mm^2 (analytic {exact:.4f})")
    print(f"  outline centroid       ({c_out[0]:.4f}, {c_out[1]:.4f}) mm")
    print(f"  holes area             {a_holes:.4f} mm^2 ({len(holes)} holes)")
    print(f"  net area               {a_net:.4f} mm^2")
    print(f"  centre of mass         ({com[0]:.4f}, {com[1]:.4f}) mm")
    print(f"  CoM offset from centroid {shift:.4f} mm")
    assert shift >= 1.0, "holes do not move the centre of mass enough"


def _write_checked(path_, make_bytes):
    """Build the bytes twice, check they are identical, write them."""
    first, second = make_bytes(), make_bytes()
    assert first == second, f"{os.path.basename(path_)} is not deterministic"
    with open(path_, "wb") as f:
        f.write(first)
    print(f"  wrote {path_} ({len(first)} bytes, "
          f"sha256 {hashlib.sha256(first).hexdigest()[:16]})")


def main():
    mesh = build_bracket()
    report_bracket(mesh)
    _write_checked(STL_PATH, lambda: stl_bytes(build_bracket()))
    import trimesh

    back = trimesh.load(STL_PATH)  # the file as users read it (float32)
    assert back.is_watertight and back.is_volume, "bracket.stl does not reload"
    assert len(back.faces) == len(mesh.faces)
    doc = build_plate()
    report_plate(doc)
    _write_checked(DXF_PATH, lambda: dxf_bytes(build_plate()))


if __name__ == "__main__":
    main()
