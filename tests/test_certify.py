"""python -m sweeps.certify: end to end, and bad configs."""
import os
import pathlib
import subprocess
import sys

import pandas as pd
import pytest

from sweeps import certify
from robustness.tables import VERDICTS
from sweeps.parquet import read_metadata

ROOT = pathlib.Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "certify_triangle.yaml"


def run_cli(*args, timeout=600):
    env = dict(os.environ)
    env.setdefault("JAX_PLATFORMS", "cpu")
    return subprocess.run([sys.executable, "-m", "sweeps.certify", *map(str, args)], cwd=ROOT,
                          capture_output=True, text=True, timeout=timeout, env=env)


def test_example_end_to_end(tmp_path):
    out = tmp_path / "out"
    r = run_cli(EXAMPLE, "--out", out, "--n-samples", "40", "--quiet")
    assert r.returncode in (0, 1), r.stderr
    assert "Traceback" not in r.stderr
    for name in ("samples", "summary", "certificates"):
        path = out / f"{name}.parquet"
        assert path.is_file()
        md = read_metadata(path)
        assert md["table"] == name and md["config"] == EXAMPLE.read_text() and md["seed"] == "0"
    certs = pd.read_parquet(out / "certificates.parquet")
    assert certs["task"].tolist() == ["translate", "turn"]
    assert set(certs["verdict"]) <= set(VERDICTS)
    summ = pd.read_parquet(out / "summary.parquet")
    assert (summ["n"] == 40).all()
    samples = pd.read_parquet(out / "samples.parquet")
    assert len(samples) == 80 and samples["sample_id"].max() == 39
    assert (samples["kind"] == "push").all()
    # the table on stdout has one line per task
    assert "translate" in r.stdout and "turn" in r.stdout
    # exit status: 0 only when every task is certified
    assert r.returncode == (0 if certs["verdict"].str.startswith("certified").all() else 1)


def _write(tmp_path, text):
    p = tmp_path / "cfg.yaml"
    p.write_text(text)
    return p


BASE = f"""part: {EXAMPLE.parent / 'biplus_stable.yaml'}
tolerances: {{tau_v: 1.0e-5}}
eps: {{pos_eps_m: 0.002, theta_eps_rad: 0.03}}
tasks:
  - {{name: a, start: [0, 0, 0], goal: [0.05, 0.0, 30deg]}}
"""


def _input_error(r, *words):
    assert r.returncode == 2, (r.stdout, r.stderr)
    assert "Traceback" not in r.stderr and r.stdout == ""
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), r.stderr
    for w in words:
        assert w in lines[0], lines[0]
    return lines[0]


def test_unknown_key_exits_2(tmp_path):
    p = _write(tmp_path, BASE.replace("tau_v: 1.0e-5", "tau_v: 1.0e-5, tau_vv: 2"))
    line = _input_error(run_cli(p), "tau_vv", "allowed keys")
    assert "tau_com" in line
    p = _write(tmp_path, BASE + "colour: red\n")
    _input_error(run_cli(p), "colour", "top level")


def test_negative_or_nan_tolerance_exits_2(tmp_path):
    p = _write(tmp_path, BASE.replace("tau_v: 1.0e-5", "tau_v: -1.0e-5"))
    _input_error(run_cli(p), "tolerances.tau_v", ">= 0", "metres")


@pytest.mark.parametrize("text,words", [
    (BASE.replace("tau_v: 1.0e-5", "tau_v: .nan"), ("tolerances.tau_v", "finite")),
    (BASE.replace("pos_eps_m: 0.002", "pos_eps_m: 0"), ("eps.pos_eps_m", "> 0")),
    (BASE.replace("30deg", "thirty"), ("tasks[0].goal[2]", "deg")),
    (BASE + "required: {probability: 1.5}\n", ("required.probability",)),
    (BASE.replace("biplus_stable.yaml", "missing.yaml"), ("part", "missing.yaml")),
    (BASE.replace("tasks:\n", "tasks: []\nx:\n"), ("x",)),
], ids=["nan", "zero-eps", "bad-angle", "probability", "missing-part", "unknown-top-key"])
def test_bad_configs_in_process(tmp_path, capsys, text, words):
    p = _write(tmp_path, text)
    code = certify.main([str(p)])
    err = capsys.readouterr().err
    assert code == 2, err
    line = err.strip().splitlines()[0]
    for w in words:
        assert w in line, line


def test_missing_config_file(tmp_path, capsys):
    assert certify.main([str(tmp_path / "nope.yaml")]) == 2
    assert "no such config file" in capsys.readouterr().err


@pytest.mark.slow
def test_bench_quick_result_line():
    env = dict(os.environ)
    env.setdefault("JAX_PLATFORMS", "cpu")
    r = subprocess.run([sys.executable, "bench/robustness.py", "--quick", "--samples", "256",
                        "--tumble-samples", "128", "--numpy", "2"], cwd=ROOT,
                       capture_output=True, text=True, timeout=600, env=env)
    assert r.returncode == 0, r.stderr
    last = r.stdout.strip().splitlines()[-1]
    assert last.startswith("RESULT push_samples_per_s=") and " tumble_steps_per_s=" in last
    push, tumble = (float(kv.split("=")[1]) for kv in last.split()[1:])
    assert push > 0 and tumble > 0
