"""Parts from CAD files (sweeps.cad, sweeps.partfile, sweeps.units): meshes, DXF
outlines and footprints, in millimetres, through the commands a user types.

Every CAD file here is written by the test itself (trimesh, ezdxf)."""
import json
import math
import re
import warnings

import ezdxf
import numpy as np
import pandas as pd
import pytest
import trimesh
from hypothesis import HealthCheck, given, settings, strategies as st

from sweeps import cad
from sweeps.partfile import PartFileError, load_part
from sweeps.units import LengthError, lengths_to_metres, parse_length
from tests.commandline import ROOT, nudge, nudge_here

pytestmark = pytest.mark.filterwarnings("ignore::UserWarning")

EXAMPLES = ROOT / "examples"
BULGE90 = math.tan(math.pi / 8)   # a 90-degree arc as an LWPOLYLINE bulge


# --------------------------------------------------------------------------
# files the tests write
# --------------------------------------------------------------------------
def rounded_plate_dxf(path, scale=1.0, units=ezdxf.units.MM, r=4.0, hole=(45.0, 15.0, 4.0),
                      chained=False, extra=()):
    """A 60 x 30 rectangle (file units x ``scale``) with corners rounded at ``r``
    and one round hole; as one closed LWPOLYLINE, or (``chained``) as LINEs and
    ARCs joined end to end."""
    doc = ezdxf.new("R2010")
    doc.units = units
    msp = doc.modelspace()
    s = scale
    w, h = 60.0, 30.0
    if not chained:
        pts = [(r, 0, 0), (w - r, 0, BULGE90), (w, r, 0), (w, h - r, BULGE90), (w - r, h, 0),
               (r, h, BULGE90), (0, h - r, 0), (0, r, BULGE90)]
        msp.add_lwpolyline([(x * s, y * s, 0, 0, b) for x, y, b in pts], format="xyseb",
                           close=True, dxfattribs={"layer": "OUTLINE"})
    else:
        a = {"layer": "OUTLINE"}
        msp.add_line((r * s, 0), ((w - r) * s, 0), dxfattribs=a)
        msp.add_arc(((w - r) * s, r * s), r * s, 270, 360, dxfattribs=a)
        msp.add_line((w * s, r * s), (w * s, (h - r) * s), dxfattribs=a)
        msp.add_arc(((w - r) * s, (h - r) * s), r * s, 0, 90, dxfattribs=a)
        msp.add_line(((w - r) * s, h * s), (r * s, h * s), dxfattribs=a)
        msp.add_arc((r * s, (h - r) * s), r * s, 90, 180, dxfattribs=a)
        msp.add_line((0, (h - r) * s), (0, r * s), dxfattribs=a)
        msp.add_arc((r * s, r * s), r * s, 180, 270, dxfattribs=a)
    if hole is not None:
        msp.add_circle((hole[0] * s, hole[1] * s), hole[2] * s, dxfattribs={"layer": "HOLES"})
    for add in extra:
        add(msp)
    doc.saveas(path)
    return path


def plate_exact(r=4.0, hole=(45.0, 15.0, 4.0)):
    """Area (mm^2) and centre of mass (mm) of :func:`rounded_plate_dxf`'s plate, exactly."""
    w, h = 60.0, 30.0
    corner = r * r - math.pi * r * r / 4        # what a rounded corner removes from the box
    # the removed corner's centroid: square r x r minus a quarter disc, about the outer corner
    d_sq, d_q = r / 2, r - 4 * r / (3 * math.pi)
    d = (r * r * d_sq - math.pi * r * r / 4 * d_q) / corner
    parts = [(w * h, np.array([w / 2, h / 2]))]
    for cx, cy, sx, sy in ((0, 0, 1, 1), (w, 0, -1, 1), (w, h, -1, -1), (0, h, 1, -1)):
        parts.append((-corner, np.array([cx + sx * d, cy + sy * d])))
    if hole is not None:
        parts.append((-math.pi * hole[2] ** 2, np.array(hole[:2])))
    area = sum(a for a, _ in parts)
    com = sum(a * c for a, c in parts) / area
    return area, com


def box_stl(path, size=(60.0, 40.0, 10.0), origin=(0.0, 0.0, 0.0)):
    m = trimesh.creation.box(size)
    m.apply_translation(np.asarray(size) / 2 + np.asarray(origin))
    m.export(path)
    return m


def wedge_stl(path, scale=1.0):
    """A non-symmetric solid (a wedge with a bevelled end): its centre of mass is not
    its vertices' mean; coordinates in file units x ``scale``."""
    v = np.array([[0, 0, 0], [70, 0, 0], [70, 30, 0], [0, 30, 0],
                  [0, 0, 25], [35, 0, 25], [35, 30, 25], [0, 30, 25]], float) * scale
    m = trimesh.convex.convex_hull(v)
    m.export(path)
    return m, v


