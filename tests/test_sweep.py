"""Parameter studies: designs, overrides, errors, the run folder, resume after
SIGKILL and Ctrl-C, the Dask executor (a LocalCluster on loopback, a killed
worker), the report, and the bundled studies, through the commands a user types."""
import json
import os
import pathlib
import signal
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest

from sweeps.config import ConfigError
from sweeps.design import expand, parse_overrides
from sweeps.study import load_design
from tests.commandline import in_process, nudge, nudge_here

ROOT = pathlib.Path(__file__).resolve().parents[1]
TABLES = ("samples", "summary", "plans")

TINY = """study: tiny
kind: push
part: nice_stable
tasks:
  - {name: a, start: [0, 0, 0], goal: [0.08, 0.03, 1.0]}
  - {name: b, start: [0, 0, 0], goal: [-0.05, 0.06, -2.0]}
tolerances: {tau_v: 2e-5, tau_com: 1e-4}
execution: {start_xy: 5e-4, start_theta: 0.01}
eps: {pos_eps_m: 0.003, theta_eps_rad: 0.05}
model: exact
samples: 24
chunk_samples: 8
seed: 3
report: false
params:
  planner.margin_deg: [5, 9]
"""


def _study(tmp_path, text=TINY, name="tiny.yaml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def run_module(*args, timeout=600, **kw):
    """``python -m sweeps.run ARGS`` (the documented main command)."""
    env = dict(os.environ, JAX_PLATFORMS="cpu")
    env.pop("NUDGE_DEBUG", None)
    return subprocess.run([sys.executable, "-m", "sweeps.run", *map(str, args)], cwd=kw.pop("cwd", ROOT),
                          capture_output=True, text=True, timeout=timeout, env=env, **kw)


def run_here(*args, cwd=None):
    """:func:`run_module` in this process (``sweeps.run.main``, as ``python -m
    sweeps.run`` runs it: :func:`tests.commandline.in_process`), returned as a
    ``CompletedProcess``: for the tests of what the command writes and says;
    a signal, a cold start or a process's environment needs :func:`run_module`."""
    from sweeps import run

    return in_process(run.main, *args, cwd=cwd)


def _tables(out):
    got = {}
    for t in TABLES:
        df = pd.read_parquet(out / t)
        key = [c for c in ("config_id", "task", "sample_id") if c in df]
        got[t] = df.sort_values(key, kind="stable").reset_index(drop=True)
    return got


def _wait_for_chunks(out, n, timeout=300):
    """Wait until the run in ``out`` has logged ``n`` finished chunks."""
    log = out / "chunks.jsonl"
    t0 = time.time()
    while time.time() - t0 < timeout and (not log.exists() or len(log.read_text().splitlines()) < n):
        time.sleep(0.01)
    return log


def _same(a, b):
    for t in TABLES:
        pd.testing.assert_frame_equal(a[t], b[t], check_exact=True)


# ---------------------------------------------------------------- designs
def test_axes_grid_linspace_range_random_zip():
    paths, pts = expand({"a": [1, 2], "b": {"linspace": [0.0, 1.0, 3]}}, seed=0)
    assert paths == ["a", "b"] and len(pts) == 6
    assert pts[0] == {"a": 1, "b": 0.0} and pts[1] == {"a": 1, "b": 0.5} and pts[5] == {"a": 2, "b": 1.0}
    _, pts = expand({"r": {"range": [0.0, 1.0, 0.25]}}, seed=0)
    assert [p["r"] for p in pts] == [0.0, 0.25, 0.5, 0.75]
    _, u1 = expand({"u": {"uniform": [1.0, 2.0], "n": 4}, "g": [0, 1]}, seed=7)
    _, u2 = expand({"u": {"uniform": [1.0, 2.0], "n": 4}}, seed=7)
    assert sorted({p["u"] for p in u1}) == sorted(p["u"] for p in u2)  # draws do not depend on other axes
    assert all(1.0 <= p["u"] <= 2.0 for p in u2)
    _, lg = expand({"l": {"loguniform": [1e-6, 1e-3], "n": 5}}, seed=1)
    assert all(1e-6 <= p["l"] <= 1e-3 for p in lg)
    paths, pts = expand({"a": [1, 2, 3], "b": [10, 20, 30], "c": [0, 1], "zip": [["a", "b"]]}, 0)
    assert len(pts) == 6 and {(p["a"], p["b"]) for p in pts} == {(1, 10), (2, 20), (3, 30)}


@pytest.mark.parametrize("params,words", [
    ({"planner.margin_deg": {"lnspace": [1, 2, 3]}}, ["params.planner.margin_deg", "linspace", "uniform"]),
    ({"x": True}, ["params.x", "a number, a list"]),
    ({"a": [1, 2], "b": [1], "zip": [["a", "b"]]}, ["params.zip[0]", "equal lengths"]),
    ({"a": [1], "zip": [["a", "nope"]]}, ["params.zip[0]", "'nope'"]),
    ({"a": {"range": [0.0, 1.0, -0.1]}}, ["params.a", "step"]),
    ({"a": []}, ["params.a", "empty"]),
])
def test_axis_errors_name_the_path(params, words):
    with pytest.raises(ConfigError) as info:
        expand(params, 0)
    for w in words:
        assert w in str(info.value), str(info.value)


def test_overrides_axis_value_and_range():
    got = parse_overrides(["planner.margin_deg=5,7,9", "samples=2000", "friction.mu_f=[0.3,0.8]",
                           "tolerances.tau_v=1e-5"])
    assert got["planner.margin_deg"] == ([5, 7, 9], True)
    assert got["samples"] == (2000, False)
    assert got["friction.mu_f"] == ([0.3, 0.8], False)
    assert got["tolerances.tau_v"] == (1e-5, False) and isinstance(got["tolerances.tau_v"][0], float)
    with pytest.raises(ConfigError, match="path=value"):
        parse_overrides(["samples"])


def test_design_applies_overrides_and_sweeps_range_fields(tmp_path):
    p = _study(tmp_path)
    d = load_design(p, ["friction.mu_f=0.3,0.8", "samples=16", "planner.margin_deg=7"])
    assert d.paths == ["friction.mu_f"] and len(d.configs) == 2
    assert [c.friction.mu_f for c in d.configs] == [(0.3, 0.3), (0.8, 0.8)]
    assert all(c.samples == 16 and c.planner.margin_deg == 7 for c in d.configs)
    assert "samples: 16" in d.text and d.run_id != load_design(p).run_id


BAD_STUDIES = [
    (("samples: 24", "samples: -1"), ["samples", ">= 1"]),
    (("planner.margin_deg: [5, 9]", "planner.margin: [5, 9]"), ["params.planner.margin", "no field 'margin'", "margin_deg"]),
    (("planner.margin_deg: [5, 9]", "planner.margin_deg: [5, 95]"), ["configuration 1", "margin_deg", "< 90"]),
    (("tau_v: 2e-5", "tau_v: -2e-5"), ["tolerances.tau_v", ">= 0"]),
    (("kind: push", "kind: tumble"), ["kind", "polygon", "push"]),
    (("model: exact", "model: exact\nbogus: 1"), ["bogus", "allowed keys"]),
    (("part: nice_stable", "part: no_such_part"), ["part", "no_such_part", "bundled"]),
    (("  - {name: b, start: [0, 0, 0], goal: [-0.05, 0.06, -2.0]}", "  - {name: b, goal: [1, 2, 3]}"),
     ["tasks[1].start", "needs a start"]),
    (("model: exact", "model: exact\nplanner: {min_fence_mu: 0.5}"), ["planner", "support_c"]),
    (("model: exact", "model: exact\nplanner: {workspace: [0.1, -0.1, 0, 1]}"), ["planner", "xmin < xmax"]),
    (("model: exact", "model: exact\nplanner: {strategy: greedy}"), ["planner.strategy", "search", "paper"]),
]


@pytest.mark.parametrize("edit,words", BAD_STUDIES)
def test_bad_studies_exit_2_naming_the_field_before_anything_runs(tmp_path, edit, words):
    """The first mistake through the command's own process (nothing a library prints
    reaches its stderr), the others in this process."""
    p = _study(tmp_path, TINY.replace(*edit))
    out = tmp_path / "out"
    r = (run_module if (edit, words) == BAD_STUDIES[0] else run_here)(p, "--out", out)
    assert r.returncode == 2, (r.stdout, r.stderr)
    assert "Traceback" not in r.stderr and r.stdout == ""
    lines = r.stderr.strip().splitlines()
    assert all(ln.startswith("error: ") for ln in lines)
    for w in words:
        assert w in r.stderr, r.stderr
    assert not out.exists()


def test_one_error_per_mistake(tmp_path):
    p = _study(tmp_path, TINY.replace("samples: 24", "samples: -1").replace("tau_v: 2e-5", "tau_v: -1"))
    with pytest.raises(ConfigError) as info:
        load_design(p)
    assert len(info.value.lines) == 2
    assert any("samples" in ln for ln in info.value.lines)
    assert any("tolerances.tau_v" in ln for ln in info.value.lines)


def test_unwritable_output_is_refused_first(tmp_path):
    p = _study(tmp_path)
    blocker = tmp_path / "blocker"
    blocker.write_text("")
    r = run_here(p, "--out", blocker / "run")
    assert r.returncode == 2 and "cannot write results" in r.stderr


def test_dry_run_prints_the_design_and_writes_nothing(tmp_path):
    p = _study(tmp_path)
    r = nudge_here("sweep", p, "--dry-run", "--out", tmp_path / "out", "--set", "tolerances.tau_v=0,1e-5")
    assert r.returncode == 0, r.stderr
    assert "4 configuration(s) x 2 task(s)" in r.stdout and "estimate" in r.stdout
    assert "planner.margin_deg" in r.stdout and "tolerances.tau_v" in r.stdout
    assert "chunk" in r.stdout
    assert not (tmp_path / "out").exists()


def test_dry_run_estimates_every_model_it_can_run(tmp_path):
    """``--dry-run`` answers for the physics model and for the limit-surface model
    on each support (issue 41: KeyError 'mujoco', exit 3), from the measured
    rates: limit_surface on the mixture of supports (its pads of 25 points) is
    slower than on rigid corners (since the solver of issue 38, by a little:
    THROUGHPUT's 60 and 70 samples/s), MuJoCo far slower than the quasi-static model."""
    import re

    secs = {}
    for model, support in (("mujoco", "any"), ("limit_surface", "rigid"), ("limit_surface", "any"),
                           ("quasistatic", "any")):
        r = nudge_here("sweep", "margins.yaml", "--dry-run", "--set", f"model={model}",
                       f"friction.support={support}", "samples=200")
        assert r.returncode == 0, r.stderr
        m = re.search(r"estimate: about ([\d.]+) (s|min|h)", r.stdout)
        assert m, r.stdout
        secs[model, support] = float(m.group(1)) * {"s": 1, "min": 60, "h": 3600}[m.group(2)]
    assert secs["limit_surface", "any"] > secs["limit_surface", "rigid"]
    assert secs["mujoco", "any"] > 10 * secs["quasistatic", "any"]


def test_a_study_over_the_budget_is_refused_in_one_line_before_any_work(tmp_path):
    r = nudge_here("sweep", "margins.yaml", "--out", tmp_path / "out", "--set", "model=mujoco",
                   "samples=100000")
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: study margins is estimated at about")
    assert "--yes" in lines[0] and "h on 2 CPU cores" in lines[0]
    assert not (tmp_path / "out").exists()


def test_a_full_disk_is_one_line_and_the_run_resumes(tmp_path, monkeypatch):
    """Issue 41: a full disk was 'internal error (OSError: [Errno 28] ...)', exit 3.
    Now one line naming the folder and the free space, exit 2, the finished chunks
    kept; the same command resumes to the end once there is space."""
    from sweeps.store import RunStore

    p = _study(tmp_path)
    out = tmp_path / "out"
    real, calls = RunStore.write, []

    def fills_up(self, table, *a, **kw):
        calls.append(table)
        if len(calls) > 2:
            raise OSError(28, "No space left on device", str(self.root / table / "part.parquet"))
        return real(self, table, *a, **kw)

    monkeypatch.setattr(RunStore, "write", fills_up)
    r = nudge_here("sweep", p, "--out", out, "--quiet")
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: no space left on the disk holding {out}")
    assert "MB free" in lines[0] and "run the same command again to resume" in lines[0]
    monkeypatch.setattr(RunStore, "write", real)
    r = nudge_here("sweep", p, "--out", out, "--quiet")
    assert r.returncode == 0, r.stderr
    assert not pd.read_parquet(out / "summary").empty


def test_a_local_run_uses_the_design_it_validated_and_only_the_wire_carries_json(tmp_path,
                                                                                monkeypatch):
    """Issue 39 (the values travel): a run in this process validates the study
    once; its units use that design (no JSON round trip, no second validation
    of ``planner.margin_deg``).  A pickled context (a Dask worker's) carries the
    resolved document only, and the worker builds the same design from it."""
    import pickle

    from sweeps import study, work

    built = []
    real = study.Design.__init__

    def counting(self, *a, **kw):
        built.append(1)
        return real(self, *a, **kw)

    monkeypatch.setattr(study.Design, "__init__", counting)
    work.CONTEXTS.clear()
    r = run_here(_study(tmp_path), "--out", tmp_path / "out", "--quiet")
    assert r.returncode == 0, r.stderr
    assert len(built) == 1
    ctx = next(iter(work.CONTEXTS))
    loaded = work.CONTEXTS[ctx]
    assert loaded.design.configs[1].planner.margin_deg == 9
    wire = pickle.loads(pickle.dumps(work.Context(str(loaded.design.path), ctx[1], ctx[0], "{}",
                                                  design=loaded.design)))
    assert wire.design is None and wire.doc_json == ctx[1]
    rebuilt = work.Loaded(wire).design
    assert len(built) == 2
    assert [c.planner.margin_deg for c in rebuilt.configs] == [5, 9]


# ---------------------------------------------------------------- running
@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """An uninterrupted run of the tiny study (local executor)."""
    tmp = tmp_path_factory.mktemp("ref")
    p = _study(tmp)
    out = tmp / "out"
    r = run_module(p, "--out", out)
    assert r.returncode == 0, r.stderr
    return p, out, _tables(out), r


@pytest.mark.slow
def test_tables_layout_and_dtypes(reference):
    p, out, t, r = reference
    s, summ, plans = t["samples"], t["summary"], t["plans"]
    assert len(s) == 2 * 2 * 24 and s["sample_id"].max() == 23
    assert s["run_id"].nunique() == 1 and s["run_id"].iloc[0].startswith("r")
    assert sorted(s["config_id"].astype(int).unique()) == [0, 1]
    assert s["planner_margin_deg"].dtype == np.int64
    assert set(zip(summ["config_id"].astype(int), summ["planner_margin_deg"])) == {(0, 5), (1, 9)}
    assert summ["n"].tolist() == [24] * 4 and str(summ["bound_violated"].dtype) == "boolean"
    assert plans["planned"].all() and (plans["n_steps"] > 0).all()
    # a samples file per block; the plans and summary rows of a configuration's tasks in one file
    for cid in (0, 1):
        folder = f"config_id={cid:05d}"
        assert sorted(f.name for f in (out / "samples" / folder).iterdir()) == [
            f"part-t{ti:04d}-b{b:04d}.parquet" for ti in range(2) for b in range(3)]
        for table in ("plans", "summary"):
            assert [f.name for f in (out / table / folder).iterdir()] == ["part-tasks.parquet"]
            assert pd.read_parquet(out / table / folder)["task"].tolist() == ["a", "b"]
    logged = [json.loads(x)["key"] for x in (out / "chunks.jsonl").read_text().splitlines()]
    assert sorted(logged) == sorted([f"c{c:05d}-t{t:04d}-b{b:04d}" for c in range(2)
                                     for t in range(2) for b in range(3)]
                                    + ["c00000-summary", "c00001-summary"])
    assert (out / "manifest.json").is_file()
    man = json.loads((out / "manifest.json").read_text())
    assert man["design"]["points"] == [{"planner.margin_deg": 5}, {"planner.margin_deg": 9}]
    # the summary table at the end names the swept parameter
    assert "planner_margin_deg" in r.stdout and "results:" in r.stdout


@pytest.mark.slow
def test_resume_after_sigkill_is_bit_identical(reference, tmp_path):
    p, _, ref, _ = reference
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "sweeps.run", str(p), "--out", str(out), "--quiet"],
                            cwd=ROOT, env=dict(os.environ, JAX_PLATFORMS="cpu"),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    log = _wait_for_chunks(out, 2)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    done_before = len(log.read_text().splitlines())
    assert done_before < 2 * 2 * 3 + 2, "the run finished before it could be killed"
    r = run_module(p, "--out", out)
    assert r.returncode == 0, r.stderr
    assert "resuming" in r.stderr
    _same(_tables(out), ref)


