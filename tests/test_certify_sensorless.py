"""Sensorless tasks (issue 40) in certify configs and studies, through the
command a user types: ``start: {heading: any, region: [...]}`` planned with
:func:`planning.plan_sensorless`, its Monte Carlo drawing the start uniformly
over the heading interval and the region, and a certificate that says so; bad
input refused in one line (exit 2) before any work; known-start tables unchanged."""
import hashlib
import math
import pathlib

import numpy as np
import pandas as pd
import pytest

from tests.commandline import nudge_here

ROOT = pathlib.Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"

KNOWN = f"""part: {EXAMPLES / 'biplus_stable.yaml'}
tolerances: {{tau_v: 2.0e-5, tau_com: 1.0e-4}}
friction: {{mu_f: [0.3, 0.8], support: any}}
execution: {{start_xy: 5.0e-4, start_theta: 0.01, fence_angle: 0.002, distance_abs: 1.0e-4}}
eps: {{pos_eps_m: 0.003, theta_eps_rad: 0.05}}
n_samples: 16
seed: 3
model: quasistatic          # the digest below was taken under it (before the default changed)
tasks:
  - {{name: turn, start: [0, 0, 0], goal: [0.10, 0.05, 60deg]}}
"""

#: digest of the known-start task's samples (final poses rounded to 1e-12, success,
#: failure mode, start offsets) as the code before sensorless tasks wrote them; since
#: December 2026 the pad and rim stand on their feet alone (the pad's and the rim's c
#: changed; with kernels.support.FEET_AT_CORNERS the old digest 326088ff... again)
KNOWN_DIGEST = "2c315eaa9d7f5147316488929fa346b34e4357b58bfd6939a78fa7086ad1e3ab"


def _digest(samples: pd.DataFrame) -> str:
    s = samples.sort_values("sample_id")
    h = hashlib.sha256()
    for c in ("final_x_m", "final_y_m", "final_theta_rad", "start_dx_m", "start_dy_m",
              "start_dtheta_rad"):
        h.update(np.round(s[c].to_numpy(np.float64), 12).tobytes())
    h.update(s["success"].to_numpy(bool).tobytes())
    h.update("|".join(s["failure_mode"].astype(str)).encode())
    return h.hexdigest()


@pytest.mark.slow
def test_known_start_tables_unchanged(tmp_path):
    p = tmp_path / "known.yaml"
    p.write_text(KNOWN)
    out = tmp_path / "o"
    r = nudge_here("certify", p, "--out", out, "--quiet")
    assert r.returncode in (0, 1), r.stderr
    d = _digest(pd.read_parquet(out / "samples"))
    assert d == KNOWN_DIGEST, d


# ---------------------------------------------------------------- the example, end to end
EXAMPLE = EXAMPLES / "certify_sensorless.yaml"


