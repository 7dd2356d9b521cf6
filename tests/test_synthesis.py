"""Robust plan synthesis (``robustness.synthesis``, ``nudge certify --synthesize``):
the batched scores are evaluate()'s on the same draws, a plan that should win
wins, the selection is biased and the certificate is taken on fresh draws."""
import dataclasses
import itertools
import pathlib
import types
import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pandas as pd
import pytest

from planning import plan_alternatives, plan_pose
from robustness import (ExecutionTolerance, FrictionRange, GeometryTolerance, Requirement, Sampler,
                        Selection, SuccessCriterion, evaluate, stats)
from robustness.evaluation import goal_errors
from robustness.replay import run_push
from robustness.synthesis import (Scores, push_candidates, score_candidates, select,
                                  selection_key, synthesize, tiebreak_key, veto_key)
from tests.commandline import nudge_here

ROOT = pathlib.Path(__file__).resolve().parents[1]
# the biplus-stable triangle of examples/biplus_stable.yaml and the tolerances of
# examples/certify_triangle.yaml
TRIANGLE = np.array([[0.0, 0.0], [0.1, 0.0], [0.03, 0.06]])
SAMPLER = Sampler(GeometryTolerance(tau_v=2e-5, tau_com=1e-4),
                  FrictionRange(mu_f=(0.3, 0.8), mu_s=(0.2, 0.5), support="any"),
                  ExecutionTolerance(start_xy=5e-4, start_theta=0.01, fence_angle=0.002,
                                     distance_abs=1e-4, distance_rel=0.005))
EPS = dict(criterion=SuccessCriterion(pos_eps_m=0.003, theta_eps_rad=0.05))
REQ = Requirement(criterion=EPS["criterion"])
START, TURN = (0.0, 0.0, 0.0), (0.10, 0.05, np.pi / 3)
SMALL = dict(margins_deg=(3.0, 7.0, 20.0), safety_factors=(1.15, 2.0), strategies=("search",),
             per_setting=2)


def _part():
    from sweeps.study import load_part_ref

    p = load_part_ref("biplus_stable", ROOT / "examples")
    return np.asarray(p.vertices), p.com


def test_alternatives_are_distinct_verified_plans_the_planners_first():
    V, com = _part()
    plans = plan_alternatives(V, START, TURN, com, limit=6)
    first = plan_pose(V, START, TURN, com)
    assert plans[0].pushes == first.pushes
    assert 2 <= len(plans) <= 6
    sigs = {tuple((p.edge, round(p.distance, 9)) for p in pl.pushes) for pl in plans}
    assert len(sigs) == len(plans)
    for pl in plans:   # replayed by the exact kinematics: within 1e-9 of the goal
        assert pl.final_error[0] <= 1e-9 * 0.2 and pl.final_error[1] <= 1e-8
    with pytest.raises(ValueError, match="limit"):
        plan_alternatives(V, START, TURN, com, limit=0)


@pytest.mark.slow
def test_batched_scores_are_evaluates_on_the_same_draws():
    V, com = _part()
    cands, _ = push_candidates(V, START, TURN, com, **SMALL)
    plans = [c.plan for c in cands]
    n, key = 300, jax.random.key(3)
    s = score_candidates(plans, SAMPLER, n, key, REQ)
    P = max(p.n_pushes for p in plans)
    longest = int(np.argmax([p.n_pushes for p in plans]))
    # the longest candidate sees exactly the draws evaluate() draws for it
    ev = evaluate(plans[longest], SAMPLER, n, key, **EPS)
    assert np.array_equal(ev.columns["success"], s.success[longest])
    # every other candidate: its pushes see the first of the same per-push errors
    with jax.enable_x64(True):
        from kernels import polygon as pg

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            body = pg.make_polygon(V, com).body
        draws = SAMPLER.sample(key, n, body=body, dtype=jnp.float64, n_vertices=3, dim=2,
                               n_pushes=P)
        for k in range(len(plans)):
            Pk = plans[k].n_pushes
            e = draws.params.execution
            cut = dataclasses.replace(e, fence_angle=e.fence_angle[:, :Pk],
                                      distance_rel=e.distance_rel[:, :Pk],
                                      distance_abs=e.distance_abs[:, :Pk])
            dk = dataclasses.replace(draws, params=dataclasses.replace(draws.params,
                                                                       execution=cut))
            _, _, r = run_push(plans[k], dk, "quasistatic", jnp.float64, 4096)
            _, _, _, ep, et = goal_errors(r.x, r.y, r.theta, plans[k].goal)
            ok = EPS["criterion"].success(ep, et, ~r.changed.astype(bool) & ~r.truncated.astype(bool))
            assert np.array_equal(ok, s.success[k]), k
    assert np.allclose(s.ci_low, [stats.one_sided_lower(int(x), n, 0.95) for x in s.n_success])


