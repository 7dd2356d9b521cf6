"""Tests for the tumble command line (``python -m sweeps.plan_tumble``), its figures
(:mod:`sweeps.figures.tumble`) and the benchmark script's quick mode."""
from __future__ import annotations

import json
import os
import pathlib
import re
import subprocess
import sys

import jax


import numpy as np  # noqa: E402
import pytest  # noqa: E402

from tests.commandline import nudge_executable, nudge_here  # noqa: E402
from kernels.polyhedron import make_polyhedron  # noqa: E402
from planning.tumbling import planner as tumble_planner  # noqa: E402  (an import error fails the suite)
from planning.tumbling.development import development_poses, face_footprint  # noqa: E402
from planning.tumbling.trajectory import sample_reached_positions  # noqa: E402
from sweeps.partfile import load_part  # noqa: E402
from sweeps.figures import tumble as tumble_plots  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
CUBE = EXAMPLES / "cube.yaml"
A = 0.1  # the example cube's edge, metres
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def run_cli(*args, process=False, timeout=300):
    """``nudge plan-tumble ARGS`` from the repository root: in this process
    (:func:`tests.commandline.nudge_here`), or with ``process`` in its own (the
    console script; nothing a library prints may reach its stderr)."""
    if not process:
        return nudge_here("plan-tumble", *args, cwd=ROOT)
    env = dict(os.environ)
    env.pop("NUDGE_DEBUG", None)
    env.setdefault("JAX_PLATFORMS", "cpu")
    return subprocess.run([nudge_executable(), "plan-tumble", *map(str, args)],
                          cwd=ROOT, capture_output=True, text=True, timeout=timeout, env=env)


def assert_png(path: pathlib.Path):
    assert path.is_file(), path
    data = path.read_bytes()
    assert len(data) > 2000 and data[:8] == PNG_MAGIC, path


def load_poly(name: str):
    p = load_part(EXAMPLES / f"{name}.yaml")
    return p, make_polyhedron(p.vertices, p.com)


def planner():
    return tumble_planner


# ---------------------------------------------------------------- plots, direct
@pytest.mark.parametrize("name", ["cube", "octahedron"])
def test_plot_development_from_polyhedron(name, tmp_path):
    part, poly = load_poly(name)
    out = tmp_path / f"dev_{name}.png"
    poses = tumble_plots.plot_development(poly, out, name=name)
    assert_png(out)
    assert sorted(poses) == list(range(poly.n_faces))
    assert poses[0] == (0.0, 0.0, 0.0)
    # each face's copy shares its hinge edge with its parent's copy (a development)
    P, parent = development_poses(poly, 0)
    for f, g in parent.items():
        if g is None:
            continue
        a, b = poly.shared_edge(f, g)
        for v in (a, b):
            wf = face_footprint(poly, f, P[f])[poly.face_cycles[f].index(v)]
            wg = face_footprint(poly, g, P[g])[poly.face_cycles[g].index(v)]
            np.testing.assert_allclose(wf, wg, atol=1e-12)
    # and every copy is congruent to its face (areas match)
    for f in P:
        w = face_footprint(poly, f, P[f])
        x, y = w[:, 0], w[:, 1]
        area = 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
        q = poly.face_corners_2d[f]
        area0 = 0.5 * abs(np.dot(q[:, 0], np.roll(q[:, 1], -1)) - np.dot(q[:, 1], np.roll(q[:, 0], -1)))
        assert area == pytest.approx(area0, rel=1e-12)


def test_cube_development_is_the_cross(tmp_path):
    _, poly = load_poly("cube")
    P, _ = development_poses(poly, 0)
    origins = sorted((round(p[0] / A), round(p[1] / A)) for p in P.values())
    # five unit steps around the root plus one face two steps away: a cross of six squares
    assert len(set(origins)) == 6
    assert sum(1 for o in origins if abs(o[0]) + abs(o[1]) == 1) == 4
    tumble_plots.plot_development(load_part(CUBE), tmp_path / "d.png", root=3)
    assert_png(tmp_path / "d.png")


