"""The command-line edge (issue 21): bad input is one ``error:`` line and exit
status 2 before any work (an inline part's geometry, an unreachable Dask
scheduler, a figure's file type, a design too large to expand, a setting the
planner refuses), a bug is exit status 3 (re-raised under ``NUDGE_DEBUG=1``),
and the push planner's effort options (``max_reorients``, ``extra_steps``)
reach the planner from ``nudge plan-push``, studies and certify configs.

In process (each command's ``main`` as the console script runs it,
:func:`tests.commandline.call`), but for the design too large to expand: a
subprocess, whose timeout guards the memory of a design that is expanded."""
from __future__ import annotations

import json
import pathlib

import pandas as pd
import pytest

from planning.pushing.plan import PushPlan
from sweeps import certify, plan_push, plan_tumble
from sweeps import run as sweep
from sweeps.config import ConfigError
from sweeps import design
from sweeps.design import expand
from tests.commandline import call, nudge

STUDY = """study: edge
kind: push
part: nice_stable
tasks:
  - {name: a, start: [0, 0, 0], goal: [0.08, 0.03, 1.0]}
model: exact
samples: 2
report: false
"""
CERTIFY = """part: rectangle
tasks:
  - {name: turn, start: [0, 0, 0], goal: [0.05, 0.02, 90deg]}
model: exact
n_samples: 10
"""
RECT = ["rectangle", "--start", "0,0,0", "--goal", "0.05,0.02,90deg"]
CUBE = ["cube", "--goal", "0.2,0,0,1", "--eps", "0.05"]


def _write(tmp_path, text, name="edge.yaml") -> pathlib.Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def _one_error(rc, err, code=2):
    lines = err.strip().splitlines()
    assert rc == code, err
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    assert "internal error" not in err and "Traceback" not in err
    return lines[0]


# ------------------------------------------------------------ inline parts
@pytest.mark.parametrize("kind,part,task,words", [
    ("push", "{vertices: [[0, 0], [0.1, 0], [0.2, 0]]}", "start: [0, 0, 0], goal: [0.1, 0, 1]",
     ["part.vertices", "collinear"]),
    ("push", "{vertices: [[0.1, 0.1], [0.1, 0.1], [0.1, 0.1]]}",
     "start: [0, 0, 0], goal: [0.1, 0, 1]", ["part.vertices", "coincident"]),
    ("push", "{vertices: [[0, 0], [0.1, 0], [0, 0.1]], com: [1, 1]}",
     "start: [0, 0, 0], goal: [0.1, 0, 1]", ["part.com", "inside"]),
    ("tumble", "{vertices: [[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0.1, 0.1, 0]]}",
     "goal: [0.1, 0, 0, 1]", ["part.vertices", "coplanar"]),
])
def test_inline_part_geometry_is_bad_input_before_any_work(tmp_path, kind, part, task, words):
    text = (f"study: inline\nkind: {kind}\npart: {part}\ntasks:\n  - {{name: a, {task}}}\n"
            "samples: 2\nreport: false\n")
    out = tmp_path / "out"
    rc, stdout, err = call(sweep.main, _write(tmp_path, text), "--out", out)
    line = _one_error(rc, err)
    for w in words:
        assert w in line, line
    assert stdout == "" and not out.exists()


def test_certify_inline_part_geometry_is_bad_input_before_any_work(tmp_path):
    text = ("part: {vertices: [[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0.1, 0.1, 0]]}\n"
            "tasks:\n  - {name: a, goal: [0.1, 0, 0, 1]}\nn_samples: 10\n")
    out = tmp_path / "out"
    rc, _, err = call(certify.main, _write(tmp_path, text), "--out", out)
    line = _one_error(rc, err)
    assert "part.vertices" in line and "coplanar" in line
    assert not out.exists()


def test_a_setting_the_planner_refuses_in_a_study_is_bad_input(tmp_path):
    """A workspace that does not hold the start: the planner's ValueError, exit 2 naming the
    configuration, the task and the field (not an internal error)."""
    out = tmp_path / "out"
    text = STUDY + "planner: {workspace: [0.5, 0.6, 0.5, 0.6]}\n"
    rc, _, err = call(sweep.main, _write(tmp_path, text), "--out", out, "--quiet")
    line = _one_error(rc, err)
    assert "planner.workspace" in line and "task a" in line and "configuration 0" in line