@pytest.mark.slow
def test_a_plan_that_should_win_wins():
    # the default plan of the 60-degree turn fails most samples at fence friction 0.3
    # (its reorient pushes slip); synthesis must find one that does not
    V, com = _part()
    # (under the fast model: the faithful one is tested by the shortlist test below)
    syn = synthesize(V, START, TURN, com, selection=Selection(SAMPLER, 400, jax.random.key(0)),
                     requirement=REQ, model="quasistatic", **SMALL)
    k = syn.scores.n_success
    assert syn.candidates[0].plan.pushes == plan_pose(V, START, TURN, com).pushes
    assert k[syn.chosen] == k.max() and k[0] < 0.5 * 400 and k[syn.chosen] > 0.95 * 400
    # and it holds on fresh draws (not the ones it was chosen on)
    fresh = evaluate(syn.plan, SAMPLER, 400, jax.random.key(99), **EPS)
    default = evaluate(syn.candidates[0].plan, SAMPLER, 400, jax.random.key(99), **EPS)
    assert fresh.summary["n_success"] > 0.95 * 400 > 2 * default.summary["n_success"]


def test_select_objectives_and_ties():
    success = np.zeros((4, 100), bool)
    success[0, :90] = True      # the default: 90
    success[1, :99] = True      # 99, long
    success[2, :100] = True     # 100, longer still
    success[3, :95] = True      # 95, the shortest
    low = np.array([stats.one_sided_lower(int(k), 100, 0.95) for k in success.sum(1)])
    s = Scores(success, low, np.array([0.3, 0.5, 0.6, 0.2]), np.array([3, 5, 6, 2]), 0.95)
    i, why = select(s, "max_lower_bound")
    assert i == 1 and "within one success" in why    # 99 ties 100 within one; the shorter
    i, why = select(s, "shortest_certifying", Requirement(0.88))
    assert i == 3 and "shortest" in why               # 95/100 reaches 0.88: the shortest
    i, why = select(s, "shortest_certifying", Requirement(0.999))
    assert i == 1 and "no candidate" in why
    with pytest.raises(ValueError, match="objective"):
        select(s, "best")


def test_selection_is_biased_so_the_certificate_uses_fresh_draws():
    # constructed case: 40 candidates all succeed with probability 0.8, independently;
    # the best of them on the selection draws looks much better than 0.8
    rng = np.random.default_rng(0)
    K, n, p = 40, 200, 0.8
    chosen_rates, fresh_rates = [], []
    for _ in range(20):
        success = rng.random((K, n)) < p
        low = np.array([stats.one_sided_lower(int(k), n, 0.95) for k in success.sum(1)])
        s = Scores(success, low, np.ones(K), np.ones(K, int), 0.95)
        i, _ = select(s)
        chosen_rates.append(success[i].mean())
        fresh_rates.append((rng.random(n) < p).mean())   # the chosen one, on fresh draws
    assert np.mean(chosen_rates) > p + 0.04            # optimistic: the maximum of 40
    assert abs(np.mean(fresh_rates) - p) < 0.02        # unbiased
    # the selection's, the tie-break's and the veto's streams are none of the
    # certification blocks' streams nor each other's
    key = jax.random.fold_in(jax.random.key(0), 1)
    keys = [k(key) for k in (selection_key, tiebreak_key, veto_key)]
    keys += [jax.random.fold_in(key, b) for b in range(4)]
    streams = [np.asarray(jax.random.bits(k, (1000,), jnp.uint32)) for k in keys]
    for s, t in itertools.combinations(streams, 2):
        assert not np.any(np.isin(s, t))
        assert abs(np.corrcoef(s.astype(float), t.astype(float))[0, 1]) < 0.1
    # the tie-break's stream as results written before it had a name drew it
    assert np.array_equal(jax.random.key_data(tiebreak_key(key)),
                          jax.random.key_data(jax.random.fold_in(selection_key(key), 1)))