@pytest.mark.slow
@pytest.mark.parametrize("name", ["cube", "octahedron"])
def test_plot_reachable_and_plan_direct(name, tmp_path):
    tp = planner()
    part, poly = load_poly(name)
    an = tp.analyze_polyhedron(part.vertices, com=part.com)
    pts = tumble_plots.plot_reachable(an, tmp_path / "lat.png", 0.6, name=name)
    assert_png(tmp_path / "lat.png")
    assert pts.ndim == 2 and pts.shape[1] == 2 and len(pts) >= 1
    tumble_plots.plot_development(an, tmp_path / "dev.png")
    assert_png(tmp_path / "dev.png")
    # a goal the planner can reach: the start translated by a lattice vector
    X1 = np.asarray([float(c) for c in an.lattice_basis[0]][:2])
    plan = tp.plan_tumble(part.vertices, (X1[0], X1[1], 0.0, 0), com=part.com, eps=1e-3)
    cfgs = tumble_plots.plot_plan(plan, tmp_path / "plan.png", name=name)
    assert_png(tmp_path / "plan.png")
    assert cfgs.shape == (plan.n_tumbles + 1, 4)
    if plan.verdict == "solved" and plan.predicted_final is not None:
        np.testing.assert_allclose(cfgs[-1, :2], np.asarray(plan.predicted_final[:2], float),
                                   atol=1e-9)
        assert int(cfgs[-1, 3]) == int(plan.predicted_final[3])


@pytest.mark.slow
@pytest.mark.parametrize("name", ["irregular_polyhedron", "truncated_pyramid"])
def test_plot_reachable_dense_zooms(name, tmp_path):
    """A dense class: the lattice mesh is far below the figure's scale (for the truncated
    pyramid ~1e-200 m^2 and very skewed), so a zoom panel shows it; no huge enumeration,
    no giant figure."""
    tp = planner()
    part, _ = load_poly(name)
    an = tp.analyze_polyhedron(part.vertices, com=part.com)
    assert an.reachable_class != "discrete"
    pts = tumble_plots.plot_reachable(an, tmp_path / "lat.png", 0.3, n_walks=200)
    assert_png(tmp_path / "lat.png")
    assert 1 <= len(pts) <= tumble_plots.MAX_DRAWN_POINTS
    from PIL import Image
    w, h = Image.open(tmp_path / "lat.png").size
    assert w < 4000 and h < 3000


def test_sample_reached_positions_cube_on_grid():
    _, poly = load_poly("cube")
    pts = sample_reached_positions(poly, 0, 0.35, n_walks=100)
    assert len(pts) > 10
    assert np.all(np.linalg.norm(pts, axis=1) <= 0.35 + 1e-12)
    # the cube's face 0 only ever lands on the a-grid
    np.testing.assert_allclose(pts / A, np.round(pts / A), atol=1e-9)


# ---------------------------------------------------------------- CLI, good input
@pytest.mark.slow
def test_cli_cube_exact_goal_json_and_plots(tmp_path):
    planner()
    from planning.tumbling.plan import TumblePlan

    plot, dev, lat = tmp_path / "plan.png", tmp_path / "dev.png", tmp_path / "lat.png"
    r = run_cli(CUBE, "--goal", f"{2 * A},0,0,0", "--eps", "1e-3", "--json",
                "--plot", plot, "--development", dev, "--lattice", lat, process=True)
    assert r.returncode == 0, r.stderr
    assert "Traceback" not in r.stderr
    d = json.loads(r.stdout)  # stdout holds the JSON and nothing else
    plan = TumblePlan.from_dict(d)
    assert plan.verdict == "solved"
    assert plan.to_dict() == d
    assert plan.error <= 1e-3
    assert tuple(plan.goal)[3] == 0
    for p in (plot, dev, lat):
        assert_png(p)


@pytest.mark.slow
def test_cli_summary_and_degrees(tmp_path):
    planner()
    r = run_cli(CUBE, "--goal", f"-{2 * A},0,180deg,0", "--eps", "1e-3", "--start", "0,0,90deg,0")
    assert r.returncode in (0, 1), r.stderr
    assert "Traceback" not in r.stderr
    assert r.stdout.startswith("cube: ")
    assert len(r.stdout.splitlines()) >= 2


@pytest.mark.slow
def test_cli_not_solvable_exits_1():
    planner()
    # the cube turns only by multiples of pi/2: a heading of 0.3 rad is off by more than eps
    r = run_cli(CUBE, "--goal", "0.2,0,0.3,0", "--eps", "1e-3")
    assert r.returncode == 1, (r.stdout, r.stderr)
    assert "Traceback" not in r.stderr
    assert "not solvable" in r.stderr
    assert r.stdout.strip()  # the plan is printed with its reason


# ---------------------------------------------------------------- CLI, bad input
def _assert_input_error(r, *words):
    assert r.returncode == 2, (r.stdout, r.stderr)
    assert "Traceback" not in r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), r.stderr
    for w in words:
        assert w in lines[0], lines[0]
    assert r.stdout == ""


def _write(tmp_path, text, name="part.yaml"):
    p = tmp_path / name
    p.write_text(text)
    return p