# ------------------------------------------------------------ Dask
@pytest.mark.parametrize("address,words", [
    ("tcp://127.0.0.1:1",
     ["cannot reach the Dask scheduler at tcp://127.0.0.1:1", "executor: local"]),
    ("tcp://127.0.0.1", ["tcp://HOST:PORT"]),
])
def test_an_unreachable_dask_scheduler_is_bad_input(tmp_path, address, words):
    out = tmp_path / "out"
    text = STUDY + f'executor: {{kind: dask, address: "{address}"}}\n'
    rc, _, err = call(sweep.main, _write(tmp_path, text), "--out", out, "--quiet")
    line = _one_error(rc, err)
    assert line.startswith("error: executor.address: "), line
    for w in words:
        assert w in line, line
    assert not out.exists()


# ------------------------------------------------------------ figures
@pytest.mark.parametrize("main,args,flag", [
    (plan_push.main, RECT + ["--plot", "{d}/x.txt"], "--plot"),
    (plan_push.main, ["rectangle", "--psd", "{d}/x.txt"], "--psd"),
    (plan_tumble.main, CUBE + ["--plot", "{d}/x.txt"], "--plot"),
    (plan_tumble.main, ["cube", "--development", "{d}/x"], "--development"),
    (plan_tumble.main, ["cube", "--lattice", "{d}/nodir/x.png"], "--lattice"),
])
def test_a_figure_file_type_is_checked_before_any_work(tmp_path, main, args, flag):
    rc, out, err = call(main, *[a.format(d=tmp_path) for a in args])
    line = _one_error(rc, err)
    assert line.startswith(f"error: {flag}: "), line
    assert ".png" in line or "does not exist" in line, line
    assert out == "" and list(tmp_path.iterdir()) == []


# ------------------------------------------------------------ bugs are exit 3
def _raise(exc):
    def f(*a, **k):
        raise exc
    return f


@pytest.mark.parametrize("exc", [ZeroDivisionError("boom"), TypeError("boom"),
                                 ArithmeticError("boom")])
def test_a_bug_in_the_tumble_planner_is_an_internal_error(monkeypatch, exc):
    import planning as tp   # the door the command uses (tests/test_layers.py)

    monkeypatch.setattr(tp, "plan_tumble", _raise(exc))
    rc, _, err = call(plan_tumble.main, *CUBE)
    assert rc == 3 and f"internal error ({type(exc).__name__}: boom)" in err, err
    with pytest.raises(type(exc)):
        call(plan_tumble.main, *CUBE, debug=True)


def test_a_bug_in_plan_push_is_an_internal_error(monkeypatch, tmp_path):
    import planning as pp   # the door the command uses (tests/test_layers.py)
    from sweeps.figures import push as push_plots

    # an ImportError is the solver's only with --solver cvxpy
    monkeypatch.setattr(pp, "plan_pose", _raise(ImportError("no module named nowhere")))
    rc, _, err = call(plan_push.main, *RECT)
    assert rc == 3 and "internal error (ImportError" in err, err
    # a ValueError inside a figure is not 'cannot write'
    monkeypatch.setattr(push_plots, "plot_psd", _raise(ValueError("bad array")))
    rc, _, err = call(plan_push.main, "rectangle", "--psd", tmp_path / "psd.png")
    assert rc == 3 and "internal error (ValueError: bad array)" in err, err


# ------------------------------------------------------------ design size
@pytest.mark.slow
def test_a_huge_design_is_refused_before_it_is_expanded(tmp_path):
    """A 1e8-configuration grid (two 10,000-value axes): one line, exit 2, also under
    --dry-run, instead of gigabytes of configurations (the timeout is the guard)."""
    text = STUDY + ("params:\n  planner.margin_deg: {linspace: [1, 20, 10000]}\n"
                    "  planner.safety_factor: {linspace: [1.1, 2, 10000]}\n")
    r = nudge("sweep", _write(tmp_path, text), "--dry-run", timeout=90)
    line = _one_error(r.returncode, r.stderr)
    assert "params:" in line and "100,000,000 configurations" in line, line
    assert f"{design.MAX_CONFIGS:,}" in line and "planner.margin_deg (10000)" in line


def test_design_size_is_counted_from_the_axes(monkeypatch):
    with pytest.raises(ConfigError, match=r"params: .*120,000 configurations"):
        expand({"a": list(range(400)), "b": list(range(300))}, 0)
    # an axis that would not fit in memory is counted, not drawn
    for spec in ({"linspace": [0, 1, 10 ** 12]}, {"range": [0, 1e12, 1]},
                 {"uniform": [0, 1], "n": 100_000}):
        with pytest.raises(ConfigError, match=r"params"):
            expand({"a": spec, "b": [1, 2]}, 0)
    monkeypatch.setattr("sweeps.design.MAX_CONFIGS", 100)
    zipped = {"a": list(range(10)), "b": list(range(10)), "c": list(range(10)), "zip": [["a", "b"]]}
    assert len(expand(zipped, 0)[1]) == 100     # zipped axes count once
    zipped["c"].append(10)
    with pytest.raises(ConfigError, match="110 configurations"):
        expand(zipped, 0)