@pytest.mark.slow
def test_ctrl_c_stops_cleanly_and_resumes(reference, tmp_path):
    p, _, ref, _ = reference
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "sweeps.run", str(p), "--out", str(out)],
                            cwd=ROOT, env=dict(os.environ, JAX_PLATFORMS="cpu"),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    _wait_for_chunks(out, 1)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 130, err
    assert "resume" in err and "Traceback" not in err
    r = run_module(p, "--out", out)
    assert r.returncode == 0, r.stderr
    _same(_tables(out), ref)


@pytest.mark.slow
def test_a_failed_write_is_not_recorded_and_the_rerun_completes_the_tables(reference, tmp_path,
                                                                            monkeypatch):
    """The local executor writes a unit's files behind the next unit's work: a
    write that fails stops the run before that unit is recorded as done, and
    the same command afterwards gives the uninterrupted run's tables."""
    from sweeps import parquet
    from sweeps.run import execute
    from sweeps.study import Executor

    p, _, ref, _ = reference
    out = tmp_path / "out"
    real, real_atomic, calls = parquet.pq.write_table, parquet._atomic_write, []

    def fails_fourth(table, where, **kw):
        if len(calls) == 4:
            raise OSError("disk full")
        return real(table, where, **kw)

    def atomic(path, write, mode):
        calls.append(pathlib.Path(path))
        return real_atomic(path, write, mode)

    from sweeps.store import RunStore

    synced, real_sync = [], RunStore.sync_log
    monkeypatch.setattr(parquet.pq, "write_table", fails_fourth)
    monkeypatch.setattr(parquet, "_atomic_write", atomic)
    monkeypatch.setattr(RunStore, "sync_log", lambda self: synced.append(real_sync(self)))
    with pytest.raises(OSError, match="disk full"):
        execute(load_design(str(p), []), out, Executor(kind="local"), quiet=True, report=False)
    monkeypatch.undo()
    assert len(synced) == 1          # the log of finished units is synced on the way out
    logged = [json.loads(x) for x in (out / "chunks.jsonl").read_text().splitlines()]
    files = {f for rec in logged for f in rec["files"]}
    assert len(logged) == 2 and all((out / f).is_file() for f in files)   # after the manifest, two blocks
    assert str(calls[3].relative_to(out)) not in files and not calls[3].exists()
    assert not list(out.rglob("*.tmp"))
    r = run_here(p, "--out", out, "--quiet")
    assert r.returncode == 0, r.stderr
    _same(_tables(out), ref)