def run(*args, cwd=None, monkeypatch=None):
    """``nudge ARGS`` in this process (:func:`tests.commandline.nudge_here`, the console
    script's own dispatcher, ``sweeps.cli.main``): the commands' compiled kernels are
    shared by the tests of this file.  ``cwd``: the working folder for the rest of the
    test (``monkeypatch``)."""
    if cwd is not None:
        monkeypatch.chdir(cwd)
    return nudge_here(*args)


def write(path, text):
    path.write_text(text)
    return path


def _error_line(proc):
    lines = [ln for ln in proc.stderr.splitlines() if ln.startswith("error:")]
    assert proc.returncode == 2, (proc.returncode, proc.stdout, proc.stderr)
    assert len(lines) == 1, proc.stderr
    assert "Traceback" not in proc.stderr
    return lines[0]


# --------------------------------------------------------------------------
# units
# --------------------------------------------------------------------------
@pytest.mark.parametrize("text, metres", [("0.05 mm", 5e-5), ("50um", 5e-5), ("0.002 in", 5.08e-5),
                                          ("1.5cm", 0.015), ("2e-3 m", 0.002), (0.25, 0.25),
                                          ("-3 mm", -0.003)])
def test_parse_length(text, metres):
    assert parse_length(text, "f") == pytest.approx(metres, rel=1e-12)


@pytest.mark.parametrize("bad", ["0.05 mmm", "mm", "5 feet", True, [1], float("nan")])
def test_parse_length_refuses_with_the_field(bad):
    with pytest.raises(LengthError, match=r"^tolerances\.tau_v: "):
        parse_length(bad, "tolerances.tau_v")


def test_config_lengths_convert_once_and_only_in_length_fields():
    doc = {"tolerances": {"tau_v": "0.05 mm", "distribution": "uniform"},
           "friction": {"c": ["4 mm", "8 mm"], "mu_f": [0.3, 0.8]},
           "execution": {"start_xy": "0.5 mm", "start_theta": 0.01}, "n_samples": 10}
    out = lengths_to_metres(doc)
    assert out["tolerances"] == {"tau_v": pytest.approx(5e-5), "distribution": "uniform"}
    assert out["friction"]["c"] == [pytest.approx(0.004), pytest.approx(0.008)]
    assert out["execution"]["start_xy"] == pytest.approx(5e-4)
    assert doc["tolerances"]["tau_v"] == "0.05 mm"   # the document as written is kept
    with pytest.raises(LengthError, match=r"^eps\.pos_eps_m: "):
        lengths_to_metres({"eps": {"pos_eps_m": "3 parsecs"}})


# --------------------------------------------------------------------------
# DXF outlines
# --------------------------------------------------------------------------
def test_outline_area_and_centre_of_mass_with_a_hole(tmp_path):
    f = rounded_plate_dxf(tmp_path / "plate.dxf")
    geo = cad.read_outline(f)
    area, com = plate_exact()
    assert geo.units == "mm" and "header" in geo.units_from
    # a fine flattening (0.05 mm chords) under-fills each arc by less than 0.05 mm of its width
    assert geo.volume == pytest.approx(area * 1e-6, rel=2e-4)
    np.testing.assert_allclose(geo.com, com * 1e-3, atol=2e-6)
    assert len(geo.loops) == 2 and "1 hole" in geo.description
    # every hull vertex lies on the real outline (within the chord tolerance, inside it)
    assert np.all(geo.vertices >= -1e-9) and np.all(geo.vertices <= [0.06 + 1e-9, 0.03 + 1e-9])


def test_chained_lines_and_arcs_are_the_same_outline(tmp_path):
    a = cad.read_outline(rounded_plate_dxf(tmp_path / "poly.dxf"), chord_tolerance="1 mm")
    b = cad.read_outline(rounded_plate_dxf(tmp_path / "chain.dxf", chained=True),
                         chord_tolerance="1 mm")
    assert a.volume == pytest.approx(b.volume, rel=1e-6)
    np.testing.assert_allclose(a.com, b.com, atol=1e-8)
    sa = {tuple(np.round(v, 9)) for v in a.vertices}
    sb = {tuple(np.round(v, 9)) for v in b.vertices}
    assert sa == sb, "the hull vertices of the two drawings differ"


def test_chord_tolerance_sets_the_corner_count(tmp_path):
    f = rounded_plate_dxf(tmp_path / "plate.dxf", r=5.0)
    fine = cad.read_outline(f)                       # 0.05 mm: many corners, a warning
    coarse = cad.read_outline(f, chord_tolerance=1.0)  # file units (mm): two chords per arc
    assert len(coarse.vertices) == 12
    assert len(fine.vertices) > 24
    assert any("corners turn less than" in w for w in fine.warnings)
    assert not any("corners turn less than" in w for w in coarse.warnings)
    # the mass properties do not depend on the hull's chords
    assert fine.volume == pytest.approx(coarse.volume, rel=1e-12)


