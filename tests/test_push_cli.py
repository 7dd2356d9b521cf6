"""Tests for the pushing CLI (``nudge plan-push``) and its figures.

The runs that plan, and one bad input, are subprocesses (the console script;
Python + JAX start-up, a few seconds of CPU each), so an autouse module fixture
starts them on a thread pool (at most one per spare core) as soon as the module
starts; they run alongside the in-process tests, and each CLI test waits only
for the run it reads.  The other bad inputs run in this process
(:func:`tests.commandline.nudge_here`).
"""
from __future__ import annotations

import json
import math
import os
import pathlib
import subprocess

from tests.commandline import nudge_executable, nudge_here
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from sweeps.plan_push import _join_pose_args, parse_pose, InputError
from planning.pushing.plan import PushPlan

ROOT = pathlib.Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"

# example -> (object class, start, goal)
EXAMPLE_RUNS = {
    "rectangle": ("nice-stable", "-0.1,0,0", "0.1,0.05,90deg"),
    "unistable": ("uni-stable", "0,0,0", "0.05,0.02,3.14159"),
    "biplus_stable": ("biplus-stable", "0.02,-0.01,30deg", "-0.05,0.06,-2.0"),
    "nice_stable": ("nice-stable", "0,0,1", "0.08,-0.03,200deg"),
}


def _bad_files(tmp: pathlib.Path) -> dict:
    files = {
        "unknown_key": "vertices: [[0, 0], [0.04, 0], [0.04, 0.02]]\ncolour: red\n",
        "nan_vertex": "vertices: [[0, 0], [0.04, .nan], [0.04, 0.02]]\n",
        "com_outside": "vertices: [[0, 0], [0.04, 0], [0.04, 0.02], [0, 0.02]]\ncom: [0.05, 0.01]\n",
    }
    out = {}
    for name, text in files.items():
        out[name] = tmp / f"{name}.yaml"
        out[name].write_text(text)
    return out


@pytest.fixture(scope="module", autouse=True)
def cli(tmp_path_factory):
    """Start every CLI run; yields ({key: (returncode, stdout, stderr)}, folder)."""
    tmp = tmp_path_factory.mktemp("push_cli")
    bad = _bad_files(tmp)
    rect = str(EXAMPLES / "rectangle.yaml")
    specs = {f"json_{name}": [str(EXAMPLES / f"{name}.yaml"), "--start", start, "--goal", goal, "--json"]
             for name, (_, start, goal) in EXAMPLE_RUNS.items()}
    specs.update({
        "plain_plots": [str(EXAMPLES / "biplus_stable.yaml"), "--start", "0,0,0", "--goal",
                        "0.05,0.02,1", "--plot", str(tmp / "plan.png"), "--psd", str(tmp / "psd.png")],
        "unknown_key": [str(bad["unknown_key"]), "--start", "0,0,0", "--goal", "0.1,0,0"],
    })
    here = {
        "nan_vertex": [str(bad["nan_vertex"]), "--start", "0,0,0", "--goal", "0.1,0,0"],
        "com_outside": [str(bad["com_outside"]), "--start", "0,0,0", "--goal", "0.1,0,0"],
        "bad_start": [rect, "--start", "0.1,zero,0", "--goal", "0.1,0,0"],
        "short_goal": [rect, "--start", "0,0,0", "--goal", "0.1,0"],
        "polyhedron": [str(EXAMPLES / "cube.yaml"), "--start", "0,0,0", "--goal", "0.1,0,0"],
        "missing_file": [str(tmp / "nope.yaml"), "--start", "0,0,0", "--goal", "0.1,0,0"],
        "bad_margin": [rect, "--start", "0,0,0", "--goal", "0.1,0,0", "--margin-deg", "120"],
    }
    env = dict(os.environ, JAX_PLATFORMS="cpu")

    def run(argv):
        p = subprocess.run([nudge_executable(), "plan-push", *argv], cwd=ROOT, env=env,
                           capture_output=True, text=True, timeout=600)
        return p.returncode, p.stdout, p.stderr

    # no more runs at once than cores (JAX start-up is CPU-bound); the heavy ones first
    pool = ThreadPoolExecutor(max_workers=max(1, min(len(specs), (os.cpu_count() or 2) - 1)))
    futures = {k: pool.submit(run, argv) for k, argv in specs.items()}
    yield _Runs(futures, here), tmp
    pool.shutdown(wait=True, cancel_futures=True)


class _Runs:
    """Results ``(returncode, stdout, stderr)`` of the started runs, waited for when
    read, and of the runs in this process, run when read."""

    def __init__(self, futures, here):
        self._futures, self._here = futures, here

    def __getitem__(self, key):
        if key in self._here:
            r = nudge_here("plan-push", *self._here[key], cwd=ROOT)
            return r.returncode, r.stdout, r.stderr
        return self._futures[key].result()


# ---------------------------------------------------------------- in-process

@pytest.mark.parametrize("text, want", [
    ("0.1,-0.2,0.5", (0.1, -0.2, 0.5)),
    (" 1e-2 , 2 , 90deg ", (0.01, 2.0, math.pi / 2)),
    ("0,0,-45deg", (0.0, 0.0, -math.pi / 4)),
    ("0,0,3rad", (0.0, 0.0, 3.0)),
    ("-.5,+.5,.25", (-0.5, 0.5, 0.25)),
])
def test_parse_pose(text, want):
    np.testing.assert_allclose(parse_pose(text, "--start"), want)


@pytest.mark.parametrize("text", ["", "1,2", "1,2,3,4", "a,0,0", "0,0,nan", "0,0,inf", "0,0,90 degrees",
                                  "0,0,1e999"])
def test_parse_pose_rejects(text):
    with pytest.raises(InputError, match="--goal"):
        parse_pose(text, "--goal")


