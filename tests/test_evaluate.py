"""Monte-Carlo evaluation of push and tumble plans."""
import dataclasses
import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from kernels.polyhedron import PartWarning, make_polyhedron
from kernels.tumble import make_config, replay
from planning.pushing.planner import plan_pose
from planning.tumbling.plan import Tumble, TumblePlan
from robustness import Bound, replay as batches
from robustness import summary
from robustness.evaluation import BoundViolation, evaluate
from robustness.samplers import ExecutionTolerance, FrictionRange, GeometryTolerance, Sampler
from robustness import CONFIDENCE, Model
from robustness.tolerances import SuccessCriterion
from robustness.tables import FAILURE_MODES

TRI = [[0.0, 0.0], [0.03, 0.0], [0.005, 0.02]]
IRREG = [[-0.054, -0.040, -0.028], [0.066, -0.040, -0.028], [0.046, 0.040, -0.028],
         [-0.044, 0.050, -0.028], [-0.034, -0.030, 0.042], [0.036, -0.020, 0.032],
         [-0.004, 0.030, 0.052]]
IRREG_COM = [0.004, -0.003, 0.002]

# fence friction high, c small: every reorient completes without slip (the exact replay's regime)
N = 32  # one batch size everywhere: the compiled kernels are shared between tests
STICKY = FrictionRange(mu_f=(50.0, 50.0), c=(0.002, 0.004))
TOL = Sampler(GeometryTolerance(tau_v=2e-5, tau_com=5e-5), STICKY,
              ExecutionTolerance(start_xy=2e-4, start_theta=5e-3, fence_angle=1e-3,
                                 distance_abs=5e-5, distance_rel=2e-3))
TIGHT = SuccessCriterion(pos_eps_m=4e-4, theta_eps_rad=2e-3)


@pytest.fixture(scope="module")
def plan():
    return plan_pose(TRI, (0.0, 0.0, 0.0), (0.1, 0.05, 1.0))


@pytest.fixture(scope="module")
def tumble_plan():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PartWarning)
        P = make_polyhedron(IRREG, IRREG_COM)
    rng = np.random.default_rng(0)
    seq, f = [], 0
    for _ in range(12):
        g = int(rng.choice(P.neighbors(f)))
        seq.append(g)
        f = g
    start = (0.01, -0.02, 0.3, 0)
    with jax.enable_x64(True):  # the test's own float64 replay of the plan
        fin, ok = replay(P.geometry(jnp.float64), make_config(*start), jnp.asarray(seq))
    assert bool(ok)
    pf = (float(fin.xy[0]), float(fin.xy[1]), float(fin.theta), int(fin.face))
    faces = [0] + seq
    tumbles = tuple(Tumble(edge=P.shared_edge(a, b), face=b) for a, b in zip(faces[:-1], faces[1:]))
    return TumblePlan(vertices=tuple(map(tuple, P.vertices.tolist())), com=tuple(P.com.tolist()),
                      start=start, goal=pf, eps=1e-3, tau_v=0.0, tau_g=None, tumbles=tumbles,
                      predicted_final=pf, error=0.0, bounds={}, verdict="solved", reason="test",
                      reachable_class="dense", n_tumbles_paper=len(seq))


@pytest.mark.slow
def test_zero_tolerances_reproduce_the_plan(plan):
    ev = evaluate(plan, Sampler(), 4, jax.random.key(0), model="exact", bound=False)
    df = ev.samples
    assert len(df) == 4 and df["success"].all() and (df["failure_mode"] == "none").all()
    last = plan.pushes[-1].pose_after
    np.testing.assert_allclose(df["final_x_m"], last[0], atol=1e-12)
    np.testing.assert_allclose(df["final_y_m"], last[1], atol=1e-12)
    np.testing.assert_allclose(df["final_theta_rad"], last[2], atol=1e-12)
    assert df["err_pos_m"].max() <= 1e-9 and df["err_theta_rad"].abs().max() <= 1e-9
    assert (df["final_edge_a"] == plan.pushes[-1].edge[0]).all()
    assert (df["final_edge_b"] == plan.pushes[-1].edge[1]).all()
    assert ev.summary["success_rate"] == 1.0 and ev.summary["n_none"] == 4