@pytest.mark.slow
def test_example_certifies_from_the_start_set(tmp_path):
    """``nudge certify examples/certify_sensorless.yaml``: both tasks planned with
    the sensorless planner, sampled from starts drawn over their heading interval
    and region, certified, and the claim names the start set."""
    import json

    out = tmp_path / "o"
    r = nudge_here("certify", EXAMPLE, "--out", out, "--quiet")
    assert r.returncode == 0, (r.stdout, r.stderr)
    certs = pd.read_parquet(out / "certificates").sort_values("task").reset_index(drop=True)
    assert certs["task"].tolist() == ["any_heading", "heading_interval"]
    assert (certs["verdict"] == "certified").all(), certs["claim"].tolist()
    assert (certs["n_samples"] == 60).all() and (certs["model"] == "limit_surface").all()
    any_claim, interval_claim = certs["claim"]
    assert any_claim.startswith("from any heading in [-180, 180] deg and any position in "
                                "[0, 0.04] x [0, 0.04] m: P(success) >= "), any_claim
    assert interval_claim.startswith("from any heading in [-20, 40] deg and any position in "
                                     "[0, 0.04] x [0, 0.04] m: "), interval_claim
    for c in certs["claim"]:
        assert "95% confidence" in c and "60 samples of the limit_surface model" in c
        assert "start heading and position (uniform)" in c and "start pose" not in c
    assert "from any heading in [-180, 180] deg" in r.stdout
    # the plans: sensorless, three phases, the reference start (region centre, interval middle)
    plans = pd.read_parquet(out / "plans").sort_values("task").reset_index(drop=True)
    assert (plans["plan_class"] == "sensorless").all() and plans["planned"].all()
    assert plans["start_x_m"].tolist() == [0.02, 0.02] and plans["start_y_m"].tolist() == [0.02, 0.02]
    assert plans["start_theta_rad"].tolist() == pytest.approx([0.0, math.radians(10.0)])
    for js, steps in zip(plans["plan_json"], plans["n_steps"]):
        d = json.loads(js)
        phases = [p["phase"] for p in d["pushes"]]
        assert len(phases) == steps and phases[-1] == "pose" and "register" in phases
        assert phases == sorted(phases, key=["orient", "register", "pose"].index)
    assert certs["plan_steps"].tolist() == plans["n_steps"].tolist()
    # the samples start all over the start set (the offsets from the reference start)
    s = pd.read_parquet(out / "samples")
    for task, half in (("any_heading", math.pi), ("heading_interval", math.radians(30.0))):
        t = s[s["task"] == task]
        assert len(t) == 60 and t["success"].mean() >= 0.95   # certified at 0.9 / 95%
        dx, dy, dth = (t[c].to_numpy() for c in ("start_dx_m", "start_dy_m", "start_dtheta_rad"))
        assert np.all(np.abs(dx) <= 0.02) and np.all(np.abs(dy) <= 0.02)
        assert np.all(np.abs(dth) <= half)
        # spread over the set, not one pose plus a small error
        assert np.ptp(dx) > 0.02 and np.ptp(dy) > 0.02 and np.ptp(dth) > half
    # the rectangle looks the same turned by pi: headings reported within half a period
    assert np.all(np.abs(s["err_theta_rad"]) < 0.05)


# ---------------------------------------------------------------- bad input: one line, exit 2
SENSORLESS = f"""part: {EXAMPLES / 'rectangle.yaml'}
tolerances: {{tau_v: 1e-5}}
friction: {{mu_f: [0.8, 1.5]}}
eps: {{pos_eps_m: 0.003, theta_eps_rad: 0.05}}
n_samples: 30
tasks:
  - {{name: a, start: {{heading: any, region: [0, 0.04, 0, 0.04]}}, goal: [0.15, 0.1, 30deg]}}
"""


@pytest.mark.parametrize("edit,words", [
    (("[0, 0.04, 0, 0.04]", "[0.04, 0, 0, 0.04]"),
     ("tasks[0].start.region:", "xmin <= xmax", "swap the bounds")),
    (("heading: any", "heading: [40deg, -20deg]"),
     ("tasks[0].start.heading:", "lo <= hi", "swap the bounds")),
    (("heading: any", "heading: [0, 400deg]"), ("tasks[0].start.heading:", "lo + 2 pi")),
    (("heading: any", "heading: sideways"), ("tasks[0].start.heading:", "any or [lo, hi]")),
    (("heading: any", "heading: [0, ten]"), ("tasks[0].start.heading[1]:", "deg")),
    (("heading: any, ", ""), ("tasks[0].start.heading:", "required", "any")),
    ((", region: [0, 0.04, 0, 0.04]", ""), ("tasks[0].start.region:", "required")),
    (("region: [0, 0.04, 0, 0.04]", "region: [0, 0.04, 0]"), ("tasks[0].start.region:",)),
    (("region:", "regoin:"), ("tasks[0].start:", "regoin", "allowed keys: heading, region")),
    (("tasks:", "design: {n_samples: 100}\ntasks:"), ("design:", "known start")),
    (("rectangle.yaml", "cube.yaml"), ("tasks[0].start:", "tumble task", "[x, y, theta, face]")),
], ids=["region-inverted", "heading-inverted", "heading-too-wide", "heading-word",
        "heading-angle", "no-heading", "no-region", "region-3", "misspelt-key",
        "design", "tumble-part"])
