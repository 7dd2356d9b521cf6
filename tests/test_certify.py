"""``nudge certify``: end to end through the console script, the run-folder
layout, resume, what a certificate claims, and bad configs."""
import os
import pathlib
import subprocess
import sys

import pandas as pd
import pytest

from robustness import tables
from robustness.certificates import VERDICTS
from sweeps import certify
from sweeps.parquet import read_metadata
from tests.commandline import nudge, nudge_here

ROOT = pathlib.Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "certify_triangle.yaml"
TABLES = ("samples", "summary", "plans", "certificates")


def _files(out, table):
    return sorted((out / table).rglob("*.parquet"))


@pytest.mark.slow
def test_example_end_to_end_layout_and_metadata(tmp_path):
    out = tmp_path / "out"
    r = nudge("certify", EXAMPLE, "--out", out, "--n-samples", "40", "--seed", "5", "--quiet")
    assert r.returncode in (0, 1), r.stderr
    # a quiet run's stderr is empty: nothing a library prints in a fresh process reaches
    # it (the other certifications run in the test's process, where only the command's
    # own lines can be seen)
    assert r.stderr == "", r.stderr
    # one folder per table, Hive-partitioned by config_id: pandas reads each as one frame
    frames = {t: pd.read_parquet(out / t) for t in TABLES}
    for t in TABLES:
        f = _files(out, t)[0]
        assert f.parent.name == "config_id=00000"
        md = read_metadata(f)
        assert md["table"] == t and md["seed"] == "5"
        # the metadata records the config as run, after the command-line overrides
        assert "n_samples: 40" in md["config"] and "seed: 5" in md["config"]
        assert (f.stat().st_mode & 0o044) == 0o044   # readable by others (umask 022)
    certs = frames["certificates"]
    assert certs["task"].tolist() == ["translate", "turn"]
    assert set(certs["verdict"]) <= set(VERDICTS)
    assert (frames["summary"]["n"] == 40).all()
    samples = frames["samples"]
    assert len(samples) == 80 and samples["sample_id"].max() == 39
    assert (samples["kind"] == "push").all() and samples["run_id"].nunique() == 1
    assert samples["dv_m"].map(len).eq(6).all()           # 3 vertices x (x, y), a list column
    assert str(frames["summary"]["bound_violated"].dtype) == "boolean"
    # every certificate states what it proves: the one-sided bound, the model, the samples
    for _, c in certs.iterrows():
        assert "limit_surface" in c["claim"] and "40 samples" in c["claim"]
        assert c["bound_model"].startswith("first-order")
    assert "translate" in r.stdout and "turn" in r.stdout
    assert r.returncode == (0 if (certs["verdict"] == "certified").all() else 1)
    # the same command resumes: nothing is recomputed, the tables are unchanged
    before = {t: pd.read_parquet(out / t) for t in TABLES}
    r2 = nudge_here("certify", EXAMPLE, "--out", out, "--n-samples", "40", "--seed", "5", "--quiet")
    assert r2.returncode == r.returncode, r2.stderr
    for t in TABLES:
        pd.testing.assert_frame_equal(pd.read_parquet(out / t), before[t])
    # another config on the same folder is refused before any work
    r3 = nudge_here("certify", EXAMPLE, "--out", out, "--n-samples", "41", "--quiet")
    assert r3.returncode == 2 and "another config" in r3.stderr


@pytest.mark.slow
def test_pd_read_parquet_on_run_folder_never_mixes_tables(tmp_path):
    out = tmp_path / "out"
    r = nudge_here("certify", EXAMPLE, "--out", out, "--n-samples", "8", "--quiet")
    assert r.returncode in (0, 1), r.stderr
    # tables live in their own folders; the run folder itself holds no Parquet file
    assert not list(out.glob("*.parquet"))


def _write(tmp_path, text):
    p = tmp_path / "cfg.yaml"
    p.write_text(text)
    return p


BASE = f"""part: {EXAMPLE.parent / 'biplus_stable.yaml'}
tolerances: {{tau_v: 1e-5}}
eps: {{pos_eps_m: 0.002, theta_eps_rad: 0.03}}
model: quasistatic      # the command's machinery (the example runs the default model)
tasks:
  - {{name: a, start: [0, 0, 0], goal: [0.05, 0.0, 30deg]}}
"""


def _input_error(r, *words):
    assert r.returncode == 2, (r.stdout, r.stderr)
    assert "Traceback" not in r.stderr and r.stdout == ""
    lines = r.stderr.strip().splitlines()
    assert lines and all(ln.startswith("error: ") for ln in lines), r.stderr
    for w in words:
        assert w in lines[0], lines[0]
    return lines[0]