@pytest.mark.slow
def test_rerun_of_a_finished_run_changes_nothing_and_changed_config_is_refused(reference, tmp_path):
    p, out, ref, _ = reference
    r = run_here(p, "--out", out, "--quiet")
    assert r.returncode == 0, r.stderr
    _same(_tables(out), ref)
    r = run_here(p, "--out", out, "--set", "samples=25")
    assert r.returncode == 2 and "another config" in r.stderr


@pytest.mark.slow
def test_a_run_folder_of_the_per_task_layout_is_refused_not_doubled(reference, tmp_path):
    """A folder whose log names a plans or summary file per task (the layout
    before a file per configuration) is refused in one line: resuming it would
    write those rows a second time."""
    import shutil

    p, ref_out, ref, _ = reference
    out = tmp_path / "out"
    shutil.copytree(ref_out, out)
    old = "summary/config_id=00000/part-t0000.parquet"
    shutil.copy(out / "summary" / "config_id=00000" / "part-tasks.parquet", out / old)
    with open(out / "chunks.jsonl", "a") as fh:
        fh.write(json.dumps({"key": "c00000-t0000-summary", "files": [old], "rows": 1}) + "\n")
    r = run_here(p, "--out", out, "--quiet")
    assert r.returncode == 2, r.stderr
    assert r.stderr.count("\n") == 1 and "earlier nudge" in r.stderr and "--out" in r.stderr
    assert "Traceback" not in r.stderr
    (out / old).unlink()      # the folder as it was: nothing was written or removed
    _same(_tables(out), ref)