def _config(tmp_path, extra=""):
    text = (ROOT / "examples" / "certify_triangle.yaml").read_text()
    text = text.replace("part: biplus_stable.yaml", f"part: {ROOT / 'examples' / 'biplus_stable.yaml'}")
    text = text.replace("n_samples: 300", "n_samples: 120")
    cfg = tmp_path / "c.yaml"
    cfg.write_text(text + extra)
    return cfg


@pytest.mark.slow
def test_certify_synthesize_end_to_end(tmp_path):
    cfg = _config(tmp_path, "synthesize:\n  n_samples: 160\n  margins_deg: [3, 20]\n"
                            "  safety_factors: [1.15, 2.0]\n  strategies: [search]\n"
                            "  per_setting: 2\n  enabled: false\n  confirm_samples: 2\n"
                            "  veto_samples: 2\n")
    out = tmp_path / "out"
    r = nudge_here("certify", cfg, "--synthesize", "--out", out, "--quiet")
    assert r.returncode in (0, 1), r.stderr
    assert "Traceback" not in r.stderr and "warning" not in r.stderr
    certs = pd.read_parquet(out / "certificates")
    cands = pd.read_parquet(out / "candidates")
    plans = pd.read_parquet(out / "plans")
    for task in ("translate", "turn"):
        c = certs[certs.task == task].iloc[0]
        g = cands[cands.task == task]
        assert g["chosen"].sum() == 1 and c["n_candidates"] == len(g) > 5
        ch = g[g.chosen].iloc[0]
        assert (g["candidate"] == 0).any() and ch["n_success"] >= g[g.candidate == 0].iloc[0]["n_success"]
        assert g["bound_position_m"].notna().all() and (g["n_steps"] >= 1).all()
        # the certified plan is the chosen one; the verdict's samples are not the selection's
        assert plans[plans.task == task].iloc[0]["plan_json"] == ch["plan_json"]
        assert c["n_samples"] == 120 and c["selection_n_samples"] == 160 == ch["n_samples"]
        assert c["selection"].startswith("synthesized:") and "fresh draws" in c["selection"]
        # a choice other than the default plan was confirmed against it in MuJoCo
        assert (ch["candidate"] != 0) == ("confirmed against the default plan by MuJoCo "
                                          "rollouts on 2 common draws" in c["selection"])
        assert "fresh draws" in c["note"]
        assert c["selection_ci_low"] == pytest.approx(ch["ci_low_one_sided"])
        # the chosen plan rolled out in MuJoCo beside its certificate, said in the note
        assert c["physics_n_samples"] == 2 and 0 <= c["physics_n_success"] <= 2
        assert c["physics_agrees"] in (True, False)
        assert "MuJoCo on 2 fresh draws" in c["note"]
        assert ("DISAGREE" in c["note"]) == (not c["physics_agrees"])
    report = (out / "report.html").read_text()
    assert "<th class=\"l\">MuJoCo</th>" in report and "/2 " in report
    turn = certs[certs.task == "turn"].iloc[0]
    assert turn["selection_ci_low"] > turn["default_selection_ci_low"] + 0.3
    assert "synthesized:" in r.stdout


@pytest.mark.slow
def test_ctrl_c_during_synthesis_is_exit_130_with_no_certificate_or_report(tmp_path, monkeypatch):
    """Ctrl-C while the last task's candidates are scored: exit 130, the resume
    line, no certificate and no report (it exited 0 with an empty table before)."""
    import os
    import signal

    import sweeps.tasks

    real = sweeps.tasks.synthesize_for

    def interrupted(*a, **kw):
        os.kill(os.getpid(), signal.SIGINT)   # the StopFlag's handler: stop after this unit
        return real(*a, **kw)

    monkeypatch.setattr(sweeps.tasks, "synthesize_for", interrupted)
    text = _config(tmp_path).read_text()
    cfg = tmp_path / "one.yaml"
    cfg.write_text(text[:text.index("tasks:")] + "tasks:\n  - name: turn\n    start: [0, 0, 0]\n"
                   "    goal: [0.01, 0.0, 1.0]\n" + "synthesize:\n  n_samples: 50\n"
                   "  margins_deg: [3]\n  safety_factors: [1.15]\n  strategies: [search]\n")
    out = tmp_path / "out"
    r = nudge_here("certify", cfg, "--synthesize", "--out", out, "--quiet")
    assert r.returncode == 130, (r.stdout, r.stderr)
    assert "stopped: finished chunks are kept; run the same command again to resume" in r.stderr
    assert not (out / "certificates").exists() and not (out / "report.html").exists()
    assert "results:" not in r.stdout