def test_bad_sensorless_starts_are_one_line_exit_2(tmp_path, edit, words):
    p = tmp_path / "cfg.yaml"
    p.write_text(SENSORLESS.replace(*edit))
    out = tmp_path / "o"
    r = nudge_here("certify", p, "--out", out)
    assert r.returncode == 2, (r.stdout, r.stderr)
    assert "Traceback" not in r.stderr and r.stdout == ""
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), r.stderr
    for w in words:
        assert w in lines[0], lines[0]
    assert not out.exists()   # refused before any work


def test_synthesize_flag_with_a_sensorless_task_is_refused(tmp_path):
    p = tmp_path / "cfg.yaml"
    p.write_text(SENSORLESS)
    r = nudge_here("certify", p, "--synthesize", "--out", tmp_path / "o")
    assert r.returncode == 2 and "synthesize:" in r.stderr and "--synthesize" in r.stderr
    assert "Traceback" not in r.stderr


# ---------------------------------------------------------------- a study
STUDY = f"""study: sensorless
kind: push
part: {EXAMPLES / 'rectangle.yaml'}
tasks:
  - {{name: known, start: [0, 0, 0], goal: [0.15, 0.1, 30deg]}}
  - {{name: unknown, start: {{heading: [-20deg, 40deg], region: [0, 0.04, 0, 0.04]}}, goal: [0.15, 0.1, 30deg]}}
tolerances: {{tau_v: 2e-5}}
friction: {{mu_f: [0.8, 1.5]}}
eps: {{pos_eps_m: 0.003, theta_eps_rad: 0.05}}
model: exact
samples: 16
seed: 1
report: false
"""


@pytest.mark.slow
def test_a_study_plans_and_samples_a_sensorless_task(tmp_path):
    from sweeps import run

    from tests.commandline import in_process

    p = tmp_path / "s.yaml"
    p.write_text(STUDY)
    out = tmp_path / "o"
    r = in_process(run.main, p, "--out", out, "--quiet")
    assert r.returncode == 0, (r.stdout, r.stderr)
    plans = pd.read_parquet(out / "plans").set_index("task")
    assert plans.loc["unknown", "plan_class"] == "sensorless"
    assert plans.loc["known", "plan_class"] != "sensorless"
    s = pd.read_parquet(out / "samples")
    u = s[s["task"] == "unknown"]
    assert len(u) == 16 and u["success"].all()
    assert np.ptp(u["start_dtheta_rad"]) > math.radians(20) and np.ptp(u["start_dx_m"]) > 0.01
    k = s[s["task"] == "known"]
    assert (k["start_dx_m"] == 0).all()   # no start error configured: the known start as given


def test_a_study_refuses_an_inverted_region_in_one_line(tmp_path):
    from sweeps import run

    from tests.commandline import in_process

    p = tmp_path / "s.yaml"
    p.write_text(STUDY.replace("region: [0, 0.04, 0, 0.04]", "region: [0, 0.04, 0.04, 0]"))
    r = in_process(run.main, p, "--out", tmp_path / "o")
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "tasks[1].start.region:" in lines[0] and "ymin <= ymax" in lines[0]
    assert "Traceback" not in r.stderr