@pytest.mark.slow
def test_tolerances_success_rate_and_interval(plan):
    ev = evaluate(plan, TOL, N, jax.random.key(1), TIGHT, model="exact")
    s, df = ev.summary, ev.samples
    assert 0.0 <= s["success_rate"] <= 1.0
    assert s["ci_low"] <= s["success_rate"] <= s["ci_high"]
    assert s["n"] == N and s["n_success"] == int(df["success"].sum())
    assert set(df["failure_mode"]) <= set(FAILURE_MODES)
    assert sum(s[f"n_{m}"] for m in FAILURE_MODES) == N
    assert df["sample_id"].tolist() == list(range(N))
    assert s["err_pos_m_q50"] <= s["err_pos_m_q90"] <= s["err_pos_m_q99"] <= s["err_pos_m_max"]
    assert s["err_pos_m_max"] > 0
    assert df.loc[df["sample_id"] == s["worst_sample_id"], "err_pos_m"].iloc[0] == s["worst_err_pos_m"]
    # the analytic bound sits beside the empirical maximum and holds here
    assert s["bound_position_m"] > 0 and s["bound_violated"] is False
    assert s["emp_max_pos_in_model_m"] <= s["bound_position_m"]
    # sampled parameters are columns of the table
    for c in ("dv0_x_m", "dcom_y_m", "mu_f", "c_m", "start_dtheta_rad", "fence_angle_err_rad_p0"):
        assert c in df.columns
    # success is exactly "within eps on both"
    ok = (df["err_pos_m"] <= 4e-4) & (df["err_theta_rad"].abs() <= 2e-3) & df["model_valid"]
    assert (ok == df["success"]).all()


def test_the_summary_is_built_when_first_read(plan, monkeypatch):
    """A caller that summarises blocks together (the runner) never pays for a
    block's summary: it is built when first read, once, from the same samples;
    the list draws are the flat columns, in vertex / push order."""
    key = jax.random.key(1)
    calls = []
    real = summary.summarise
    monkeypatch.setattr("robustness.evaluation.summarise",
                        lambda *a, **k: calls.append(1) or real(*a, **k))
    ev = evaluate(plan, TOL, N, key, TIGHT, model="exact")
    assert not calls
    s = ev.summary
    assert len(calls) == 1 and ev.summary is s and s["n"] == N
    assert s["n_success"] == int(ev.samples["success"].sum())
    df, m, P = ev.samples, len(plan.vertices), len(plan.pushes)
    flat = np.stack([df[f"dv{i}_{a}_m"] for i in range(m) for a in "xy"], axis=1)
    assert np.array_equal(ev.lists["dv_m"], flat)
    for stem in ("fence_angle_err_rad", "push_dist_rel_err", "push_dist_abs_err_m"):
        assert ev.lists[stem].shape == (N, P)
        assert np.array_equal(ev.lists[stem], np.stack([df[f"{stem}_p{k}"] for k in range(P)], 1))


def test_exact_and_quasistatic_agree_when_sticking(plan):
    a = evaluate(plan, TOL, N, jax.random.key(2), model="exact", bound=False).samples
    b = evaluate(plan, TOL, N, jax.random.key(2), model="quasistatic",
                 bound=False).samples
    assert (b["n_incomplete"] == 0).all() and (b["slip_m"] == 0).all()
    for col in ("final_x_m", "final_y_m", "final_theta_rad"):
        np.testing.assert_allclose(a[col], b[col], atol=1e-9)
    assert (a["final_edge_a"] == b["final_edge_a"]).all()
    assert (a["success"] == b["success"]).all()


def test_float32_sees_the_same_samples(plan):
    a = evaluate(plan, TOL, N, jax.random.key(2), model="exact", bound=False).samples
    b = evaluate(plan, TOL, N, jax.random.key(2), model=Model("exact", dtype=jnp.float32),
                 bound=False).samples
    assert (b["dtype"] == "float32").all()
    np.testing.assert_allclose(a["dv0_x_m"], b["dv0_x_m"], rtol=1e-6)  # same draws, cast
    np.testing.assert_allclose(a["final_x_m"], b["final_x_m"], atol=2e-6)
    np.testing.assert_allclose(a["final_theta_rad"], b["final_theta_rad"], atol=2e-5)


