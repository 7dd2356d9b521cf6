"""Tests for sweeps.partfile: the YAML part-file loader."""
from __future__ import annotations

import pathlib

import numpy as np
import pytest

from sweeps.partfile import ALLOWED_KEYS, PartFile, PartFileError, load_part, parse_part

EXAMPLES = pathlib.Path(__file__).resolve().parents[1] / "examples"
POLYGONS = ["rectangle", "unistable", "biplus_stable", "nice_stable"]


def write(tmp_path, text: str, name: str = "part.yaml") -> pathlib.Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def error_of(path) -> str:
    with pytest.raises(PartFileError) as info:
        load_part(path)
    msg = str(info.value)
    assert "\n" not in msg, msg
    assert msg.startswith(str(path)), msg
    return msg


@pytest.mark.parametrize("name", POLYGONS)
def test_polygon_examples_load(name):
    part = load_part(EXAMPLES / f"{name}.yaml")
    assert isinstance(part, PartFile)
    assert part.kind == "polygon" and part.name == name and part.dim == 2
    assert part.vertices.dtype == np.float64 and part.vertices.shape[1] == 2
    assert part.vertices.shape[0] >= 3
    assert part.path == EXAMPLES / f"{name}.yaml"
    assert part.com is None or part.com.shape == (2,)
    assert not part.vertices.flags.writeable


def test_polyhedron_examples_load():
    # every example that is not a certification config is a part file
    files = [f for f in sorted(EXAMPLES.glob("*.yaml")) if not f.name.startswith("certify")]
    parts = [load_part(f) for f in files]
    assert {p.name for p in parts} >= {"cube", "tetrahedron", "octahedron", "rectangle"}
    polyhedra = [p for p in parts if p.kind == "polyhedron"]
    assert polyhedra, "expected the polyhedron examples (cube.yaml, ...)"
    for part in polyhedra:
        assert part.vertices.shape[1] == 3 and part.vertices.shape[0] >= 4
        assert part.com is None or part.com.shape == (3,)


def test_minimal_file_defaults(tmp_path):
    p = write(tmp_path, "vertices: [[0, 0], [0.03, 0], [0, 0.02]]\n", "wedge.yaml")
    part = load_part(p)
    assert part.name == "wedge" and part.kind == "polygon" and part.com is None
    assert part.description is None
    np.testing.assert_array_equal(part.vertices, [[0, 0], [0.03, 0], [0, 0.02]])


def test_material_fields_and_their_defaults(tmp_path):
    """thickness / density / mass: the physics scene's part (defaults: a 3 mm steel
    plate; a polyhedron of density 500)."""
    part = load_part(write(tmp_path, "vertices: [[0, 0], [0.04, 0], [0.04, 0.02], [0, 0.02]]\n"))
    assert part.thickness == 0.003 and part.density == 7800.0
    assert part.mass == pytest.approx(7800 * 0.04 * 0.02 * 0.003)
    part = load_part(write(tmp_path, "vertices: [[0, 0], [0.04, 0], [0.04, 0.02], [0, 0.02]]\n"
                                     "thickness: 0.005\nmass: 0.01\n", "m.yaml"))
    assert part.thickness == 0.005 and part.density == pytest.approx(0.01 / (0.04 * 0.02 * 0.005))
    assert parse_part(part.to_dict(), part.path).density == pytest.approx(part.density)
    cube = load_part(write(tmp_path, "vertices: [[0,0,0],[1,0,0],[0,1,0],[0,0,1],[1,1,0],[1,0,1],"
                                     "[0,1,1],[1,1,1]]\n", "c.yaml"))
    assert cube.thickness is None and cube.density == 500.0 and cube.mass == pytest.approx(500.0)


def test_kind_inferred_for_3_columns(tmp_path):
    p = write(tmp_path, "vertices: [[0,0,0],[1,0,0],[0,1,0],[0,0,1]]\ncom: [0.1, 0.1, 0.1]\n")
    part = load_part(p)
    assert part.kind == "polyhedron" and part.com.tolist() == [0.1, 0.1, 0.1]


