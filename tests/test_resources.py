"""What a run may hold and how it ends when the machine cannot give more (issue 41).

* Blocks: a run whose block size is not set holds about half a minute of
  samples at once (:func:`robustness.block_samples`), so a 10^5-sample MuJoCo
  certification builds a few dozen models at a time (it grew to 4 GB and died by SIGSEGV
  before its first sample).
* The support loads compile once per shape (an uncompiled loop compiled an
  executable per sample: the memory maps grew past the kernel's limit).
* The console commands run under a supervisor: a death by signal (memory,
  memory maps, native code) is one ``error:`` line and exit status 4.
"""
import os
import pathlib
import shlex
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from tests.commandline import nudge_executable

ROOT = pathlib.Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "certify_triangle.yaml"


def _config(tmp_path, model: str) -> pathlib.Path:
    cfg = tmp_path / "c.yaml"
    cfg.write_text(EXAMPLE.read_text()
                   .replace("part: biplus_stable.yaml",
                            f"part: {ROOT / 'examples' / 'biplus_stable.yaml'}")
                   .replace("model: limit_surface", f"model: {model}"))
    return cfg


def test_block_sizes_hold_about_half_a_minute_of_samples():
    from robustness import block_samples, peak_bytes, samples_per_second
    from robustness.models import BLOCK_MAX, BLOCK_MIN, BLOCK_SECONDS

    for kind, model, support in (("push", "mujoco", "any"), ("push", "mujoco", "rigid"),
                                 ("push", "limit_surface", "any"),
                                 ("push", "limit_surface", "rigid"),
                                 ("push", "quasistatic", "any"), ("tumble", "exact", "any")):
        b = block_samples(kind, model, support)
        assert BLOCK_MIN <= b <= BLOCK_MAX and b & (b - 1) == 0, (model, b)
        secs = b / samples_per_second(kind, model, support)
        assert secs <= BLOCK_SECONDS or b == BLOCK_MIN, (model, support, secs)
        assert 2 * b > BLOCK_MAX or 2 * secs > BLOCK_SECONDS, (model, support, secs)
    assert block_samples("push", "mujoco", "any") <= 64
    assert peak_bytes("mujoco", 64) < 1.2e9 < peak_bytes("mujoco", 100_000)


def test_a_physics_study_of_many_samples_is_cut_into_small_units():
    """A study with no chunk_samples was one unit of all its samples per task:
    10^5 MuJoCo samples in one process call."""
    from robustness import block_samples
    from sweeps.study import load_design
    from sweeps.work import block_size, plan_units

    d = load_design("margins.yaml", ["model=mujoco", "samples=100000"])
    b = block_samples("push", "mujoco", "any")
    assert block_size(d.configs[0]) == b <= 64
    blocks, _ = plan_units(d, {})
    assert max(u.samples for u in blocks) == b
    d = load_design("margins.yaml", ["model=mujoco", "samples=100000", "chunk_samples=500"])
    assert block_size(d.configs[0]) == 500   # the user's value is kept
    d = load_design("margins.yaml", [])     # the quick default study is unchanged: whole configurations
    assert all(u.n_tasks > 1 for u in plan_units(d, {})[0])


@pytest.mark.float64
def test_support_loads_compile_once_per_shape():
    """``equilibrium_weights`` ran a ``fori_loop`` op by op: each call (one per
    MuJoCo sample) compiled a new executable, and a 10^5-sample run's memory maps
    grew until LLVM's mmap failed."""
    import jax

    from robustness.physics.geometry import support_of
    from kernels.support import CODES

    compiles = []
    rng = np.random.default_rng(0)

    def body():
        a = np.sort(rng.uniform(0, 2 * np.pi, 6))
        return np.stack([np.cos(a), np.sin(a)], 1) * 0.03

    support_of(CODES["tripod"], body(), 0.004, np.zeros(6))   # compile what it needs
    jax.monitoring.register_event_duration_secs_listener(
        lambda event, secs, **kw: compiles.append(event) if "backend_compile" in event else None)
    for _ in range(5):
        feet, w = support_of(CODES["tripod"], body(), 0.004, np.zeros(6))
        assert feet.shape == (3, 2) and abs(w.sum() - 1) < 1e-12
    n = len(compiles)
    compiles.clear()
    compiles.append("done")   # the listener stays registered: nothing else counts after this
    assert n == 0, f"{n} compilations in 5 calls of one shape"


@pytest.mark.parametrize("signum,code,word", [
    (signal.SIGSEGV, 4, "native code"), (signal.SIGABRT, 4, "native code"),
    (signal.SIGKILL, 4, "out of memory"), (signal.SIGINT, 130, "resume"),
    (signal.SIGTERM, 143, "SIGTERM")])
def test_every_death_by_signal_has_one_line_and_a_status(signum, code, word):
    from sweeps.terminal import death_line

    line, status = death_line(int(signum))
    assert status == code and word in line and "\n" not in line
    assert "run the same command again to resume" in line