def test_certify_synthesize_bad_field_is_one_line(tmp_path):
    cfg = _config(tmp_path, "synthesize:\n  objective: best\n")
    r = nudge_here("certify", cfg, "--out", tmp_path / "o")
    assert r.returncode == 2
    lines = [x for x in r.stderr.splitlines() if x.strip()]
    assert len(lines) == 1 and "synthesize.objective" in lines[0], r.stderr
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_tumble_candidates_are_scored_like_evaluate_and_ties_go_to_the_smaller_bound():
    from sweeps.study import load_part_ref

    part = load_part_ref("truncated_pyramid", ROOT / "examples")
    sampler = Sampler(GeometryTolerance(tau_v=5e-5),
                      execution=ExecutionTolerance(tumble_slip_xy=2e-5, tumble_slip_theta=2e-4))
    goal = (0.2, 0.0, 0.0, 0)
    eps = dict(criterion=SuccessCriterion(pos_eps_m=0.0025, theta_eps_rad=0.012))
    syn = synthesize(part.vertices, (0, 0, 0, 0), goal, part.com,
                     selection=Selection(sampler, 300, jax.random.key(0)),
                     requirement=Requirement(**eps), eps=1e-3)
    cands, s = syn.candidates, syn.scores
    assert len(cands) >= 2 and all(c.plan.verdict == "solved" for c in cands)
    assert len({c.plan.faces for c in cands}) == len(cands)
    assert max(c.plan.n_tumbles for c in cands) <= cands[0].plan.n_tumbles + 2
    longest = int(np.argmax([c.plan.n_tumbles for c in cands]))
    ev = evaluate(cands[longest].plan, sampler, 300, jax.random.key(0), **eps)
    assert np.array_equal(ev.columns["success"], s.success[longest])
    # every candidate, the shorter ones too: its tumbles see the first of the same slips
    # and no more (a step past a plan's tumbles is a no-op without a slip)
    lengths = {c.plan.n_tumbles for c in cands}
    assert len(lengths) >= 2
    with jax.enable_x64(True):
        from robustness.hulls import face_merge_tol
        from robustness.replay import run_tumble

        draws = sampler.sample(jax.random.key(0), 300, dtype=jnp.float64,
                               n_vertices=len(part.vertices), dim=3, n_tumbles=max(lengths))
        v = np.asarray(cands[0].plan.vertices)
        tol = face_merge_tol(5e-5, float(np.max(np.linalg.norm(v[:, None] - v[None], axis=-1))))
        for i, c in enumerate(cands):
            _, r = run_tumble(c.plan, draws, jnp.float64, 4096, merge_tol=tol,
                              slip_theta=2e-4)
            _, _, _, ep, et = goal_errors(r.x, r.y, r.theta, c.plan.goal)
            ok = eps["criterion"].success(ep, et, ~r.changed) & (r.face == goal[3])
            assert np.array_equal(ok, s.success[i]), i
    assert np.all(np.isfinite(s.bound_position_m)) and np.array_equal(s.cost, s.bound_position_m)
    k = s.n_success
    tied = [i for i in range(len(k)) if k[i] >= k.max() - 1]
    assert syn.chosen == min(tied, key=lambda i: (s.bound_position_m[i], s.steps[i], i))


@pytest.mark.slow
def test_a_study_sweeps_synthesis_on_and_off(tmp_path):
    study = tmp_path / "syn.yaml"
    study.write_text(f"""study: syn
kind: push
part: {ROOT / 'examples' / 'biplus_stable.yaml'}
tasks:
  - {{name: turn, start: [0, 0, 0], goal: [0.10, 0.05, 60deg]}}
tolerances: {{tau_v: 2.0e-5, tau_com: 1.0e-4}}
friction: {{mu_f: [0.3, 0.8], mu_s: [0.2, 0.5], support: any}}
execution: {{start_xy: 5.0e-4, start_theta: 0.01, fence_angle: 0.002, distance_abs: 1.0e-4,
            distance_rel: 0.005}}
eps: {{pos_eps_m: 0.003, theta_eps_rad: 0.05}}
samples: 120
seed: 0
model: quasistatic     # the sweep's machinery, on the fast model (the test of a minute less)
report: false
synthesize: {{n_samples: 200, margins_deg: [3, 20], safety_factors: [1.15, 2.0],
              strategies: [search], per_setting: 2, veto_samples: 0}}
params:
  synthesize.enabled: [false, true]
""")
    out = tmp_path / "out"
    r = nudge_here("sweep", study, "--out", out, "--quiet", cwd=ROOT)
    assert r.returncode == 0, r.stderr
    s = pd.read_parquet(out / "summary").sort_values("config_id")
    p = pd.read_parquet(out / "plans").sort_values("config_id")
    assert s["synthesize_enabled"].tolist() == ["false", "true"]   # a swept bool: JSON text
    assert p["plan_json"].iloc[0] != p["plan_json"].iloc[1]       # another plan was chosen
    assert s["n_success"].iloc[1] > s["n_success"].iloc[0] + 50    # and it holds on the study's draws