def test_quasistatic_shows_failures_when_slippery(plan):
    # same vmap axes as TOL (one compiled kernel): only the friction values differ
    s = Sampler(TOL.geometry, FrictionRange(mu_f=(0.02, 0.02), c=(0.01, 0.02)), TOL.execution)
    df = evaluate(plan, s, N, jax.random.key(3), model="quasistatic",
                  bound=False).samples
    assert (df["slip_m"] > 0).any()
    assert (df["failure_mode"] != "none").any()


def test_bound_violation_is_reported_not_clipped(plan, monkeypatch):
    monkeypatch.setattr(summary, "analytic_bound",
                        lambda p, s, k: Bound(1e-9, 0.0, 1e-9))
    ev = evaluate(plan, TOL, N, jax.random.key(1), model="exact")
    with pytest.warns(BoundViolation, match="BOUND VIOLATED"):   # when the summary is built
        assert ev.summary["bound_violated"] is True
    assert ev.summary["emp_max_pos_in_model_m"] > 1e-9  # the maximum is kept as measured


def test_tumble_zero_tolerances_and_com_offset(tumble_plan):
    ev = evaluate(tumble_plan, Sampler(GeometryTolerance(tau_com=2e-3)), 16, jax.random.key(0))
    df = ev.samples
    assert ev.model == "exact" and df["success"].all()
    # a centre-of-mass offset does not move a tumbling part (errors in the nominal frames)
    assert df["err_pos_m"].max() <= 1e-12 and df["err_theta_rad"].abs().max() <= 1e-12
    assert (df["final_face"] == tumble_plan.goal[3]).all()
    assert ev.summary["pos_eps_m"] == tumble_plan.eps


@pytest.mark.slow
def test_tumble_vertex_tolerance_bound_and_slip(tumble_plan):
    # eq. (6) of the paper raises lengths to high powers: in metres, for a part smaller than a
    # metre, its bound collapses (~1e-31 m here) and the samples exceed it -- an expected
    # finding, asserted here rather than left in the suite's output
    ev = evaluate(tumble_plan, Sampler(GeometryTolerance(tau_v=2e-5, tau_com=2e-3)), 16,
                  jax.random.key(1))
    with pytest.warns(BoundViolation, match="PAPER BOUND VIOLATED") as rec:
        s = ev.summary
    assert all("eq. 6" in str(w.message) for w in rec if issubclass(w.category, BoundViolation))
    assert rec[0].filename == __file__   # the warning points at the caller, not at a decorator
    s = ev.summary
    assert s["paper_bound_violated"] is True and s["paper_bound_position_m"] < 1e-20
    assert s["err_pos_m_max"] > 0 and s["bound_position_m"] > 0
    assert s["n_in_bound_model"] == 16 and s["bound_violated"] is False
    # start and slip errors: their first-order contribution is part of the bound
    slip = Sampler(GeometryTolerance(tau_com=2e-3),
                   execution=ExecutionTolerance(start_xy=1e-4, start_theta=1e-3,
                                                tumble_slip_xy=2e-5, tumble_slip_theta=2e-4))
    ev2 = evaluate(tumble_plan, slip, 16, jax.random.key(1))
    s2 = ev2.summary
    assert (ev2.samples["slip_m"] > 0).all() and s2["n_in_bound_model"] == 16
    assert 0.2 * s2["bound_position_m"] <= s2["emp_max_pos_in_model_m"] <= s2["bound_position_m"]
    assert s2["emp_max_theta_in_model_rad"] <= s2["bound_theta_rad"]
    assert s2["bound_violated"] is False