@pytest.mark.slow
def test_unknown_key_exits_2(tmp_path):
    p = _write(tmp_path, BASE.replace("tau_v: 1e-5", "tau_v: 1e-5, tau_vv: 2"))
    line = _input_error(nudge("certify", p), "tau_vv", "allowed keys")
    assert "tau_com" in line
    p = _write(tmp_path, BASE + "colour: red\n")
    _input_error(nudge_here("certify", p), "colour", "top level")


@pytest.mark.parametrize("text,words", [
    (BASE.replace("tau_v: 1e-5", "tau_v: -1e-5"), ("tolerances.tau_v", ">= 0")),
    (BASE.replace("tau_v: 1e-5", "tau_v: .nan"), ("tolerances.tau_v", "finite")),
    (BASE.replace("pos_eps_m: 0.002", "pos_eps_m: 0"), ("eps.pos_eps_m", "> 0")),
    (BASE.replace("30deg", "thirty"), ("tasks[0].goal[2]", "deg")),
    (BASE + "required: {probability: 1.5}\n", ("required.probability",)),
    (BASE.replace("biplus_stable.yaml", "missing.yaml"), ("part", "missing.yaml")),
    (BASE.replace("tasks:\n", "tasks: []\nx:\n"), ("x",)),
    (BASE + "n_samples: lots\n", ("n_samples",)),
    (BASE + "friction: {mu_f: [0.8, 0.3]}\n", ("friction", "mu_f")),
], ids=["negative", "nan", "zero-eps", "bad-angle", "probability", "missing-part",
        "unknown-top-key", "n-samples", "inverted-range"])