@pytest.mark.slow
def test_physics_breaks_the_kinematic_tie():
    from robustness import physics_tiebreak

    from sweeps.study import load_part_ref

    part = load_part_ref("rectangle", ROOT / "examples")
    # a short translation: many candidates succeed on every selection draw (a tie)
    syn = synthesize(part.vertices, START, (0.05, 0.02, 0.0), part.com,
                     selection=Selection(SAMPLER, 200, jax.random.key(0)), requirement=REQ,
                     model="quasistatic", **SMALL)
    k = syn.scores.n_success
    tied = [i for i in range(len(k)) if k[i] >= k[syn.chosen] - 1]
    assert len(tied) >= 2
    out = physics_tiebreak(syn, SAMPLER, 2, jax.random.key(5), top=2, **EPS)
    idx, got, n = out.physics
    assert n == 2 and len(idx) == 2 and syn.chosen in idx and out.chosen in idx
    assert got[idx.index(out.chosen)] == max(got)
    assert "MuJoCo rollouts on 2 common draws" in out.describe()
    assert out.scores is syn.scores and out.candidates is syn.candidates


@pytest.mark.slow
def test_certify_keeps_the_default_plan_when_physics_contradicts_the_choice(tmp_path):
    """The rectangle's 60-degree turn (``bench/synthesis.py``'s task): the exact
    limit surface prefers a candidate (300/300 selection draws against the
    default plan's 66/300) that MuJoCo fails on 7 of 16 common draws where the
    default plan succeeds on all 16; ``nudge certify --synthesize`` keeps the
    default plan, certifies it, and says why in the certificate, the
    candidates table and the report."""
    cfg = tmp_path / "turn.yaml"
    cfg.write_text(f"""part: {ROOT / 'examples' / 'rectangle.yaml'}
tolerances: {{tau_v: 2.0e-5, tau_com: 1.0e-4}}
friction: {{mu_f: [0.5, 0.8], mu_s: [0.2, 0.5], support: any}}
execution: {{start_xy: 5.0e-4, start_theta: 0.01, fence_angle: 0.002, distance_abs: 1.0e-4,
             distance_rel: 0.005}}
eps: {{pos_eps_m: 0.003, theta_eps_rad: 0.05}}
n_samples: 100
synthesize: {{n_samples: 300, veto_samples: 16, confirm_samples: 0}}
tasks:
  - {{name: turn, start: [0, 0, 0], goal: [0.1118034, 0.0559017, 60deg]}}
""")
    out = tmp_path / "out"
    r = nudge_here("certify", cfg, "--synthesize", "--out", out, "--quiet")
    assert r.returncode in (0, 1), r.stderr
    assert "Traceback" not in r.stderr
    c = pd.read_parquet(out / "certificates").iloc[0]
    assert c["selection"].startswith("default plan kept: the limit_surface model preferred ")
    assert "but MuJoCo contradicted it (MuJoCo rollouts on 16 common draws: " in c["selection"]
    assert "/16 for the default plan, worse by more than two standard errors)" in c["selection"]
    cands = pd.read_parquet(out / "candidates")
    assert cands[cands.chosen]["candidate"].tolist() == [0]
    assert c["selection_ci_low"] == pytest.approx(c["default_selection_ci_low"])
    plans = pd.read_parquet(out / "plans")
    assert plans["plan_json"].iloc[0] == cands[cands.candidate == 0]["plan_json"].iloc[0]
    assert "default plan kept" in r.stdout and "default plan kept" in (out / "report.html").read_text()