def test_a_process_starved_of_memory_ends_in_one_line_not_a_signal(tmp_path):
    """Under ``ulimit -v`` 1 GB the command's process aborts in native code
    (std::bad_alloc: SIGABRT, exit -6 before); the supervisor answers for it."""
    cfg = _config(tmp_path, "quasistatic")
    cmd = (f"ulimit -v 1000000 && exec {shlex.quote(nudge_executable())} certify "
           f"{shlex.quote(str(cfg))} --n-samples 50 --out {shlex.quote(str(tmp_path / 'out'))}")
    r = subprocess.run(["bash", "-c", cmd], cwd=ROOT, capture_output=True, text=True,
                       timeout=300, env=dict(os.environ, JAX_PLATFORMS="cpu"))
    assert r.returncode == 4, (r.returncode, r.stderr[-2000:])
    last = r.stderr.strip().splitlines()[-1]
    assert last.startswith("error: ") and "memory" in last and "resume" in last, last
    assert not (tmp_path / "out" / "certificates").exists()


def _rss_kb(pid: int) -> int:
    for line in pathlib.Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    return 0


def _children(pid: int) -> list:
    p = pathlib.Path(f"/proc/{pid}/task/{pid}/children")
    return [int(x) for x in p.read_text().split()] if p.exists() else []


@pytest.mark.slow
@pytest.mark.skipif(not pathlib.Path("/proc/self/status").exists(), reason="reads /proc")
def test_an_accepted_hundred_thousand_sample_physics_certification_runs_in_blocks(tmp_path):
    """Issue 41: 10^5 MuJoCo samples with ``--yes`` built every sample's model
    before the first ran (4 GB, then SIGSEGV, nothing written).  Now blocks of
    about half a minute's samples are written as they finish, memory stays flat,
    and Ctrl-C stops it cleanly (exit 130, the blocks kept, no certificate)."""
    import pyarrow.parquet as pq

    from robustness import block_samples

    cfg, out = _config(tmp_path, "mujoco"), tmp_path / "out"
    proc = subprocess.Popen([nudge_executable(), "certify", str(cfg), "--n-samples", "100000",
                             "--yes", "--out", str(out)], cwd=ROOT, text=True,
                            env=dict(os.environ, JAX_PLATFORMS="cpu"),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    samples = out / "samples" / "config_id=00000"
    deadline, peak = time.monotonic() + 400, 0
    try:
        while time.monotonic() < deadline and not list(samples.glob("*.parquet")):
            assert proc.poll() is None, proc.communicate()
            peak = max([peak] + [_rss_kb(c) for c in _children(proc.pid)])
            time.sleep(0.5)
        assert list(samples.glob("*.parquet")), "no block in 400 s"
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err[-2000:]
    assert "resume" in err and "Traceback" not in err
    assert 0 < peak < 2_000_000, f"peak RSS {peak / 1e6:.2f} GB"
    files = sorted(samples.glob("*.parquet"))
    size = block_samples("push", "mujoco", "any")
    assert all(pq.read_metadata(f).num_rows == size for f in files), files
    assert not (out / "certificates").exists() and not (out / "report.html").exists()


def test_a_resumed_run_is_estimated_on_what_is_left(tmp_path):
    """The estimate of a resumed certification leaves out the samples of its
    finished blocks (the log's ``rows``): a run interrupted after most of its
    work is not refused again for the work it has done."""
    import json

    from sweeps import certify
    from sweeps.store import LOG, finished_units

    assert finished_units(tmp_path / "none") == {}
    (tmp_path / "samples").mkdir()
    for b in range(3):
        (tmp_path / "samples" / f"b{b}.parquet").write_bytes(b"")
    with open(tmp_path / LOG, "w") as f:
        for b in range(3):
            f.write(json.dumps({"key": f"t0000-b{b:04d}", "files": [f"samples/b{b}.parquet"],
                                "rows": 1000}) + "\n")
        f.write(json.dumps({"key": "t0000-b0003", "files": ["samples/gone.parquet"],
                            "rows": 1000}) + "\n")   # its file is gone: not finished
    done = finished_units(tmp_path)
    assert sorted(done) == ["t0000-b0000", "t0000-b0001", "t0000-b0002"]
    cfg, _, _, part, tasks = certify.load(_config(tmp_path, "mujoco"), n_samples=9000)
    whole = certify.estimate_seconds(cfg, part, 1)
    left = certify.estimate_seconds(cfg, part, 1, sum(r["rows"] for r in done.values()))
    from robustness import samples_per_second

    rate = samples_per_second("push", "mujoco", "any")
    assert whole > 3600 > left and whole - left == pytest.approx(3000 / rate, rel=0.01)


def test_sensorless_tasks_and_the_margin_search_are_estimated_at_their_own_cost(tmp_path):
    """A sensorless task replays one MuJoCo rollout a sample from its own start,
    slower than a known-start push (its measured rate, not the push's); the
    margin search adds its grid's search draws and the chosen plan's
    certification on the task's draws."""
    from robustness import samples_per_second
    from sweeps import certify

    cfg, _, _, part, _ = certify.load(_config(tmp_path, "mujoco"), n_samples=100)
    one = certify.estimate_seconds(cfg, part, 2)
    mixed = certify.estimate_seconds(cfg, part, 2, sensorless=1)
    per = 1 / samples_per_second("sensorless", "mujoco") - 1 / samples_per_second("push", "mujoco")
    assert mixed - one == pytest.approx(100 * per, rel=1e-9) and mixed > 5 * one
    from sweeps.config import MarginSearch

    grid = MarginSearch(margins_deg=[3, 7], safety_factors=[1.15], n_samples=50)
    searched = certify.estimate_seconds(cfg.model_copy(update={"margin_search": grid}), part, 2)
    rate = samples_per_second("push", "mujoco", cfg.friction.support)
    assert searched - one == pytest.approx(2 * (2 * 50 + 100) / rate, rel=1e-9)