def test_tumble_combinatorics_change_is_a_failure(tumble_plan):
    ev = evaluate(tumble_plan, Sampler(GeometryTolerance(tau_v=2.5e-2, tau_com=2e-3)), 16,
                  jax.random.key(5), bound=False)
    df = ev.samples
    assert df["hull_changed"].any()
    changed = df[df["hull_changed"]]
    assert (changed["failure_mode"] == "combinatorics_changed").all()
    assert not changed["success"].any() and not changed["model_valid"].any()


# --------------------------------------------------------------------------
# the batched replays: same numbers as the kernels, compiled once per shape
# --------------------------------------------------------------------------
def _kernel_tumble_replay(plan, draws):
    """Reference: the tumble kernel (:func:`kernels.tumble.tumble`) step by step on each
    perturbed part, slip after every tumble, nominal-frame conversions (float64)."""
    from kernels.tumble_geometry import tumble_geometry
    from kernels.planar import rot2, wrap_angle
    from kernels.tumble import TumbleConfig, tumble

    poly = batches.tumble_nominal(plan)
    p = draws.broadcast()
    V0, com0 = jnp.asarray(poly.vertices), jnp.asarray(poly.com)
    origins = jnp.asarray(poly.face_origins)
    xaxes = jnp.asarray(poly.face_rotations[:, 0, :])
    start = jnp.asarray(plan.start[:3])
    seq = jnp.asarray(np.asarray(plan.faces, np.int32).reshape(-1))

    def one(dv, dc, so, slips):
        geom = tumble_geometry(V0 + dv, com0 + dc, poly.topology)
        q, phi = batches._frame_offset(geom, origins, xaxes, int(plan.start[3]))
        th = start[2] + so[2] - phi
        cfg = TumbleConfig(xy=start[:2] + so[:2] - rot2(th) @ q, theta=wrap_angle(th),
                           face=jnp.asarray(int(plan.start[3]), jnp.int32))

        def body(c, xs):
            face, slip = xs
            c2, _ = tumble(geom, c, face)
            return TumbleConfig(c2.xy + slip[:2], wrap_angle(c2.theta + slip[2]), c2.face), None

        fin, _ = jax.lax.scan(body, cfg, (seq, slips))
        q, phi = batches._frame_offset(geom, origins, xaxes, fin.face)
        xy = fin.xy + rot2(fin.theta) @ q
        return jnp.stack([xy[0], xy[1], wrap_angle(fin.theta + phi)]), fin.face

    g, e = p.geometry, p.execution
    return jax.jit(jax.vmap(one))(g.vertex_offset, g.com_offset, e.start_offset, e.tumble_slip)


@pytest.mark.slow
@pytest.mark.float64
@pytest.mark.parametrize("series", [True, False])
def test_tumble_replay_is_the_kernels(tumble_plan, series):
    """The evaluation's replay (edge motions composed as 2x2 rotations, faces walked on the
    host) gives the tumble kernel's poses, sample by sample, with vertex, centre-of-mass,
    start and slip errors."""
    s = Sampler(GeometryTolerance(tau_v=2e-4, tau_com=2e-3),
                execution=ExecutionTolerance(start_xy=1e-3, start_theta=0.05, tumble_slip_xy=2e-4,
                                             tumble_slip_theta=0.05))
    n = N
    draws = s.sample(jax.random.key(7), n, n_vertices=len(tumble_plan.vertices), dim=3,
                     n_tumbles=tumble_plan.n_tumbles)
    _, r = batches.run_tumble(tumble_plan, draws, jnp.float64, 16,
                              slip_theta=0.05 if series else np.inf)
    want, face = _kernel_tumble_replay(tumble_plan, draws)
    got = np.stack([r.x, r.y, r.theta], axis=1)
    assert np.all(np.asarray(face) == r.face) and r.ok.all()
    dth = np.abs((got[:, 2] - np.asarray(want)[:, 2] + np.pi) % (2 * np.pi) - np.pi)
    assert np.max(np.abs(got[:, :2] - np.asarray(want)[:, :2])) < 1e-13 and np.max(dth) < 1e-13
    assert np.ptp(got[:, 0]) > 1e-4   # the perturbations do move the part