def test_full_file_round_trips(tmp_path):
    text = ("name: t\nkind: polygon\nvertices: [[0, 0], [1, 0], [0, 1]]\ncom: [0.3, 0.3]\n"
            "description: a triangle\n")
    part = load_part(write(tmp_path, text))
    assert part.to_dict() == {"name": "t", "kind": "polygon",
                              "vertices": [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
                              "com": [0.3, 0.3], "description": "a triangle"}
    again = parse_part(part.to_dict(), part.path)
    np.testing.assert_array_equal(again.vertices, part.vertices)


def test_unknown_key_names_it_and_lists_allowed(tmp_path):
    msg = error_of(write(tmp_path, "vertices: [[0,0],[1,0],[0,1]]\ncolour: red\n"))
    assert "unknown key 'colour'" in msg
    for key in ALLOWED_KEYS:
        assert key in msg


@pytest.mark.parametrize("text, field", [
    ("vertices: [[0,0],[1,.nan],[0,1]]\n", "vertices[1][1]"),
    ("vertices: [[0,0],[1,0],[0,.inf]]\n", "vertices[2][1]"),
    ("vertices: [[0,0],[1,0],[0,1]]\ncom: [.nan, 0]\n", "com[0]"),
    ("vertices: [[0,0],[1,'a'],[0,1]]\n", "vertices[1][1]"),
    ("vertices: [[0,0],[1,true],[0,1]]\n", "vertices[1][1]"),
    ("vertices: [[0,0],[1,0,2],[0,1]]\n", "vertices"),
    ("kind: polygon\nvertices: [[0,0,0],[1,0,0],[0,1,0]]\n", "vertices[0]"),
    ("kind: polyhedron\nvertices: [[0,0,0],[1,0,0],[0,1,0]]\n", "at least 4"),
    ("vertices: [[0,0],[1,0]]\n", "at least 3"),
    ("vertices: []\n", "vertices"),
    ("vertices: 3\n", "vertices"),
    ("vertices: [0, 1, 2]\n", "vertices[0]"),
    ("vertices: [[0,0],[1,0],[0,1]]\ncom: [1, 2, 3]\n", "com"),
    ("vertices: [[0,0],[1,0],[0,1]]\ncom: 1\n", "com"),
    ("kind: polygn\nvertices: [[0,0],[1,0],[0,1]]\n", "kind"),
    ("name: [1]\nvertices: [[0,0],[1,0],[0,1]]\n", "name"),
    ("name: t\n", "vertices"),
    ("- 1\n- 2\n", "mapping"),
    ("", "empty"),
    ("vertices: [[0,0],[1,0],[0,1]]\nvertices: [[0,0],[1,0],[0,1]]\n", "given twice"),
    ("vertices: [[0,0],[1,0],[0,1]\n", "YAML syntax error"),
    ("vertices: [[0,0],[1,0],[0,1]]\nthickness: -1\n", "thickness: must be a finite number > 0"),
    ("vertices: [[0,0],[1,0],[0,1]]\ndensity: 7800\nmass: 1\n", "mass: give the part's density"),
    ("vertices: [[0,0,0],[1,0,0],[0,1,0],[0,0,1]]\nthickness: 0.003\n", "thickness: a polyhedron"),
    ("vertices: [[0,0],[1,0],[0,1]]\n  bad: indent\n", "YAML syntax error"),
])
def test_bad_files_give_one_line_naming_the_field(tmp_path, text, field):
    msg = error_of(write(tmp_path, text))
    assert field in msg, msg


def test_missing_file_and_directory(tmp_path):
    assert "no such part file" in error_of(tmp_path / "nope.yaml")
    assert "directory" in error_of(tmp_path)


def test_error_is_a_value_error(tmp_path):
    assert issubclass(PartFileError, ValueError)
    with pytest.raises(ValueError):
        load_part(write(tmp_path, "vertices: [[0,0],[1,0],[0,.nan]]\n"))


def test_exponent_numbers_are_numbers(tmp_path):
    # YAML 1.1 reads 1e9 / 1e-3 as strings; part files read them as the numbers they are
    p = write(tmp_path, "vertices: [[0, 0], [4e-2, 0], [4.0e-2, 2e-2], [0, 2E-2]]\n")
    part = load_part(p)
    assert part.vertices.tolist() == [[0, 0], [0.04, 0], [0.04, 0.02], [0, 0.02]]
    p = write(tmp_path, "vertices: [[0, 0], [1e9, 0], [0, 1e9]]\n", "big.yaml")
    assert load_part(p).vertices[1, 0] == 1e9


def test_a_key_given_twice_is_an_error(tmp_path):
    msg = error_of(write(tmp_path, "vertices: [[0, 0], [1, 0], [0, 1]]\nvertices: []\n"))
    assert "given twice" in msg and "line 2" in msg