def test_too_many_chunks_is_refused_before_they_are_listed(tmp_path):
    text = STUDY.replace("samples: 2", "samples: 2000000\nchunk_samples: 1")
    rc, out, err = call(sweep.main, _write(tmp_path, text), "--dry-run")
    line = _one_error(rc, err)
    assert "chunk_samples" in line and "2,000,001" in line, line
    assert out == ""


# ------------------------------------------------------------ planner options
def _plan(*args) -> PushPlan:
    rc, out, err = call(plan_push.main, *RECT, *args, "--json")
    assert rc == 0, err
    return PushPlan.from_dict(json.loads(out))


def test_plan_push_max_reorients_and_extra_steps_reach_the_planner():
    rc, out, err = call(plan_push.main, *RECT, "--max-reorients", "1")
    assert rc == 1 and out == "" and "max_reorients" in err, err
    few = _plan("--extra-steps", "0")
    assert few.options.extra_steps == 0 and few.options.max_reorients == 24
    capped = _plan("--max-reorients", "3")
    assert capped.options.max_reorients == 3 and capped.n_reorients <= 3
    default = _plan()
    assert few.n_reorients == 2 and default.n_reorients > 3   # both options change the plan


@pytest.mark.parametrize("args,flag", [
    (["--max-reorients", "0"], "--max-reorients"), (["--max-reorients", "2.5"], "--max-reorients"),
    (["--extra-steps", "-1"], "--extra-steps"), (["--extra-steps", "x"], "--extra-steps"),
])
def test_plan_push_bad_effort_options(args, flag):
    rc, out, err = call(plan_push.main, *RECT, *args)
    line = _one_error(rc, err)
    assert flag in line and "integer" in line, line


@pytest.mark.parametrize("planner,field", [
    ("{max_reorients: 0}", "planner.max_reorients"),
    ("{max_reorients: true}", "planner.max_reorients"),
    ("{max_reorients: 2.5}", "planner.max_reorients"), ("{extra_steps: -1}", "planner.extra_steps"),
])
def test_study_and_certify_effort_options_are_validated(tmp_path, planner, field):
    rc, _, err = call(sweep.main, _write(tmp_path, STUDY + f"planner: {planner}\n"), "--dry-run")
    lines = [_one_error(rc, err)]
    rc, _, err = call(certify.main, _write(tmp_path, CERTIFY + f"planner: {planner}\n", "c.yaml"),
                      "--out", tmp_path / "cert")
    lines.append(_one_error(rc, err))
    for line in lines:
        assert field in line and "unknown key" not in line, line
        assert "integer" in line or ">=" in line, line


@pytest.mark.slow
def test_study_and_certify_effort_options_reach_the_planner(tmp_path):
    out = tmp_path / "out"
    text = STUDY + "planner: {max_reorients: 1}\n"
    rc, _, err = call(sweep.main, _write(tmp_path, text), "--out", out, "--quiet")
    assert rc == 0, err
    plans = pd.read_parquet(out / "plans")
    assert not plans["planned"].any() and "max_reorients" in plans["reason"].iloc[0]
    rc, stdout, err = call(certify.main, _write(tmp_path, CERTIFY + "planner: {max_reorients: 1}\n",
                                                "c.yaml"), "--out", tmp_path / "cert")
    assert rc == 1 and "max_reorients" in err, err
    rc, stdout, err = call(certify.main, _write(tmp_path, CERTIFY + "planner: {extra_steps: 0}\n",
                                                "c0.yaml"), "--out", tmp_path / "cert0")
    plan = json.loads(pd.read_parquet(tmp_path / "cert0" / "plans")["plan_json"].iloc[0])
    assert plan["extra_steps"] == 0 and plan["max_reorients"] == 24


def test_a_listening_scheduler_address_passes_the_probe():
    import socket

    from sweeps.executors import check_scheduler

    with socket.socket() as server:
        server.bind(("127.0.0.1", 0))
        server.listen(1)
        check_scheduler(f"tcp://127.0.0.1:{server.getsockname()[1]}")   # no error