def _walk_plan(k, seed=0):
    """A ``k``-tumble random walk on the IRREG polyhedron (its goal: where it ends)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PartWarning)
        P = make_polyhedron(IRREG, IRREG_COM)
    rng = np.random.default_rng(seed)
    faces = [0]
    for _ in range(k):
        faces.append(int(rng.choice(P.neighbors(faces[-1]))))
    with jax.enable_x64(True):
        fin, ok = replay(P.geometry(jnp.float64), make_config(0.0, 0.0, 0.0, 0),
                         jnp.asarray(faces[1:]))
    pf = (float(fin.xy[0]), float(fin.xy[1]), float(fin.theta), int(fin.face))
    return TumblePlan(vertices=tuple(map(tuple, P.vertices.tolist())), com=tuple(P.com.tolist()),
                      start=(0.0, 0.0, 0.0, 0), goal=pf, eps=1e-3, tau_v=0.0, tau_g=None,
                      tumbles=tuple(Tumble(edge=P.shared_edge(a, b), face=b)
                                    for a, b in zip(faces[:-1], faces[1:])),
                      predicted_final=pf, error=0.0, bounds={}, verdict="solved", reason="test",
                      reachable_class="dense", n_tumbles_paper=k)


@pytest.mark.float64
def test_tumble_steps_past_a_plan_slip_nothing():
    """A plan replayed on draws for more tumbles (robust synthesis scores plans of several
    lengths on one set of draws; evaluate() keeps every column the sampler drew) sees
    its own tumbles' slips and no more: bit for bit its replay on draws cut to its
    length, alone or beside longer plans, and the slip sums of the columns likewise (the
    replay's summed slip to the last bits where the draws' columns fall in another power
    of two than the plan's)."""
    from robustness import samplers

    s = Sampler(GeometryTolerance(tau_v=1e-4),
                execution=ExecutionTolerance(tumble_slip_xy=2e-4, tumble_slip_theta=0.02))
    long = _walk_plan(21)          # drawn_steps(21) = 22: one column past the plan
    plans = [long] + [_first_tumbles(long, k) for k in (20, 9)]
    m = len(long.vertices)
    wide = s.sample(jax.random.key(5), N, n_vertices=m, dim=3, n_tumbles=21, exact_steps=False)
    assert wide.params.execution.tumble_slip.shape[1] == samplers.drawn_steps(21) == 22

    def cut(draws, k):
        e = draws.params.execution
        return dataclasses.replace(draws, params=dataclasses.replace(
            draws.params, execution=dataclasses.replace(e, tumble_slip=e.tumble_slip[:, :k])))

    fields = ("x", "y", "theta", "slip")
    # chunks of 16 samples: the walk as wide as the drawn columns (22 steps); of 64: the
    # power of two (32 steps)
    for chunk in (16, 64):
        many = batches.run_tumble_many(plans, wide, jnp.float64, chunk, slip_theta=0.02)
        for i, pl in enumerate(plans):
            k = pl.n_tumbles
            _, ref = batches.run_tumble(pl, cut(wide, k), jnp.float64, chunk, slip_theta=0.02)
            _, got = batches.run_tumble(pl, wide, jnp.float64, chunk, slip_theta=0.02)
            same_bucket = batches._bucket(k, 16) == batches._bucket(22, 16)
            for f in fields:
                for r in (got, jax.tree_util.tree_map(lambda x: x[i], many)):
                    if f == "slip" and not same_bucket:
                        np.testing.assert_allclose(r.slip, ref.slip, rtol=1e-14, err_msg=str(k))
                    else:
                        np.testing.assert_array_equal(getattr(r, f), getattr(ref, f),
                                                      err_msg=f"{chunk} {k} {f}")
            assert np.all(ref.slip > 0)
        cols = [samplers.parameter_columns(d, n_vertices=m, dim=3, n_tumbles=k)
                for d in (cut(wide, k), wide)]
        for name in ("slip_sum_dx_m", "slip_sum_dy_m", "slip_sum_dtheta_rad"):
            np.testing.assert_array_equal(cols[1][name], cols[0][name], err_msg=name)
    # the exact draws are the wide ones cut: the plan's numbers do not depend on the layout
    exact = s.sample(jax.random.key(5), N, n_vertices=m, dim=3, n_tumbles=21)
    np.testing.assert_array_equal(exact.params.execution.tumble_slip,
                                  wide.params.execution.tumble_slip[:, :21])


def test_tumble_hull_check_is_the_host_reference(tumble_plan):
    """The combinatorics check inside the compiled evaluation (kernels.hulls) flags exactly
    the samples the host-side Qhull reference flags."""
    from robustness.hulls import face_merge_tol, polyhedron_combinatorics_changed

    s = Sampler(GeometryTolerance(tau_v=1.2e-3))
    ev = evaluate(tumble_plan, s, N, jax.random.key(11), bound=False)
    draws = s.sample(jax.random.key(11), N, n_vertices=len(tumble_plan.vertices), dim=3,
                     n_tumbles=tumble_plan.n_tumbles)
    V = np.asarray(tumble_plan.vertices)[None] + np.asarray(draws.broadcast().geometry.vertex_offset)
    v = np.asarray(tumble_plan.vertices)
    tol = face_merge_tol(1.2e-3, float(np.max(np.linalg.norm(v[:, None] - v[None], axis=-1))))
    want = polyhedron_combinatorics_changed(V, batches.tumble_nominal(tumble_plan), tol)
    assert 0 < want.sum() < N   # both answers occur
    np.testing.assert_array_equal(ev.samples["hull_changed"].to_numpy(), want)


def _longer(plan, extra):
    """The plan with its last push repeated ``extra`` more times (a longer plan of the
    same part, for counting compilations; its goal is not met, which does not matter)."""
    import dataclasses

    return dataclasses.replace(plan, pushes=tuple(plan.pushes) + (plan.pushes[-1],) * extra)


def _first_tumbles(tplan, k):
    """The first ``k`` tumbles of a tumble plan."""
    import dataclasses

    return dataclasses.replace(tplan, tumbles=tplan.tumbles[:k], n_tumbles_paper=k)


_COMPILES: list = []
jax.monitoring.register_event_duration_secs_listener(
    lambda name, secs, **kw: _COMPILES.append(name)
    if name == "/jax/core/compile/backend_compile_duration" else None)


@pytest.mark.slow
def test_one_compilation_per_shape_bucket(plan, tumble_plan):
    """A study of several plan lengths (one length bucket), sample counts (one chunk
    bucket) and tolerance values compiles the push batch, the tumble batch and each
    sampler once; running it again compiles nothing at all."""
    from robustness import samplers

    P = len(plan.pushes)
    bucket = batches._bucket(P + 1, 2)    # holds P + 1 and P or P + 2, whatever P is
    lengths = [k for k in range(P, 2 * P + 3) if batches._bucket(k, 2) == bucket]
    assert len(lengths) >= 2
    plans = [_longer(plan, k - P) for k in lengths]
    tol = [Sampler(GeometryTolerance(tau_v=t, tau_com=5e-5), STICKY,
                   ExecutionTolerance(start_xy=2e-4, fence_angle=f, distance_rel=2e-3))
           for t, f in ((1e-5, 1e-3), (3e-5, 2e-3))]
    t_plans = [tumble_plan, _first_tumbles(tumble_plan, 9)]
    t_tol = [Sampler(GeometryTolerance(tau_v=t), execution=ExecutionTolerance(tumble_slip_xy=x))
             for t, x in ((1e-5, 1e-5), (2e-5, 3e-5))]

    # counts padded into one chunk bucket (32); a count equal to the bucket is passed
    # as it is (no host round trip), a call signature of its own (jit's dispatch cache
    # counts it) though not a compilation: the test then passed only after other tests
    def study():
        for i, n in enumerate((20, 27, 30, 17)):
            evaluate(plans[i % len(plans)], tol[i % 2], n, jax.random.key(i), model="quasistatic",
                     bound=False)
        for i, n in enumerate((20, 29, 31)):
            evaluate(t_plans[i % 2], t_tol[i % 2], n, jax.random.key(i), bound=False)

    def counts():
        return (batches._push_batch._cache_size(), batches._tumble_batch._cache_size(),
                samplers._staged.cache_info().currsize)

    before = counts()
    study()
    mid = counts()
    assert mid[0] - before[0] <= 1 and mid[1] - before[1] <= 1, (before, mid)
    assert mid[2] - before[2] <= 2, (before, mid)    # one push and one tumble sampler
    del _COMPILES[:]
    study()
    assert counts() == mid and not _COMPILES, _COMPILES


def test_summary_one_sided_lower_bound(plan):
    """The summary carries the ONE-sided Clopper-Pearson lower bound at the stated
    confidence (what a probability claim uses) beside the two-sided interval."""
    from robustness import stats

    ev = evaluate(plan, TOL, N, jax.random.key(1), TIGHT, model="exact", bound=False)
    s = ev.summarise(confidence=0.9)
    assert s["confidence"] == 0.9 and ev.summary["confidence"] == CONFIDENCE
    assert s["ci_low_one_sided"] == stats.one_sided_lower(s["n_success"], s["n"], 0.9)
    assert s["ci_low"] <= s["ci_low_one_sided"] <= s["success_rate"]
    ev = evaluate(plan, Sampler(), 8, jax.random.key(0), model="exact", bound=False)
    assert ev.summary["ci_low_one_sided"] == pytest.approx(0.05 ** (1 / 8), rel=1e-12)  # k = n


def test_edge_pairs_are_the_hull_edges_vertex_pairs():
    from kernels import make_polygon
    from robustness.replay import edge_pairs

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # vertex 5 is interior: caller indices and hull indices differ
        poly = make_polygon(np.array([[0, 0], [1, 0], [1.2, 0.5], [0.5, 1], [0.3, 0.9], [0.6, 0.4]]))
    edges = np.array([-1, *range(poly.n), -1, poly.n - 1])
    a, b = edge_pairs(poly, edges)
    want = [poly.edge_vertices(int(e)) if e >= 0 else (-1, -1) for e in edges]
    assert list(zip(a.tolist(), b.tolist())) == want
    assert a.dtype == np.int64 and b.dtype == np.int64


@pytest.mark.slow
@pytest.mark.float64
def test_a_batch_of_several_calls_runs_in_this_thread_over_every_device(plan, monkeypatch):
    """A batch of several compiled calls runs in the caller's thread: one call
    after the other on one device; on several (the suite's processes have two
    CPU devices: conftest) as calls spread over the devices, a short run of
    calls padded, and a batch of one call cut into a share per device
    (robustness.replay._map_calls).  The outcomes are the same bit for bit, in
    float64, and a limit-surface batch the same whatever its calls' size."""
    import threading

    from kernels import polygon as pg

    devices = tuple(jax.devices())
    assert len(devices) == 2 and all(d.platform == "cpu" for d in devices)
    assert batches.replay_devices() == devices
    body = pg.make_polygon(np.asarray(plan.vertices), np.asarray(plan.com)).body
    draws = TOL.sample(jax.random.key(3), 40, body=body, dtype=jnp.float64,
                       n_vertices=len(plan.vertices), dim=2, n_pushes=len(plan.pushes))
    seen, spread, batch, spread_call = [], [], batches._push_batch, batches._spread_call

    def spy(*a, **k):
        seen.append(threading.get_ident())
        return batch(*a, **k)

    def spread_spy(*a, **k):
        spread.append(threading.get_ident())
        return spread_call(*a, **k)

    monkeypatch.setattr(batches, "_push_batch", spy)
    monkeypatch.setattr(batches, "_spread_call", spread_spy)
    runs = {}
    for k in (1, 2):
        monkeypatch.setattr(batches, "replay_devices", lambda k=k: devices[:k])
        _, _, r = batches.run_push(plan, draws, "quasistatic", jnp.float64, 8)   # 5 calls
        runs[k] = np.stack([r.x, r.y, r.theta, r.slip], axis=1)
        assert runs[k].dtype == np.float64
        if k == 1:
            assert len(seen) == 5 and not spread
    assert len(spread) == 3   # 2 + 2 + the last call beside a copy of itself
    assert set(seen) | set(spread) == {threading.get_ident()}
    assert np.all(np.isfinite(runs[1])) and np.array_equal(runs[1], runs[2])
    monkeypatch.setattr(batches, "SPREAD_MIN_SAMPLES", 8)   # one call of 64 -> 2 shares of 32
    one = {}
    for k in (1, 2):
        monkeypatch.setattr(batches, "replay_devices", lambda k=k: devices[:k])
        spread.clear()
        _, _, r = batches.run_push(plan, draws, "quasistatic", jnp.float64, 4096)
        one[k] = np.stack([r.x, r.y, r.theta, r.slip], axis=1)
        assert len(spread) == k - 1
    assert np.array_equal(one[1], one[2]) and np.array_equal(one[1], runs[1])
    monkeypatch.setattr(batches, "replay_devices", lambda: devices)
    assert batches.limit_surface_calls(("limit_surface", ("rigid",)), 600, 4096) == (512, True)
    assert batches._chunks(600, 512, True) == [(0, 512, 512), (512, 600, 512)]  # one shape
    assert batches.limit_surface_calls("quasistatic", 600, 4096) == (4096, False)
    ls = {}
    for call in (16, 64):   # 3 whole calls of 16 over 2 devices / one call of 64
        monkeypatch.setattr(batches, "LIMIT_SURFACE_CALL", call)
        _, _, r = batches.run_push(plan, draws, "limit_surface", jnp.float64, 4096)
        ls[call] = np.stack([r.x, r.y, r.theta], axis=1)
    assert ls[16].dtype == np.float64 and np.all(np.isfinite(ls[16]))
    assert np.array_equal(ls[16], ls[64])


@pytest.mark.slow
@pytest.mark.float64
def test_compiled_replays_hold_no_lapack_call(plan, monkeypatch):
    """A compiled push replay, limit surface on every support family, holds no
    LAPACK custom call: batched on the CPU, those block XLA's pool threads until
    their pieces run, and two replays executing at once (two devices) deadlocked
    on them (kernels.linsolve).  The check itself finds the call that
    ``jnp.linalg.solve`` makes."""
    from kernels import polygon as pg

    def lapack(f, *args, **kw):
        return "lapack" in jax.jit(f, static_argnames=tuple(kw)).lower(*args, **kw).as_text()

    A = jnp.eye(3, dtype=jnp.float64)[None].repeat(4, 0)
    assert lapack(jnp.linalg.solve, A, jnp.ones((4, 3, 1)))   # the check can fail
    texts, batch = [], batches._push_batch

    def spy(nom, q, model):
        texts.append(batch.lower(nom, q, model=model).as_text())
        return batch(nom, q, model)

    monkeypatch.setattr(batches, "_push_batch", spy)
    body = pg.make_polygon(np.asarray(plan.vertices), np.asarray(plan.com)).body
    sampler = Sampler(TOL.geometry, FrictionRange(mu_f=(0.5, 0.8), mu_s=(0.3, 0.5), support="any"),
                      TOL.execution)
    draws = sampler.sample(jax.random.key(5), 8, body=body, dtype=jnp.float64,
                           n_vertices=len(plan.vertices), dim=2, n_pushes=len(plan.pushes))
    for model in ("limit_surface", "quasistatic"):
        batches.run_push(plan, draws, model, jnp.float64, 4096)
    assert len(texts) == 2 and "while" in texts[0]
    assert not any("lapack" in t for t in texts)


def test_a_bad_thread_count_is_named(monkeypatch):
    from robustness.cpus import cpu_threads

    monkeypatch.setenv("NUDGE_THREADS", "two")
    with pytest.raises(ValueError, match="NUDGE_THREADS: expected a whole number"):
        cpu_threads()
    monkeypatch.setenv("NUDGE_THREADS", "0")
    with pytest.raises(ValueError, match="NUDGE_THREADS"):
        cpu_threads()
    monkeypatch.delenv("NUDGE_THREADS")
    assert cpu_threads() >= 1