@settings(max_examples=20, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 10_000), unit=st.sampled_from([("mm", ezdxf.units.MM, 1e-3),
                                                           ("in", ezdxf.units.IN, 0.0254),
                                                           ("m", ezdxf.units.M, 1.0)]))
def test_random_outlines_as_shuffled_lines_read_back(tmp_path, seed, unit):
    """A random convex polygon drawn as LINEs in random order and directions, in a random
    unit, reads back as the metre polygon: the same hull and centroid (shoelace, numpy)."""
    name, code, k = unit
    rng = np.random.default_rng(seed)
    from scipy.spatial import ConvexHull

    pts = rng.normal(size=(9, 2)) * [0.04, 0.02]
    ring = pts[ConvexHull(pts).vertices]            # CCW hull, metres
    doc = ezdxf.new("R2010")
    doc.units = code
    msp = doc.modelspace()
    segs = [(ring[i], ring[(i + 1) % len(ring)]) for i in range(len(ring))]
    for j in rng.permutation(len(segs)):
        a, b = segs[j]
        if rng.random() < 0.5:
            a, b = b, a
        msp.add_line(tuple(a / k), tuple(b / k))
    doc.saveas(tmp_path / f"r{seed}.dxf")
    geo = cad.read_outline(tmp_path / f"r{seed}.dxf")
    assert geo.units == name
    # a straight-sided drawing: no convexity or chord warning (a corner that turns little is one)
    assert all("corners of the drawing" in w and "chord" not in w for w in geo.warnings)
    np.testing.assert_allclose(np.sort(geo.vertices, axis=0), np.sort(ring, axis=0), atol=1e-12)
    x, y = ring[:, 0], ring[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    area = cross.sum() / 2
    com = np.array([((x + xn) * cross).sum(), ((y + yn) * cross).sum()]) / (6 * area)
    assert geo.volume == pytest.approx(area, rel=1e-12)
    np.testing.assert_allclose(geo.com, com, atol=1e-12)


def test_non_convex_outline_warns_with_the_area_its_hull_adds(tmp_path):
    doc = ezdxf.new("R2010")
    doc.units = ezdxf.units.MM
    doc.modelspace().add_lwpolyline([(0, 0), (80, 0), (80, 50), (40, 50), (40, 30), (0, 30)],
                                    close=True)
    doc.saveas(tmp_path / "ell.dxf")
    geo = cad.read_outline(tmp_path / "ell.dxf")
    (w,) = [w for w in geo.warnings if "not convex" in w]
    assert "adds 400 mm^2 (12.5% of its area)" in w
    assert len(geo.vertices) == 5


def test_a_drawing_border_needs_the_layer(tmp_path):
    border = lambda msp: msp.add_lwpolyline([(-50, -50), (150, -50), (150, 100), (-50, 100)],  # noqa: E731
                                            close=True, dxfattribs={"layer": "BORDER"})
    f = rounded_plate_dxf(tmp_path / "drawing.dxf", extra=[border])
    with pytest.raises(ValueError, match="nested loops.*layer:"):
        cad.read_outline(f)
    geo = cad.read_outline(f, layer="OUTLINE")          # the hole is on another layer: kept
    assert "1 hole" in geo.description
    assert geo.volume == pytest.approx(plate_exact()[0] * 1e-6, rel=2e-4)


def test_empty_and_foreign_unit_drawings_say_one_line(tmp_path):
    doc = ezdxf.new("R2010")
    doc.modelspace().add_text("no geometry here")
    doc.saveas(tmp_path / "empty.dxf")
    with pytest.raises(ValueError, match="empty.dxf has no lines or curves in its model space"):
        cad.read_outline(tmp_path / "empty.dxf")
    feet = rounded_plate_dxf(tmp_path / "feet.dxf", units=ezdxf.units.FT)
    with pytest.raises(ValueError, match=r"drawn in Feet \(\$INSUNITS 2\).*give units:"):
        cad.read_outline(feet)
    assert cad.read_outline(feet, units="in").units == "in"   # the part file's unit is used


def test_units_of_the_part_file_win_over_the_header_with_a_warning(tmp_path):
    f = rounded_plate_dxf(tmp_path / "plate.dxf", scale=1 / 25.4, units=ezdxf.units.IN)
    inches = cad.read_outline(f)
    mm = cad.read_outline(rounded_plate_dxf(tmp_path / "mm.dxf"))
    np.testing.assert_allclose(inches.com, mm.com, atol=1e-7)
    forced = cad.read_outline(f, units="mm")
    assert forced.units == "mm" and any("says its unit is in" in w for w in forced.warnings)


# --------------------------------------------------------------------------
# meshes and footprints
# --------------------------------------------------------------------------
def test_mesh_hull_and_its_own_centre_of_mass(tmp_path):
    m, v = wedge_stl(tmp_path / "wedge.stl")
    geo = cad.read_mesh(tmp_path / "wedge.stl", "mm")
    np.testing.assert_allclose(geo.com, m.center_mass * 1e-3, atol=1e-12)
    assert geo.volume == pytest.approx(m.volume * 1e-9, rel=1e-12)
    assert {tuple(np.round(x, 12)) for x in geo.vertices} == {tuple(np.round(x, 12)) for x in v * 1e-3}
    assert not np.allclose(geo.com, v.mean(axis=0) * 1e-3)   # a solid's, not the corners' mean


def test_an_open_mesh_is_planned_on_its_hull_with_a_warning(tmp_path):
    m = trimesh.creation.box((0.06, 0.04, 0.01))
    m.update_faces(np.arange(len(m.faces) - 2))
    m.export(tmp_path / "open.stl")
    geo = cad.read_mesh(tmp_path / "open.stl")
    assert geo.com is None and geo.volume is None
    (w,) = geo.warnings
    assert "not a closed, manifold mesh (4 open edges)" in w and "hull" in w
    part = load_part(tmp_path / "open.stl")
    assert part.com is None and part.kind == "polyhedron"


def test_a_mesh_of_several_bodies_warns(tmp_path):
    a, b = trimesh.creation.box((10, 10, 10)), trimesh.creation.box((10, 10, 10))
    b.apply_translation((30, 0, 0))
    trimesh.util.concatenate([a, b]).export(tmp_path / "two.stl")
    geo = cad.read_mesh(tmp_path / "two.stl", "mm")
    assert any("holds 2 separate bodies" in w for w in geo.warnings)
    np.testing.assert_allclose(geo.com, [0.015, 0, 0], atol=1e-12)


def test_tessellation_noise_on_a_face_is_a_sliver_warning(tmp_path):
    """A box whose top face is split by a 0.01 mm bump: two hull faces 0.014 deg from flat."""
    v = np.array([[0, 0, 0], [60, 0, 0], [60, 40, 0], [0, 40, 0],
                  [0, 0, 20], [60, 0, 20], [60, 40, 20], [0, 40, 20.01]], float)
    trimesh.convex.convex_hull(v).export(tmp_path / "noisy.stl")
    (w,) = cad.read_mesh(tmp_path / "noisy.stl", "mm").warnings
    assert "1 hull edge joins faces within 0.017 deg of flat" in w and "--tau-v" in w
    box_stl(tmp_path / "box.stl")
    assert cad.read_mesh(tmp_path / "box.stl", "mm").warnings == ()


def test_footprint_on_a_face(tmp_path):
    box_stl(tmp_path / "box.stl")
    down = cad.read_footprint(tmp_path / "box.stl", "-z", "mm")
    assert down.height == pytest.approx(0.01)
    np.testing.assert_allclose(sorted(map(tuple, down.vertices)),
                               [(0, 0), (0, 0.04), (0.06, 0), (0.06, 0.04)], atol=1e-12)
    side = cad.read_footprint(tmp_path / "box.stl", "+x", "mm")
    assert side.height == pytest.approx(0.06)
    assert np.ptp(side.vertices, axis=0) == pytest.approx([0.04, 0.01])
    with pytest.raises(ValueError, match="face: expected one of"):
        cad.read_footprint(tmp_path / "box.stl", "sideways", "mm")


def test_footprint_refuses_a_face_the_part_does_not_rest_on(tmp_path):
    # a slanted slab whose centre of mass overhangs its small bottom face
    v = np.array([[0, 0, 0], [10, 0, 0], [10, 20, 0], [0, 20, 0],
                  [60, 0, 10], [70, 0, 10], [70, 20, 10], [60, 20, 10]], float)
    trimesh.convex.convex_hull(v).export(tmp_path / "lean.stl")
    with pytest.raises(ValueError, match="does not rest on that face"):
        cad.read_footprint(tmp_path / "lean.stl", "-z", "mm")


@settings(max_examples=15, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 10_000), unit=st.sampled_from(["mm", "in", "cm"]),
       fmt=st.sampled_from(["stl", "obj", "ply"]))