@pytest.mark.slow
def test_a_configuration_of_few_samples_is_one_unit_and_resumes(tmp_path):
    """Where a configuration's tasks have few samples (each one block, 4,096 in all at
    most) the configuration is one unit of work: its samples, plans and summary rows in
    one file each, a task after the other; a run that lost a unit reruns it alone, to
    the same tables; a folder whose log names blocks of it (the work split another way)
    is refused (in process here, for speed: through the command, the bundled margins
    study runs such units and the per-task layout's refusal is one line, exit 2)."""
    from sweeps.run import execute
    from sweeps.store import RunError
    from sweeps.study import Executor

    p = _study(tmp_path, TINY.replace("chunk_samples: 8", "chunk_samples: 24"))
    out = tmp_path / "out"

    def run():
        return execute(load_design(str(p), []), out, Executor(kind="local"), quiet=True,
                       report=False)

    assert run() == 0
    ref = _tables(out)
    for cid in (0, 1):
        folder = f"config_id={cid:05d}"
        for table in TABLES:
            assert [f.name for f in (out / table / folder).iterdir()] == ["part-tasks.parquet"]
        s = pd.read_parquet(out / "samples" / folder)
        assert s["task"].tolist() == ["a"] * 24 + ["b"] * 24
        assert s["sample_id"].tolist() == list(range(24)) * 2
        assert pd.read_parquet(out / "summary" / folder)["n"].tolist() == [24, 24]
    logged = [json.loads(x) for x in (out / "chunks.jsonl").read_text().splitlines()]
    assert [rec["key"] for rec in logged] == ["c00000-tasks", "c00001-tasks"]
    assert [rec["rows"] for rec in logged] == [48, 48]
    # the run as if killed before its last unit was logged (its files half there)
    lines = (out / "chunks.jsonl").read_text().splitlines(keepends=True)
    (out / "chunks.jsonl").write_text(lines[0])
    (out / "summary" / "config_id=00001" / "part-tasks.parquet").unlink()
    assert run() == 0
    assert len((out / "chunks.jsonl").read_text().splitlines()) == 2
    _same(_tables(out), ref)
    with open(out / "chunks.jsonl", "a") as fh:
        fh.write(json.dumps({"key": "c00000-t0000-b0000", "files": [], "rows": 24}) + "\n")
    with pytest.raises(RunError, match="earlier nudge .* cannot be resumed; choose another --out"):
        run()