# ---------------------------------------------------------------- the Monte Carlo itself
@pytest.mark.slow
def test_sensorless_monte_carlo_draws_its_starts_over_the_start_set():
    """``robustness.evaluate`` of a SensorlessPlan: the starts uniform over the
    heading interval and the region (not the plan's reference start plus an
    error), reproducible from the key; with nothing else perturbed the exact
    replay reaches the goal from every one, and the start is what was perturbed."""
    import jax

    from planning import plan_sensorless
    from robustness import Sampler, SuccessCriterion, evaluate, perturbed_sources, start_set
    from robustness.sensorless import draw_starts

    rect = np.array([[0.0, 0.0], [0.04, 0.0], [0.04, 0.02], [0.0, 0.02]])
    region, heading = (0.0, 0.04, 0.01, 0.03), (-0.3, 0.5)
    plan = plan_sensorless(rect, (0.15, 0.1, 0.5), region, heading, n_headings=36, n_side=2)
    crit = SuccessCriterion(pos_eps_m=1e-3, theta_eps_rad=0.01)
    key = jax.random.key(7)
    ev = evaluate(plan, Sampler(), 64, key, crit, "exact", bound=False)
    s = ev.samples
    assert s["success"].all(), s["failure_mode"].value_counts()
    starts = draw_starts(plan, key, 64)
    ref = np.asarray(plan.start)
    assert ref.tolist() == pytest.approx([0.02, 0.02, 0.1])
    got = np.stack([s["start_dx_m"], s["start_dy_m"], s["start_dtheta_rad"]], axis=1) + ref
    np.testing.assert_allclose(got, starts, atol=1e-15)
    assert starts[:, 0].min() >= 0.0 and starts[:, 0].max() <= 0.04
    assert starts[:, 1].min() >= 0.01 and starts[:, 1].max() <= 0.03
    assert starts[:, 2].min() >= -0.3 and starts[:, 2].max() <= 0.5
    assert np.ptp(starts[:, 2]) > 0.6 and np.ptp(starts[:, 0]) > 0.03   # spread, not a point
    again = evaluate(plan, Sampler(), 64, key, crit, "exact", bound=False).samples
    pd.testing.assert_frame_equal(again, s)
    assert perturbed_sources(Sampler(), "push", "exact", sensorless=True) == (
        "start heading and position (uniform)",)
    assert start_set(plan) == ("any heading in [-17.19, 28.65] deg and any position in "
                               "[0, 0.04] x [0.01, 0.03] m")
    # no analytic bound about one start for a start set
    assert math.isnan(ev.summary["bound_position_m"])


@pytest.mark.slow
def test_a_start_error_is_not_applied_and_the_certificate_says_so(tmp_path):
    p = tmp_path / "cfg.yaml"
    p.write_text(SENSORLESS.replace("tasks:", "execution: {start_xy: 5.0e-4}\nmodel: exact\ntasks:"))
    out = tmp_path / "o"
    r = nudge_here("certify", p, "--out", out, "--quiet")
    assert r.returncode == 0, (r.stdout, r.stderr)
    c = pd.read_parquet(out / "certificates").iloc[0]
    assert "start_xy / start_theta not applied" in c["note"]
    assert c["claim"].startswith("from any heading in [-180, 180] deg and any position in "
                                 "[0, 0.04] x [0, 0.04] m: P(success) >= ")
    assert "30 samples of the exact model" in c["claim"]
    s = pd.read_parquet(out / "samples")
    assert np.all(np.abs(s["start_dx_m"]) <= 0.02) and np.ptp(s["start_dx_m"]) > 0.01