def test_random_hulls_read_back_in_metres(tmp_path, seed, unit, fmt):
    """Random convex solids written in another unit and format read back as the metre
    solid (STL stores float32: agreement to its precision)."""
    rng = np.random.default_rng(seed)
    pts_m = rng.normal(size=(12, 3)) * [0.03, 0.02, 0.01]
    solid = trimesh.convex.convex_hull(pts_m)
    k = {"mm": 1e-3, "in": 0.0254, "cm": 1e-2}[unit]
    scaled = solid.copy()
    scaled.apply_scale(1 / k)
    f = tmp_path / f"r{seed}.{fmt}"
    scaled.export(f)
    geo = cad.read_mesh(f, unit)
    size = float(np.ptp(pts_m, axis=0).max())
    np.testing.assert_allclose(geo.com, solid.center_mass, atol=1e-6 * size)
    assert geo.volume == pytest.approx(solid.volume, rel=1e-5)
    np.testing.assert_allclose(np.sort(geo.vertices, axis=0),
                               np.sort(solid.vertices[np.unique(solid.faces)], axis=0),
                               atol=1e-6 * size)


# --------------------------------------------------------------------------
# part files
# --------------------------------------------------------------------------
def test_part_file_keys_units_and_material(tmp_path):
    rounded_plate_dxf(tmp_path / "plate.dxf")
    write(tmp_path / "plate.yaml", "outline: plate.dxf\nthickness: 4\ndensity: 7850\n")
    part = load_part(tmp_path / "plate.yaml")
    area, _ = plate_exact()
    assert part.kind == "polygon" and part.units == "mm" and part.thickness == pytest.approx(0.004)
    # the modelled prism (the hull) gets the density that gives the real plate's mass
    assert part.mass == pytest.approx(7850 * area * 1e-6 * 0.004, rel=3e-4)
    assert part.source.name == "plate.dxf" and "mm" in part.source_label
    # a footprint's default thickness is the mesh's height; com given in the part's unit
    box_stl(tmp_path / "box.stl")
    write(tmp_path / "fp.yaml", "footprint: box.stl\nunits: mm\ncom: [30, 21]\n")
    fp = load_part(tmp_path / "fp.yaml")
    assert fp.thickness == pytest.approx(0.01)
    np.testing.assert_allclose(fp.com, [0.03, 0.021])
    # a YAML vertex list in mm is the metre part
    write(tmp_path / "tri.yaml", "vertices: [[0, 0], [100, 0], [0, 60]]\nunits: mm\nthickness: 5 mm\n")
    tri = load_part(tmp_path / "tri.yaml")
    np.testing.assert_allclose(tri.vertices, [[0, 0], [0.1, 0], [0, 0.06]])
    assert tri.thickness == pytest.approx(0.005)