def test_rollouts_contradict_a_choice_only_beyond_two_standard_errors():
    from robustness.synthesis import contradicts

    both = np.ones(24, bool)
    assert not contradicts(both, both)
    assert contradicts(both, np.zeros(24, bool))              # every draw worse
    assert contradicts([1, 1], [0, 0])                         # alike: any margin
    one = both.copy()
    one[0] = False
    assert not contradicts(both, one)                          # 1 of 24: within 2 SE
    half = np.arange(24) % 2 == 0
    assert contradicts(both, half)                             # 12 of 24
    assert not contradicts(half, both)                         # better: never
    assert not contradicts([], [])


def test_physics_vetoes_a_choice_it_contradicts_and_says_so(monkeypatch):
    """``physics_veto`` rolls the chosen candidate and the default plan out on
    the same draws: contradicted, the default plan is kept and the selection
    sentence says why; confirmed, the choice stays and the sentence says so.
    MuJoCo is replaced by fixed per-draw successes (the rollouts are tested in
    the end-to-end test above)."""
    import robustness.blocks
    from robustness import physics_veto

    part_syn = synthesize(TRIANGLE, START, TURN, None,
                          selection=Selection(SAMPLER, 100, jax.random.key(0)), requirement=REQ,
                          model="quasistatic", **SMALL)
    syn = dataclasses.replace(part_syn, chosen=1)
    calls = []

    def fake(results):
        def sample_block(plan, sampler, n, key, criterion, model):
            calls.append((plan, n, model.name))
            ok = results[0 if plan is syn.candidates[0].plan else 1]
            return types.SimpleNamespace(stats={"success": np.asarray(ok[:n], bool)})
        return sample_block

    monkeypatch.setattr(robustness.blocks, "sample_block", fake(([1] * 8, [0] * 4 + [1] * 4)))
    out = physics_veto(syn, SAMPLER, 8, jax.random.key(1), **EPS)
    assert [c[1:] for c in calls] == [(8, "mujoco")] * 2
    assert out.chosen == 0 and out.vetoed_from == 1 and out.veto == (8, 4, 8, True)
    assert out.plan is syn.candidates[0].plan
    text = out.describe()
    assert text.startswith("default plan kept:") and "MuJoCo contradicted it" in text
    assert "4/8 for it against 8/8 for the default plan" in text

    monkeypatch.setattr(robustness.blocks, "sample_block", fake(([1] * 8, [1] * 7 + [0])))
    out = physics_veto(syn, SAMPLER, 8, jax.random.key(1), **EPS)
    assert out.chosen == 1 and out.vetoed_from is None and out.veto == (8, 7, 8, False)
    assert out.describe().startswith("synthesized:")
    assert "confirmed against the default plan by MuJoCo rollouts on 8 common draws (7/8 " \
           "against 8/8)" in out.describe()
    calls.clear()
    assert physics_veto(dataclasses.replace(syn, chosen=0), SAMPLER, 8, jax.random.key(1),
                        **EPS).veto is None and not calls       # the default chosen: nothing


@pytest.mark.slow
def test_the_faithful_model_chooses_among_the_fast_models_shortlist(monkeypatch):
    """model=limit_surface: the quasi-static model shortlists the default plan
    and the best SHORTLIST - 1 candidates on the same draws, each of them is
    scored under the exact limit surface (the scores are run_push's under that
    model), and the selection says it chose from a shortlist."""
    import robustness.synthesis as sy

    monkeypatch.setattr(sy, "SHORTLIST", 3)
    V, com = _part()
    n, key = 64, jax.random.key(5)
    sampler = dataclasses.replace(SAMPLER, friction=dataclasses.replace(SAMPLER.friction,
                                                                        support="rigid"))
    full, _ = push_candidates(V, START, TURN, com, **SMALL)
    assert len(full) > 3
    syn = synthesize(V, START, TURN, com, selection=Selection(sampler, n, key), requirement=REQ,
                     model="limit_surface", **SMALL)
    assert syn.screened == len(full) and len(syn.candidates) == 3 and syn.model == "limit_surface"
    assert syn.candidates[0].plan.pushes == full[0].plan.pushes
    pre = score_candidates([c.plan for c in full], sampler, n, key, REQ)
    best = sorted(range(1, len(full)), key=lambda j: (-int(pre.n_success[j]), float(pre.cost[j]), j))
    assert [c.plan.pushes for c in syn.candidates[1:]] == [full[j].plan.pushes for j in best[:2]]
    faithful = score_candidates([c.plan for c in syn.candidates], sampler, n, key, REQ,
                                model="limit_surface")
    assert np.array_equal(faithful.success, syn.scores.success)
    assert "the 3 of" in syn.describe() and "limit_surface model" in syn.describe()