CUBE_ROWS = "\n".join(f"  - [{x}, {y}, {z}]" for x in (-0.05, 0.05) for y in (-0.05, 0.05)
                      for z in (-0.05, 0.05))


def test_cli_unknown_yaml_key(tmp_path):
    p = _write(tmp_path, f"kind: polyhedron\ncolour: red\nvertices:\n{CUBE_ROWS}\n")
    _assert_input_error(run_cli(p, "--goal", "0.2,0,0,0", "--eps", "1e-3"), "colour")


def test_cli_nan_vertex(tmp_path):
    rows = CUBE_ROWS.replace("[-0.05, -0.05, -0.05]", "[-0.05, .nan, -0.05]")
    p = _write(tmp_path, f"kind: polyhedron\nvertices:\n{rows}\n")
    _assert_input_error(run_cli(p, "--goal", "0.2,0,0,0", "--eps", "1e-3"), "vertices")


@pytest.mark.parametrize("goal", ["0.2,0,0", "0.2,zero,0,0", "0.2,0,0,-1", "0.2,0,0,1.5",
                                  "0.2,0,ninety,0", "nan,0,0,0"])
def test_cli_bad_goal(goal):
    _assert_input_error(run_cli(CUBE, "--goal", goal, "--eps", "1e-3"), "--goal")


@pytest.mark.parametrize("eps", ["-1e-3", "0", "abc", "inf"])
def test_cli_bad_eps(eps):
    _assert_input_error(run_cli(CUBE, "--goal", "0.2,0,0,0", "--eps", eps), "--eps")


@pytest.mark.slow
def test_cli_other_bad_input(tmp_path):
    _assert_input_error(run_cli(CUBE, "--goal", "0.2,0,0,0", process=True), "--eps")  # eps missing
    _assert_input_error(run_cli(CUBE, "--eps", "1e-3"), "--goal")  # goal missing
    _assert_input_error(run_cli(tmp_path / "missing.yaml", "--goal", "0.2,0,0,0", "--eps", "1"),
                        "missing.yaml")
    _assert_input_error(run_cli(EXAMPLES / "rectangle.yaml", "--goal", "0.2,0,0,0", "--eps", "1"),
                        "polyhedron")
    _assert_input_error(run_cli(CUBE, "--goal", "0.2,0,0,0", "--eps", "1e-3", "--tau-v", "-1"),
                        "--tau-v")
    _assert_input_error(run_cli(CUBE, "--goal", "0.2,0,0,0", "--eps", "1e-3", "--frobnicate"),
                        "frobnicate")
    flat = _write(tmp_path, "kind: polyhedron\nvertices: [[0,0,0],[1,0,0],[0,1,0],[1,1,0]]\n")
    _assert_input_error(run_cli(flat, "--goal", "0.2,0,0,0", "--eps", "1e-3"), "coplanar")
    _assert_input_error(run_cli(CUBE, "--goal", "0.2,0,0,6", "--eps", "1e-3"), "face 6")


# ---------------------------------------------------------------- bench
@pytest.mark.slow
def test_bench_quick_result_line():
    env = dict(os.environ)
    env.setdefault("JAX_PLATFORMS", "cpu")
    r = subprocess.run([sys.executable, "bench/tumble_planning.py", "--quick"], cwd=ROOT,
                       capture_output=True, text=True, timeout=600, env=env)
    assert r.returncode == 0, r.stderr[-3000:]
    last = r.stdout.strip().splitlines()[-1]
    m = re.fullmatch(r"RESULT median_shortening=(\S+) tumble_steps_per_s=(\d+)", last)
    assert m, last
    float(m.group(1))  # a number (nan when nothing was solved)
    assert int(m.group(2)) > 0


@pytest.mark.slow
def test_cli_effort_budget_runs_out_with_its_own_message(tmp_path):
    # a unit cube whose vertices carry 1e-9 of noise: dense at tau_v = 0, and this goal is
    # off its lattice; with a tiny budget the planner returns the best plan it has
    p = tmp_path / "noisy_cube.yaml"
    p.write_text("vertices: [[1e-9, 0, 0], [1, 2e-9, 0], [1, 1, 1e-9], [0, 1, 0], [0, 0, 1], "
                 "[1, 0, 1.000000003], [1, 1, 1], [2e-9, 1, 1]]\n")
    r = run_cli(p, "--goal=-3,1.5,0,0", "--eps", "1e-6", "--effort", "100000")
    assert r.returncode == 1, r.stderr
    assert "effort budget exhausted" in r.stderr and "Traceback" not in r.stderr
    r = run_cli(p, "--goal=-3,1.5,0,0", "--eps", "1e-6", "--effort", "1.5")
    assert r.returncode == 2 and "--effort" in r.stderr