@pytest.mark.parametrize("text, match", [
    ("mesh: box.stl\nvertices: [[0, 0], [1, 0], [0, 1]]\n", "mesh: give the part's geometry once.*got vertices and mesh"),
    ("mesh: box.stl\nunits: mm\nface: -z\n", "face: only with footprint"),
    ("mesh: box.stl\nunits: furlongs\n", "units: expected one of m | cm | mm | um | in"),
    ("mesh: box.stl\nunits: mm\nkind: polygon\n", "kind: mesh: gives a polyhedron.*footprint"),
    ("mesh: missing.stl\nunits: mm\n", "mesh: no such file"),
    ("mesh: box.stl\n", "units: box.stl carries no unit and is 72.8 across.*units: mm"),
    ("outline: box.stl\n", "outline: box.stl cannot be read as a DXF drawing"),
    ("footprint: box.stl\nunits: mm\nface: 99\n", "face: expected one of -x.*or a face number 0..5"),
    ("description: no geometry\n", "vertices: required key is missing.*mesh:, outline: or footprint:"),
])
def test_bad_cad_part_files_say_one_line(tmp_path, text, match):
    box_stl(tmp_path / "box.stl", size=(60, 40, 10))
    f = write(tmp_path / "p.yaml", text)
    with pytest.raises(PartFileError, match=match) as info:
        load_part(f)
    assert "\n" not in str(info.value) and str(info.value).startswith(str(f))


# --------------------------------------------------------------------------
# through the commands
# --------------------------------------------------------------------------
def _plan(proc):
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def test_plan_push_on_a_dxf_equals_its_metre_twin(tmp_path, monkeypatch):
    """A mm DXF, given directly, plans as the YAML vertex list (metres) of its hull."""
    rounded_plate_dxf(tmp_path / "plate.dxf", hole=None)
    write(tmp_path / "coarse.yaml", "outline: plate.dxf\nchord_tolerance: 1\n")
    part = load_part(tmp_path / "coarse.yaml")
    write(tmp_path / "twin.yaml", json.dumps({"vertices": part.vertices.tolist(),
                                              "com": part.com.tolist()}))
    pose = ["--start", "0,0,0", "--goal", "0.1,0.05,90deg", "--json"]
    cad_plan = _plan(run("plan-push", tmp_path / "coarse.yaml", *pose, cwd=tmp_path, monkeypatch=monkeypatch))
    twin_plan = _plan(run("plan-push", tmp_path / "twin.yaml", *pose, cwd=tmp_path, monkeypatch=monkeypatch))
    assert cad_plan["pushes"] == twin_plan["pushes"]
    assert cad_plan["total_distance"] == pytest.approx(twin_plan["total_distance"], rel=1e-12)