@pytest.mark.slow
def test_dask_executor_matches_local(reference, tmp_path):
    """Dask workers with a persistent compilation cache of their own (the suite's is
    another folder: conftest) give the local run's tables."""
    p, _, ref, _ = reference
    out, cache = tmp_path / "out", tmp_path / "jax-cache"
    r = nudge("sweep", p, "--out", out, "--executor", "dask", "--quiet",
              env={"NUDGE_JAX_CACHE": str(cache)})
    assert r.returncode == 0, r.stderr
    _same(_tables(out), ref)
    assert any(cache.iterdir()), "the workers wrote no compiled kernel"


@pytest.mark.slow
def test_local_run_uses_the_cache_cold_and_warm_and_gives_the_same_tables(reference, tmp_path):
    p, _, ref, _ = reference
    cache = tmp_path / "jax-cache"
    for run in ("cold", "warm"):
        out = tmp_path / run
        r = nudge("sweep", p, "--out", out, "--quiet", env={"NUDGE_JAX_CACHE": str(cache)})
        assert r.returncode == 0, r.stderr
        _same(_tables(out), ref)
        assert any(cache.iterdir())


def _replay_devices() -> int:
    from robustness.replay import replay_devices

    return len(replay_devices())


def test_the_cache_is_scoped_to_the_run(tmp_path, monkeypatch):
    """A run called from Python leaves JAX's cache settings (and the environment
    its subprocesses inherit) as it found them."""
    import jax

    from sweeps.executors import DaskExecutor, LocalExecutor

    monkeypatch.setenv("NUDGE_JAX_CACHE", str(tmp_path))
    before, env = jax.config.jax_compilation_cache_dir, dict(os.environ)   # Dask sets its own (OMP_NUM_THREADS)
    with LocalExecutor():
        assert jax.config.jax_compilation_cache_dir == str(tmp_path)
    assert jax.config.jax_compilation_cache_dir == before
    monkeypatch.delenv("NUDGE_THREADS", raising=False)
    env.pop("NUDGE_THREADS", None)
    monkeypatch.setenv("JAX_NUM_CPU_DEVICES", "3")     # this process's (a command line's)
    env["JAX_NUM_CPU_DEVICES"] = "3"
    with DaskExecutor(workers=1, threads_per_worker=2) as ex:
        assert os.environ["JAX_COMPILATION_CACHE_DIR"] == str(tmp_path)
        assert os.environ["NUDGE_THREADS"] == "2"   # a worker's rollouts: its own threads
        # ... and its compiled replays a CPU device per thread (robustness.replay.replay_devices)
        assert ex.client.submit(_replay_devices, pure=False).result() == 2
    ours = ("JAX_COMPILATION_CACHE_DIR", "JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "JAX_PLATFORMS",
            "NUDGE_THREADS", "JAX_NUM_CPU_DEVICES")
    assert {k: os.environ.get(k) for k in ours} == {k: env.get(k) for k in ours}