def test_bad_configs_in_process(tmp_path, capsys, text, words):
    p = _write(tmp_path, text)
    code = certify.main([str(p), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == 2, err
    line = err.strip().splitlines()[0]
    for w in words:
        assert w in line, line
    assert not (tmp_path / "o").exists()   # nothing ran, nothing was written


def test_numbers_like_1e5_are_numbers(tmp_path):
    # YAML 1.1 reads 1e-5 as a string; nudge reads it as the number it is
    cfg, doc, text, part, tasks = certify.load(_write(tmp_path, BASE))
    assert cfg.tolerances.tau_v == 1e-5 and isinstance(doc["tolerances"]["tau_v"], float)


def test_missing_config_file(tmp_path, capsys):
    assert certify.main([str(tmp_path / "nope.yaml")]) == 2
    assert "no such config" in capsys.readouterr().err


@pytest.mark.slow
def test_nothing_perturbed_is_said(tmp_path):
    text = f"""part: {EXAMPLE.parent / 'rectangle.yaml'}
friction: {{mu_f: [0.8, 0.8], c: [0.005, 0.005]}}
eps: {{pos_eps_m: 0.002, theta_eps_rad: 0.03}}
n_samples: 5
tasks:
  - {{name: a, start: [0, 0, 0], goal: [0.05, 0.0, 0.0]}}
"""
    out = tmp_path / "o"
    r = nudge_here("certify", _write(tmp_path, text), "--out", out, "--quiet")
    assert r.returncode == 1, r.stderr
    c = pd.read_parquet(out / "certificates").iloc[0]
    assert c["verdict"] == "not certified" and c["reason"] == "nothing_perturbed"
    assert bool(c["nothing_perturbed"]) and "nothing was perturbed" in c["claim"]


@pytest.mark.slow
def test_too_few_samples_says_how_many_are_needed(tmp_path):
    text = BASE.replace("tau_v: 1e-5", "tau_v: 1e-7") + "required: {probability: 0.95}\n"
    out = tmp_path / "o"
    r = nudge_here("certify", _write(tmp_path, text), "--out", out, "--n-samples", "10", "--quiet")
    c = pd.read_parquet(out / "certificates").iloc[0]
    if c["n_success"] == 10:   # every sample succeeded: the answer is 'too few samples'
        assert r.returncode == 1
        assert c["reason"] == "too_few_samples" and c["samples_needed"] == 59
        assert "at least 59 successes without a failure are needed" in c["claim"]


@pytest.mark.slow
def test_non_convex_part_warns(tmp_path):
    text = """part:
  vertices: [[0, 0], [0.04, 0], [0.04, 0.02], [0.02, 0.005], [0, 0.02]]
tolerances: {tau_v: 1e-6}
eps: {pos_eps_m: 0.002, theta_eps_rad: 0.03}
n_samples: 4
tasks:
  - {name: a, start: [0, 0, 0], goal: [0.05, 0.0, 0.0]}
"""
    r = nudge_here("certify", _write(tmp_path, text), "--out", tmp_path / "o")
    assert r.returncode in (0, 1), r.stderr
    assert "warning: vertices: points [3] are not vertices of the convex hull" in r.stderr


@pytest.mark.slow
def test_auto_samples_grow_until_decided(tmp_path):
    text = BASE.replace("tau_v: 1e-5", "tau_v: 1e-7") + "required: {probability: 0.9}\n"
    out = tmp_path / "o"
    r = nudge_here("certify", _write(tmp_path, text), "--out", out, "--n-samples", "auto",
              "--max-samples", "200", "--quiet")
    assert r.returncode in (0, 1), r.stderr
    c = pd.read_parquet(out / "certificates").iloc[0]
    s = pd.read_parquet(out / "samples")
    # auto is sequential: 4 looks fixed in advance, from the fewest samples that could certify
    # at the per-look 1 - 0.05/4 (42 for 0.9), doubling, to the cap; Bonferroni over the looks
    assert list(c["look_counts"]) == [42, 84, 168, 200] and c["n_looks"] == 4
    assert c["procedure"] == "sequential_bonferroni" and c["look_confidence"] == 1 - 0.05 / 4
    assert c["n_samples"] == c["look_counts"][c["look"] - 1] and len(s) == c["n_samples"]
    assert s["sample_id"].tolist() == list(range(len(s)))
    assert "sequential: Bonferroni over 4 looks at n = 42, 84, 168, 200" in c["claim"]
    assert "98.75% confidence, 95% over all looks" in c["claim"] and "Bonferroni" in r.stdout
    if c["verdict"] != "certified":
        assert c["n_samples"] == 200 or c["reason"] == "below_requirement"


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
    vals = dict(kv.split("=") for kv in last.split()[1:])
    assert float(vals["push_samples_per_s"]) > 0 and float(vals["tumble_steps_per_s"]) > 0


def test_help_explains_units_and_exit_codes():
    r = nudge_here("certify", "--help")
    assert r.returncode == 0 and "metres" in r.stdout and "Exit status" in r.stdout


@pytest.mark.slow
def test_tumble_task_without_a_plan_has_zero_steps(tmp_path):
    text = f"""part: {EXAMPLE.parent / 'cube.yaml'}
tolerances: {{tau_v: 1e-5}}
planner: {{tumble_eps: 1e-3}}
eps: {{pos_eps_m: 0.0025, theta_eps_rad: 0.012}}
n_samples: 8
tasks:
  - {{name: roll_two, goal: [0.2, 0.0, 0.0, 0]}}
  - {{name: off_lattice, goal: [0.1, 0.1, 90deg, 0]}}
"""
    out = tmp_path / "o"
    r = nudge_here("certify", _write(tmp_path, text), "--out", out, "--quiet")
    assert r.returncode == 1, r.stderr
    c = pd.read_parquet(out / "certificates").set_index("task")
    assert c.loc["off_lattice", "verdict"] == "no plan" and c.loc["off_lattice", "plan_steps"] == 0
    assert c.loc["off_lattice", "plan_verdict"] == "no_plan"
    assert c.loc["roll_two", "plan_steps"] > 0 and c.loc["roll_two", "kind"] == "tumble"
    s = pd.read_parquet(out / "summary").set_index("task")
    assert s.loc["off_lattice", "n"] == 0 and s.loc["off_lattice", "dominant_failure_mode"] == "no_plan"
    # column types never depend on the data: the no-plan task's file reads back with the
    # planned task's dtypes, column for column; counts are 0 (not null) without samples
    files = {f.name: pd.read_parquet(f) for f in _files(out, "summary")}
    planned, empty = files["part-t0000.parquet"], files["part-t0001.parquet"]
    assert empty["task"].iloc[0] == "off_lattice"
    assert dict(empty.dtypes) == dict(planned.dtypes)
    ints = [f.name for f in tables.SUMMARY_SCHEMA if f.type == "int64"]
    assert len(ints) >= 16 and all(str(s[c].dtype) == "int64" for c in ints), s.dtypes[ints]
    assert s.loc["off_lattice", "n_none"] == 0 and s.loc["off_lattice", "n_in_bound_model"] == 0
    assert s.loc["off_lattice", "worst_sample_id"] == -1
    assert s.loc["roll_two", "n_none"] == s.loc["roll_two", "n_success"] == 8
    p = pd.read_parquet(out / "plans").set_index("task")
    assert not p.loc["off_lattice", "planned"] and "not_solvable" in p.loc["off_lattice", "reason"]


def test_a_physics_certification_of_a_hundred_thousand_samples_is_refused_at_once(tmp_path):
    """Issue 41: 10^5 MuJoCo samples (a slipped zero) ran 81 s silently and died by
    SIGSEGV; now one line naming the estimate and --yes, exit 2, nothing written."""
    cfg = tmp_path / "c.yaml"
    text = EXAMPLE.read_text().replace("part: biplus_stable.yaml",
                                       f"part: {ROOT / 'examples' / 'biplus_stable.yaml'}")
    cfg.write_text(text + "model: mujoco\n" if "\nmodel:" not in text
                   else text.replace("model: limit_surface", "model: mujoco"))
    r = nudge_here("certify", cfg, "--n-samples", "100000", "--out", tmp_path / "out")
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "estimated at about" in lines[0] and "--yes" in lines[0], lines
    assert "model mujoco" in lines[0]
    assert not (tmp_path / "out").exists()


MARGIN_SEARCH = f"""part: {ROOT / 'examples' / 'biplus_stable.yaml'}
tolerances: {{tau_v: 1.5e-4, tau_com: 3.0e-4}}
friction: {{mu_f: [3.0, 4.0], support: any}}
execution: {{start_xy: 5.0e-4, start_theta: 0.01, fence_angle: 0.003}}
eps: {{pos_eps_m: 0.003, theta_eps_rad: 0.05}}
required: {{probability: 0.97}}
n_samples: 300
model: quasistatic
margin_search: {{margins_deg: [3, 7], safety_factors: [1.15, 2.0], n_samples: 200}}
tasks:
  - {{name: turn, start: [0, 0, 0], goal: [0.10, 0.05, 60deg]}}
"""


@pytest.mark.slow
def test_the_margin_search_recommends_what_a_re_run_certifies(tmp_path):
    """The triangle's turn at 7 deg and 1.15 does not reach 0.97 (288/300); the
    margin search judges the grid on its own draws (3 deg / 1.15 fails there,
    3 deg / 2.0 passes), certifies that plan on the task's draws and recommends
    it; re-run with that setting, ``nudge certify`` draws the same samples and
    states the same claim, word for word."""
    cfg = tmp_path / "search.yaml"
    cfg.write_text(MARGIN_SEARCH)
    r = nudge_here("certify", cfg, "--out", tmp_path / "a")
    assert r.returncode == 1, (r.stdout, r.stderr)
    c = pd.read_parquet(tmp_path / "a" / "certificates").iloc[0]
    assert c["verdict"] == "not certified"
    assert (c["recommended_margin_deg"], c["recommended_safety_factor"]) == (3.0, 2.0)
    assert "margin 3 deg, safety factor 2: 200/200 on the search draws" in c["note"]
    nxt = next(ln for ln in r.stdout.splitlines() if "next:" in ln)
    assert "planner: {margin_deg: 3, safety_factor: 2}" in nxt
    again = tmp_path / "again.yaml"
    again.write_text(MARGIN_SEARCH.replace(
        "margin_search: {margins_deg: [3, 7], safety_factors: [1.15, 2.0], n_samples: 200}",
        "planner: {margin_deg: 3, safety_factor: 2.0}"))
    r = nudge_here("certify", again, "--out", tmp_path / "b", "--quiet")
    assert r.returncode == 0, (r.stdout, r.stderr)
    b = pd.read_parquet(tmp_path / "b" / "certificates").iloc[0]
    assert b["verdict"] == "certified"
    assert f"on the task's own draws, not the search's: {b['claim']}" in c["note"]


def test_recommend_margins_judges_each_setting_and_skips_the_unplannable():
    """Settings without a plan are recorded and skipped; none passing gives no
    recommendation; bad arguments are refused before any work."""
    import jax

    from robustness import Requirement, Sampler, recommend_margins

    calls = []

    def replan(m, sf):
        calls.append((m, sf))
        return None

    rec, trials = recommend_margins(replan, [(3, 1.15), (7, 2.0)], Sampler(), 8,
                                    jax.random.key(0), Requirement())
    assert rec is None and calls == [(3.0, 1.15), (7.0, 2.0)]
    assert [(t.margin_deg, t.safety_factor, t.n) for t in trials] == [(3.0, 1.15, 0), (7.0, 2.0, 0)]
    with pytest.raises(ValueError, match="n: expected an integer >= 1"):
        recommend_margins(replan, [(3, 1.15)], Sampler(), 0, jax.random.key(0))
    with pytest.raises(ValueError, match="requirement"):
        recommend_margins(replan, [(3, 1.15)], Sampler(), 8, jax.random.key(0), 0.9)