def test_plan_tumble_mesh_mm_and_metre_twin_and_vertex_list(tmp_path, monkeypatch):
    """A mesh in mm given directly (OBJ), the same mesh in metres (PLY), and its hull as a
    YAML vertex list (with the mesh's centre of mass) give the same tumble plan."""
    m, _ = wedge_stl(tmp_path / "wedge_mm.obj")
    m_m = m.copy()
    m_m.apply_scale(1e-3)
    m_m.export(tmp_path / "wedge_m.ply")
    geo = cad.read_mesh(tmp_path / "wedge_mm.obj", "mm")
    write(tmp_path / "wedge.yaml", json.dumps({"vertices": geo.vertices.tolist(),
                                               "com": geo.com.tolist()}))
    args = ["--goal", "0.1,0,0,2", "--eps", "0.002", "--json"]
    a = _plan(run("plan-tumble", tmp_path / "wedge_mm.obj", "--units", "mm", *args, cwd=tmp_path, monkeypatch=monkeypatch))
    b = _plan(run("plan-tumble", tmp_path / "wedge_m.ply", *args, cwd=tmp_path, monkeypatch=monkeypatch))
    c = _plan(run("plan-tumble", tmp_path / "wedge.yaml", *args, cwd=tmp_path, monkeypatch=monkeypatch))
    assert a["verdict"] == "solved"
    assert a["tumbles"] == b["tumbles"] == c["tumbles"]
    np.testing.assert_allclose(a["predicted_final"][:3], c["predicted_final"][:3], atol=1e-12)


def test_plan_push_on_a_mesh_is_its_footprint(tmp_path, monkeypatch):
    box_stl(tmp_path / "box.stl", size=(60, 40, 10))
    write(tmp_path / "twin.yaml", "vertices: [[0, 0], [0.06, 0], [0.06, 0.04], [0, 0.04]]\n")
    pose = ["--start", "0,0,0", "--goal", "0.1,0.05,90deg", "--json"]
    proc = run("plan-push", tmp_path / "box.stl", "--units", "mm", *pose, cwd=tmp_path, monkeypatch=monkeypatch)
    assert "part: box: " in proc.stderr and "(mm, --units)" in proc.stderr
    a = _plan(proc)["pushes"]
    b = _plan(run("plan-push", tmp_path / "twin.yaml", *pose, cwd=tmp_path, monkeypatch=monkeypatch))["pushes"]
    assert [(p["kind"], p["edge"], p["contact_vertex"]) for p in a] == \
        [(p["kind"], p["edge"], p["contact_vertex"]) for p in b]
    np.testing.assert_allclose([p["distance"] for p in a], [p["distance"] for p in b], atol=1e-12)


@pytest.mark.parametrize("make, args, match", [
    ("box", ["plan-tumble", "box.stl", "--goal", "0.1,0,0,1", "--eps", "0.002"],
     "--units: box.stl carries no unit and is 72.8 across.*--units: mm"),
    ("garbage", ["plan-tumble", "junk.stl", "--goal", "0.1,0,0,1", "--eps", "0.002"],
     "junk.stl holds no triangles"),
    ("open", ["plan-push", "open.dxf", "--start", "0,0,0", "--goal", "0.1,0,0"],
     r"open.dxf has no closed loop: LINE #\w+ \(layer 0\), LINE #\w+ \(layer 0\)"),
    ("two", ["plan-push", "two.dxf", "--start", "0,0,0", "--goal", "0.1,0,0"],
     r"2 closed outlines side by side: LWPOLYLINE #\w+ \(layer A\).*LWPOLYLINE #\w+ \(layer B\)"),
    ("dxf", ["plan-tumble", "plate.dxf", "--goal", "0.1,0,0,1", "--eps", "0.002"],
     "this planner takes polyhedron parts, this file holds a polygon"),
    ("box", ["plan-push", "box.stl", "--units", "mm", "--face", "+q", "--start", "0,0,0",
             "--goal", "0.1,0,0"], "face: expected one of"),
])
def test_bad_cad_files_exit_2_in_one_line_before_work(tmp_path, make, args, match):
    if make == "box":
        box_stl(tmp_path / "box.stl")
    elif make == "garbage":
        (tmp_path / "junk.stl").write_text("solid junk\n  not a facet\nendsolid\n")
    elif make == "open":
        doc = ezdxf.new("R2010")
        msp = doc.modelspace()
        msp.add_line((0, 0), (0.08, 0))
        msp.add_line((0.08, 0), (0.08, 0.02))
        msp.add_line((0.08, 0.025), (0, 0.02))
        doc.saveas(tmp_path / "open.dxf")
    elif make == "two":
        doc = ezdxf.new("R2010")
        msp = doc.modelspace()
        msp.add_lwpolyline([(0, 0), (0.01, 0), (0.01, 0.01)], close=True, dxfattribs={"layer": "A"})
        msp.add_lwpolyline([(0.02, 0), (0.03, 0), (0.03, 0.01)], close=True, dxfattribs={"layer": "B"})
        doc.saveas(tmp_path / "two.dxf")
    elif make == "dxf":
        rounded_plate_dxf(tmp_path / "plate.dxf")
    proc = nudge(*args, cwd=tmp_path)
    assert re.search(match, _error_line(proc)), proc.stderr
    assert proc.stdout == ""