@pytest.mark.slow
def test_a_killed_dask_worker_loses_and_duplicates_nothing(reference, tmp_path):
    from distributed import Client, LocalCluster

    p, _, ref, _ = reference
    out = tmp_path / "out"
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address="127.0.0.1:0", scheduler_kwargs={"dashboard": False},
                      silence_logs=50) as cluster, Client(cluster) as client:
        pids = list(client.run(os.getpid).values())
        proc = subprocess.Popen([sys.executable, "-m", "sweeps.run", str(p), "--out", str(out),
                                 "--quiet", "--set", f"executor={{kind: dask, address: '{cluster.scheduler_address}'}}"],
                                cwd=ROOT, env=dict(os.environ, JAX_PLATFORMS="cpu"),
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        _wait_for_chunks(out, 1)
        os.kill(pids[0], signal.SIGKILL)   # the nanny restarts it; its tasks are re-run
        _, err = proc.communicate(timeout=600)
    assert proc.returncode == 0, err
    got = _tables(out)
    assert not got["samples"].duplicated(["config_id", "task", "sample_id"]).any()
    _same(got, ref)


@pytest.mark.slow
def test_report_is_self_contained(tmp_path, monkeypatch):
    p = _study(tmp_path, TINY.replace("report: false", "report: true").replace("samples: 24", "samples: 8"))
    out = tmp_path / "out"
    r = nudge_here("sweep", p, "--out", out, "--quiet")
    assert r.returncode == 0, r.stderr
    html = (out / "report.html").read_text()
    assert html.count("data:image/png;base64,") >= 4
    assert "http://" not in html and "https://" not in html and "<script" not in html
    assert "alt=\"success vs planner.margin_deg\"" in html
    # which configuration to use, in the report and under the run's table (issue 42)
    from markupsafe import escape

    from sweeps.report import recommendation

    rec = recommendation(pd.read_parquet(out / "summary"), pd.read_parquet(out / "plans"),
                         load_design(str(p), []))
    assert f'<h2>Recommendation</h2><p class="advice">{escape(rec)}</p>' in html
    assert rec.startswith(("use configuration", "no configuration meets"))
    r = nudge_here("sweep", p, "--out", out)
    assert r.returncode == 0 and rec in r.stdout.splitlines(), r.stdout
    # the report reads the summary and plans, never the samples (a big run's samples
    # table can be larger than memory), and it is the report that the whole tables give
    from sweeps.report import write_report
    from sweeps.store import RunStore

    store = RunStore(out, json.loads((out / "manifest.json").read_text()))
    design = load_design(str(p), [])
    real, asked = RunStore.read, []

    def spy(self, table, config_id=None, columns=None):
        asked.append((table, columns))
        return real(self, table, config_id, columns)

    monkeypatch.setattr(RunStore, "read", spy)
    write_report(store, design)
    assert "samples" not in [t for t, _ in asked] and "summary" in [t for t, _ in asked]
    assert (out / "report.html").read_text() == html
    monkeypatch.setattr(RunStore, "read", lambda self, table, config_id=None, columns=None:
                        real(self, table, config_id))
    write_report(store, design)
    assert (out / "report.html").read_text() == html
    # a summary holding every failure mode any model gives (a fence strike is physics'
    # alone): each is drawn and explained (issue 41: the report died on a KeyError)
    from markupsafe import escape   # what the report's jinja2 template escapes with

    from robustness import failure_modes

    def every_mode(self, table, config_id=None, columns=None):
        t = real(self, table, config_id, columns)
        if table == "summary":
            for name in failure_modes.NAMES[1:]:
                t[f"n_{name}"] = 1
        return t

    monkeypatch.setattr(RunStore, "read", every_mode)
    write_report(store, design)
    page = (out / "report.html").read_text()
    for m in failure_modes.MODES[1:]:
        assert f"<code>{m.name}</code>: {escape(m.description)}" in page, m.name


# ---------------------------------------------------------------- bundled studies
@pytest.mark.slow
@pytest.mark.parametrize("name", ["margins.yaml", "tolerances.yaml"])
def test_bundled_studies_are_found_by_name_and_valid(tmp_path, name):
    r = run_here(name, "--dry-run", cwd=tmp_path)   # not in the working folder: the bundled one
    assert r.returncode == 0, r.stderr
    assert "configuration(s)" in r.stdout


@pytest.mark.slow
def test_bundled_margins_runs_small(tmp_path):
    r = run_module("margins.yaml", "--out", tmp_path / "out", "--set", "samples=8",
                   "--set", "tasks.sample.n=2", "--quiet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert r.stderr == "", r.stderr     # quiet, in a fresh process: nothing a library prints
    s = pd.read_parquet(tmp_path / "out" / "summary")
    assert len(s) == 2 * len(s["config_id"].unique()) and (s["n"] == 8).all()
    # each configuration (2 tasks x 8 samples) is one unit: a file per table
    assert {f.name for f in (tmp_path / "out" / "samples").rglob("*.parquet")} == {
        "part-tasks.parquet"}
    # the bundled axes show the margin's effect: the paper's plans get shorter with it
    # (and the fence angle error it guards against is an axis)
    assert {"planner_margin_deg", "planner_strategy", "execution_fence_angle"} <= set(s.columns)
    p = pd.read_parquet(tmp_path / "out" / "plans")
    d = p[p["planner_strategy"] == "paper"].groupby("planner_margin_deg")["total_distance_m"].mean()
    assert d[12] < d[7] < d[3], d


@pytest.mark.slow
def test_planner_options_reach_the_plans(tmp_path):
    """The push planner's options are study fields (and axes): the paper's strategy plans
    no shorter than the default search, and a workspace is honoured."""
    text = (TINY.replace("samples: 24", "samples: 4").replace("chunk_samples: 8", "chunk_samples: 4")
            .replace("  planner.margin_deg: [5, 9]", "  planner.strategy: [search, paper]")
            + "planner: {workspace: [-0.15, 0.15, -0.15, 0.15]}\n")
    out = tmp_path / "out"
    r = run_here(_study(tmp_path, text), "--out", out, "--quiet")
    assert r.returncode == 0, r.stderr
    plans = pd.read_parquet(out / "plans")
    assert plans["planned"].all()
    d = plans.pivot_table(index="task", columns="planner_strategy", values="total_distance_m")
    assert (d["search"] <= d["paper"] + 1e-9).all(), d