def test_negative_pose_values_are_joined():
    assert _join_pose_args(["p.yaml", "--start", "-0.1,0,0", "--goal", "0,0,0"]) == \
        ["p.yaml", "--start=-0.1,0,0", "--goal", "0,0,0"]
    assert _join_pose_args(["--start", "--json"]) == ["--start", "--json"]


def test_planning_error_exits_1(monkeypatch, capsys):
    import planning as pose_planner   # the door the command uses
    from sweeps import plan_push as push

    def fail(*a, **k):
        raise pose_planner.PlanningError("no feasible pose plan (test)")

    monkeypatch.setattr(pose_planner, "prepare_part", lambda *a, **k: None)
    monkeypatch.setattr(pose_planner, "plan_pose", fail)
    rc = push.main([str(EXAMPLES / "rectangle.yaml"), "--start", "0,0,0", "--goal", "0.1,0,0"])
    cap = capsys.readouterr()
    assert rc == 1 and cap.out == ""
    assert cap.err.strip() == "error: no feasible pose plan (test)"


@pytest.mark.slow
def test_psd_only_mode(tmp_path, capsys):
    from sweeps import plan_push as push
    rc = push.main([str(EXAMPLES / "unistable.yaml"), "--psd", str(tmp_path / "u.png")])
    cap = capsys.readouterr()
    assert rc == 0
    assert "uni-stable part, stable edges [[0, 1]]" in cap.out
    assert (tmp_path / "u.png").read_bytes()[:8] == PNG_MAGIC


@pytest.mark.slow
@pytest.mark.parametrize("name", ["unistable", "biplus_stable"])  # each new part costs ~3 s CPU
def test_push_stability_matches_tables(name):
    """The replayed capture ranges agree with the planner's tables."""
    from sweeps.partfile import load_part
    from planning.pushing.planner import prepare_part
    from sweeps.figures.push import push_stability

    pf = load_part(EXAMPLES / f"{name}.yaml")
    part = prepare_part(pf.vertices, pf.com)
    assert part.class_name == EXAMPLE_RUNS[name][0]
    data = push_stability(part)  # the CLI's grid: shares the compiled replay with test_psd_only_mode
    n_grid = len(data.theta)
    cell = 2 * math.pi / n_grid
    # every orientation ends on a stable edge
    assert set(np.unique(data.final_edge)) == set(part.stable)
    for e in part.stable:
        te = data.edge_theta[e]
        for sense, sign in ((0, +1), (1, -1)):  # CW lands from te + alpha, CCW from te - alpha
            mx = part.max_reorient[e, sense]
            # orientations strictly inside the maximum reorient range end on edge e
            alphas = np.arange(cell, mx - cell, cell)
            idx = np.round(np.mod(te + sign * alphas, 2 * math.pi) / cell).astype(int) % n_grid
            inside = np.abs(np.mod(data.theta[idx] - te + math.pi, 2 * math.pi) - math.pi) < mx - 0.5 * cell
            assert np.all(data.final_edge[idx[inside]] == e), (e, sense)
            assert part.step[e, sense] < mx
    # the radius function is smallest at the stable edges' orientations
    for e in part.stable:
        k = int(np.round(data.edge_theta[e] / cell)) % n_grid
        nb = data.radius[[(k - 3) % n_grid, (k + 3) % n_grid]]
        assert data.radius[k] <= nb.min() + 1e-12
    # between two neighbouring divergent orientations there is exactly one stable edge
    assert len(data.divergent) == len(part.stable)


# ---------------------------------------------------------------- CLI subprocesses

@pytest.mark.slow
@pytest.mark.parametrize("name", list(EXAMPLE_RUNS))
def test_json_round_trips_and_reaches_goal(cli, name):
    rc, out, err = cli[0][f"json_{name}"]
    assert rc == 0, err
    assert "Traceback" not in err
    d = json.loads(out)  # nothing but JSON on stdout
    plan = PushPlan.from_dict(d)
    assert plan.to_dict() == d
    assert plan.object_class == EXAMPLE_RUNS[name][0]
    assert max(plan.final_error) < 1e-9
    _, _, goal = EXAMPLE_RUNS[name]
    want = parse_pose(goal, "goal")
    np.testing.assert_allclose(plan.goal, want)
    np.testing.assert_allclose(plan.pushes[-1].pose_after[:2], want[:2], atol=1e-9)


@pytest.mark.slow
def test_plain_output_and_figures(cli):
    rc, out, err = cli[0]["plain_plots"]
    tmp = cli[1]
    assert rc == 0, err
    assert "Traceback" not in err
    assert "biplus-stable part" in out and "kind" in out and "reorient" in out
    for name in ("plan.png", "psd.png"):
        data = (tmp / name).read_bytes()
        assert data[:8] == PNG_MAGIC and len(data) > 20_000
        assert f"wrote {tmp / name}" in err


@pytest.mark.slow
@pytest.mark.parametrize("key, needles", [
    ("unknown_key", ["unknown key 'colour'", "allowed keys", "vertices"]),
    ("nan_vertex", ["vertices[1][1]", "finite"]),
    ("com_outside", ["com", "inside"]),
    ("bad_start", ["--start", "y must be a number"]),
    ("short_goal", ["--goal", "x,y,theta"]),
    ("polyhedron", ["kind", "polygon"]),
    ("missing_file", ["no such part file"]),
    ("bad_margin", ["--margin-deg"]),
])
def test_bad_input_exits_2_with_one_line(cli, key, needles):
    rc, out, err = cli[0][key]
    assert rc == 2, (out, err)
    assert "Traceback" not in err
    assert out == ""
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    for n in needles:
        assert n in lines[0], lines[0]