def test_nudge_parts_lists_the_bundled_cad_parts():
    proc = nudge("parts")
    assert proc.returncode == 0, proc.stderr
    lines = {ln.split()[0]: ln for ln in proc.stdout.splitlines() if ln.startswith("  ")}
    assert "(hull of bracket.stl, mm)" in lines["bracket"]
    assert "(hull of plate.dxf, mm)" in lines["plate"]
    assert "examples/certify_bracket.yaml" in proc.stdout
    assert "examples/certify_plate.yaml" in proc.stdout


def test_bundled_bracket_is_a_closed_mesh_planned_from_its_hull():
    part = load_part(EXAMPLES / "bracket.yaml")
    mesh = trimesh.load(EXAMPLES / "bracket.stl", force="mesh")
    assert mesh.is_watertight and mesh.is_volume and part.warnings == ()
    np.testing.assert_allclose(part.com, mesh.center_mass * 1e-3, atol=1e-12)
    assert part.mass == pytest.approx(2700 * mesh.volume * 1e-9, rel=1e-9)
    with warnings.catch_warnings():
        warnings.simplefilter("error")          # no sliver or coplanar faces on its hull
        from kernels import make_polyhedron

        assert len(make_polyhedron(part.vertices, part.com).faces) == 7
    plate = load_part(EXAMPLES / "plate.yaml")
    assert plate.warnings == () and "3 holes" in plate.cad.description


@pytest.mark.slow
def test_bundled_certify_configs_run_and_name_their_source(tmp_path, monkeypatch):
    for name, source in (("certify_bracket", "bracket.stl"), ("certify_plate", "plate.dxf")):
        out = tmp_path / name
        proc = run("certify", EXAMPLES / f"{name}.yaml", "--n-samples", "40", "--out", out,
                     "--quiet")
        assert proc.returncode in (0, 1), proc.stderr
        assert f"{source} (mm, " in proc.stderr
        certs = pd.read_parquet(out / "certificates")
        assert set(certs.part_source) == {source} and set(certs.part_units) == {"mm"}
        plans = pd.read_parquet(out / "plans")
        assert set(plans.part_source) == {source} and plans.planned.all()


@pytest.mark.slow
def test_sweep_with_an_inline_cad_part_and_lengths_in_mm(tmp_path, monkeypatch):
    rounded_plate_dxf(tmp_path / "plate.dxf")
    study = write(tmp_path / "cad.yaml", """study: cad
kind: push
part: {outline: plate.dxf, chord_tolerance: 1.0, thickness: 4}
tasks:
  - {name: a, start: [0, 0, 0], goal: [80 mm, 30 mm, 1.0]}
tolerances: {tau_v: 0.02 mm, tau_com: 0.1 mm}
execution: {start_xy: 0.5 mm, start_theta: 0.01}
eps: {pos_eps_m: 3 mm, theta_eps_rad: 0.05}
model: exact
samples: 16
chunk_samples: 8
seed: 3
params:
  tolerances.tau_v: [0.01 mm, 0.05 mm]
""")
    out = tmp_path / "out"
    proc = run("sweep", study, "--out", out, "--quiet", cwd=tmp_path, monkeypatch=monkeypatch)
    assert proc.returncode == 0, proc.stderr
    assert "part: plate: " in proc.stderr and "(mm, the file (DXF header))" in proc.stderr
    plans = pd.read_parquet(out / "plans")
    assert set(plans.part) == {"plate"} and set(plans.part_source) == {"plate.dxf"}
    assert set(plans.part_units) == {"mm"}
    summary = pd.read_parquet(out / "summary").sort_values("config_id")
    assert summary.tolerances_tau_v.tolist() == pytest.approx([1e-5, 5e-5])   # metres, numbers
    manifest = json.loads((out / "manifest.json").read_text())
    assert "0.02 mm" in json.dumps(manifest)   # the config as written is kept
    html = (out / "report.html").read_text()
    assert "from <code>plate.dxf (mm, the file (DXF header))</code>" in html