@pytest.mark.slow
def test_a_failing_sensorless_task_gets_the_remedies_it_can_use(tmp_path):
    """The triangle slips along fences of friction 0.3-0.8 (the orient and register
    pushes assume it sticks): not certified, slip; the margin search re-plans it
    sensorlessly; the next steps name no --synthesize / --design (refused for it)."""
    p = tmp_path / "cfg.yaml"
    p.write_text(f"""part: {EXAMPLES / 'biplus_stable.yaml'}
tolerances: {{tau_v: 2.0e-5}}
friction: {{mu_f: [0.3, 0.8]}}
eps: {{pos_eps_m: 0.003, theta_eps_rad: 0.05}}
n_samples: 30
margin_search: {{margins_deg: [5, 9], safety_factors: [1.15], n_samples: 20}}
tasks:
  - {{name: a, start: {{heading: any, region: [0, 0.04, 0, 0.04]}}, goal: [0.15, 0.1, 30deg]}}
""")
    out = tmp_path / "o"
    r = nudge_here("certify", p, "--out", out, "--quiet")
    assert r.returncode == 1, (r.stdout, r.stderr)
    c = pd.read_parquet(out / "certificates").iloc[0]
    assert c["verdict"] == "not certified" and c["dominant_failure_mode"] == "slip"
    assert c["claim"].startswith("from any heading in [-180, 180] deg")
    assert "margin / safety factor" in c["note"]
    nxt = [ln for ln in r.stdout.splitlines() if "next:" in ln]
    assert nxt and "friction.mu_f" in nxt[0]
    assert "--synthesize" not in r.stdout and "--design" not in r.stdout


@pytest.mark.slow
def test_mujoco_rolls_sensorless_plans_out_from_the_start_set(tmp_path):
    """``model: mujoco`` on a sensorless task: each sample is the plan from its
    drawn start rolled out in MuJoCo (contact strokes), its start read back from
    the table, the claim stating the physics model; beside it the exact
    kinematics' verdict on the same draws."""
    p = tmp_path / "cfg.yaml"
    p.write_text(SENSORLESS.replace("tasks:", "model: mujoco\nfriction: {mu_f: [0.8, 1.5], "
                                               "support: rigid}\ntasks:")
                 .replace("friction: {mu_f: [0.8, 1.5]}\n", "").replace("n_samples: 30", "n_samples: 1"))
    out = tmp_path / "o"
    r = nudge_here("certify", p, "--out", out, "--quiet")
    assert r.returncode in (0, 1), (r.stdout, r.stderr)
    cert = pd.read_parquet(out / "certificates").iloc[0]
    assert cert["model"] == "mujoco" and cert["n_samples"] == 1
    assert "from any heading in [-180, 180] deg" in cert["claim"]
    s = pd.read_parquet(out / "samples").iloc[0]
    assert s["model"] == "mujoco" and s["kind"] == "sensorless"
    assert abs(s["start_dx_m"]) <= 0.02 and abs(s["start_dy_m"]) <= 0.02
    assert abs(s["err_theta_rad"]) < math.pi / 2    # folded: the rectangle's period is pi
    assert not pd.isna(s["success_exact"])           # the kinematics on the same draw
    assert bool(s["success"]) is (s["failure_mode"] == "none")


@pytest.mark.slow
def test_the_library_certifies_a_sensorless_plan_as_the_command_line_does(tmp_path):
    """``robustness.certify`` on the task's key draws the blocks ``nudge certify``
    draws and states the same claim, start set first (it named no start set and
    sized its blocks apart)."""
    import jax

    from robustness import certify
    from sweeps import certify as cli
    from sweeps.tasks import plan_task

    p = tmp_path / "cfg.yaml"
    p.write_text(SENSORLESS)
    r = nudge_here("certify", p, "--out", tmp_path / "o", "--quiet")
    assert r.returncode in (0, 1), (r.stdout, r.stderr)
    claim = pd.read_parquet(tmp_path / "o" / "certificates").iloc[0]["claim"]
    cfg, _, _, part, tasks = cli.load(p)
    _, start, goal = tasks[0]
    plan, _ = plan_task(part, start, goal, cfg.planner, cfg.eps)
    cert, _, _ = certify(plan, cfg.sampler(), jax.random.fold_in(jax.random.key(cfg.seed), 0),
                         cfg.requirement(), samples=30, model=cfg.model_spec(cfg.model, None))
    assert cert.claim == claim and claim.startswith("from any heading in [-180, 180] deg")