def test_plot_draws_the_real_outline(tmp_path, monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from planning import plan_pose
    from sweeps.figures import push as push_plots

    rounded_plate_dxf(tmp_path / "plate.dxf")
    write(tmp_path / "plate.yaml", "outline: plate.dxf\nchord_tolerance: 1\n")
    part = load_part(tmp_path / "plate.yaml")
    plan = plan_pose(part.vertices, (0, 0, 0), (0.08, 0.0, 0.0), com=part.com)
    figs = []
    monkeypatch.setattr(plt, "close", lambda fig=None: figs.append(fig))
    push_plots.plot_plan(plan, tmp_path / "p.png", outline=part.loops)
    (ax,) = figs[0].axes
    black = [p for p in ax.patches if not p.get_fill() and p.get_edgecolor()[:3] == (0, 0, 0)]
    # the outline and the hole at the start and at the goal
    assert len(black) == 4
    sizes = sorted(len(p.get_xy()) for p in black)
    assert sizes[-1] >= len(part.loops[0])
    assert (tmp_path / "p.png").stat().st_size > 0


@pytest.mark.parametrize("kind, want", [("push", "polygon"), ("tumble", "polyhedron")])
def test_a_study_names_a_mesh_directly_read_as_its_kind(tmp_path, kind, want, monkeypatch):
    """``part: box.stl`` in a push study is the mesh's footprint, in a tumble study its hull."""
    box_stl(tmp_path / "box.stl")
    goal = "[0.1, 0, 0]" if kind == "push" else "[0.05, 0, 0, 3]"   # one tumble onto face 3
    study = write(tmp_path / "s.yaml", f"""study: direct
kind: {kind}
part: box.stl
tasks:
  - {{name: a, start: {"[0, 0, 0]" if kind == "push" else "[0, 0, 0, 0]"}, goal: {goal}}}
samples: 8
""")
    proc = run("sweep", study, "--dry-run", "--out", tmp_path / "out", cwd=tmp_path, monkeypatch=monkeypatch)
    # no unit and 72.8 across: refused before any work, naming the fix
    line = _error_line(proc)
    assert "units: box.stl carries no unit" in line
    key = "footprint" if kind == "push" else "mesh"
    assert line.endswith(f"in a config: part: {{{key}: box.stl, units: mm}}"), line
    study.write_text(study.read_text().replace("part: box.stl", "part: {mesh: box.stl, units: mm}"
                                                if kind == "tumble" else
                                                "part: {footprint: box.stl, units: mm}"))
    proc = run("sweep", study, "--dry-run", "--out", tmp_path / "out", cwd=tmp_path, monkeypatch=monkeypatch)
    assert proc.returncode == 0, proc.stderr
    assert f"part: box ({want}, from box.stl (mm, the part file))" in proc.stdout
    assert not (tmp_path / "out").exists()
    if kind == "tumble":   # and the run itself: a mesh through python -m sweeps.run
        proc = run("sweep", study, "--out", tmp_path / "out", "--quiet", cwd=tmp_path,
                   monkeypatch=monkeypatch)
        assert proc.returncode == 0, proc.stderr
        plans = pd.read_parquet(tmp_path / "out" / "plans")
        assert plans.planned.all() and set(plans.part_source) == {"box.stl"}
        assert len(pd.read_parquet(tmp_path / "out" / "samples")) == 8


@pytest.mark.slow
def test_an_edited_cad_file_does_not_resume_its_run(tmp_path, monkeypatch):
    rounded_plate_dxf(tmp_path / "plate.dxf", hole=None)
    cfg = write(tmp_path / "c.yaml", """part: {outline: plate.dxf, chord_tolerance: 1}
tolerances: {tau_v: 0.02 mm}
model: exact
n_samples: 16
tasks:
  - {name: t, start: [0, 0, 0], goal: [80 mm, 0, 0]}
""")
    out = tmp_path / "out"
    first = run("certify", cfg, "--out", out, "--quiet", cwd=tmp_path, monkeypatch=monkeypatch)
    assert first.returncode in (0, 1), first.stderr
    manifest = json.loads((out / "manifest.json").read_text())
    assert "# part geometry: plate.dxf sha256 " in manifest["config"]
    again = run("certify", cfg, "--out", out, "--quiet", cwd=tmp_path, monkeypatch=monkeypatch)   # resumes: nothing to do
    assert again.returncode == first.returncode, again.stderr
    rounded_plate_dxf(tmp_path / "plate.dxf", hole=None, r=6.0)   # the drawing changed
    line = _error_line(run("certify", cfg, "--out", out, "--quiet", cwd=tmp_path, monkeypatch=monkeypatch))
    assert "of another config" in line and "plate.dxf sha256" in line
