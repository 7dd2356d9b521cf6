"""First-order tolerance bounds confronted with hand derivations and Monte Carlo."""
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from kernels.polyhedron import make_polyhedron
from kernels.tumble import make_config, replay
from kernels.tumble_geometry import tumble_geometry
from planning.pushing.planner import plan_pose
from robustness.bounds import push_final_pose_fn, push_plan_bound, tumble_first_order_bound
from robustness.tolerances import ExecutionTolerance, GeometryTolerance, SuccessCriterion

pytestmark = pytest.mark.float64  # calls kernels on float64 arrays directly

RECT = [[0, 0], [0.04, 0], [0.04, 0.02], [0, 0.02]]
TRI = [[0, 0], [0.03, 0], [0.005, 0.02]]
UNI = [[0.0, 0.0], [0.0394, 0.0], [0.042, 0.0043], [0.0404, 0.0117], [0.0311, 0.0185], [0.0158, 0.0166]]
UNI_COM = [0.0349, 0.0020]


def test_translation_push_by_hand():
    # One translation push of s along +x on the 40 x 20 mm rectangle (centre of mass at the
    # centre; the left edge, corners (-0.02, -/+0.01), is flush).  A fence angle error a makes
    # the first-touching corner pivot until the edge is flush again: the part turns by a, the
    # centre of mass moves by R(a)(c - v) - (c - v) = a (-/+0.01, 0.02), then the corner advances
    # s along the tilted direction (s a across).  So to first order
    #   |dx| <= d + 0.01 |a|,  |dy| <= (s + 0.02) |a|,  |dtheta| <= |a|.
    plan = plan_pose(RECT, (0, 0, 0), (0.1, 0, 0))
    assert plan.plan_class == "translation" and plan.n_pushes == 1
    s = plan.pushes[0].distance
    a, d = 1e-3, 2e-4
    b = push_plan_bound(plan, execution=ExecutionTolerance(fence_angle=a, distance_abs=d))
    assert b.x_m == pytest.approx(d + 0.01 * a, rel=1e-5)
    assert b.y_m == pytest.approx((s + 0.02) * a, rel=1e-5)
    assert b.theta_rad == pytest.approx(a, rel=1e-5)


def test_start_errors_do_not_reach_final_orientation():
    # every push ends with a stable edge flush: start errors cannot change the final heading
    plan = plan_pose(TRI, (0.01, -0.02, 0.4), (0.1, 0.05, 2.0))
    b = push_plan_bound(plan, execution=ExecutionTolerance(start_xy=1e-3, start_theta=1e-2))
    assert b.theta_rad == pytest.approx(0.0, abs=1e-12)
    assert b.by_source["start_xy"].position_m > 0


@pytest.mark.slow
@pytest.mark.parametrize("verts,com,goal", [
    (TRI, None, (0.1, 0.05, 1.0)),
    (RECT, None, (-0.05, 0.08, -2.5)),
    (UNI, UNI_COM, (0.0, 0.1, math.pi)),
])
def test_first_order_bound_vs_monte_carlo(verts, com, goal):
    plan = plan_pose(verts, (0, 0, 0), goal, com=com)
    geo = GeometryTolerance(tau_v=2e-5, tau_com=2e-5, com_shape="box")
    tol = ExecutionTolerance(start_xy=2e-5, start_theta=2e-4, fence_angle=2e-4, distance_abs=2e-5,
                             distance_rel=1e-3)
    b = push_plan_bound(plan, geo, tol)
    f, sz = push_final_pose_fn(plan)
    n, P = sz["n"], sz["pushes"]
    rng = np.random.default_rng(7)
    N = 4000
    u = lambda *s: rng.uniform(-1.0, 1.0, s)
    dists = np.array([p.distance for p in plan.pushes])
    out = np.asarray(jax.jit(jax.vmap(f))(
        jnp.asarray(u(N, n, 2) * geo.tau_v), jnp.asarray(u(N, 2) * geo.tau_com),
        jnp.asarray(u(N, 3) * np.array([tol.start_xy, tol.start_xy, tol.start_theta])),
        jnp.asarray(u(N, P) * tol.fence_angle),
        jnp.asarray(u(N, P) * (tol.distance_abs + tol.distance_rel * dists))))
    g = np.asarray(plan.goal)
    pos = np.hypot(out[:, 0] - g[0], out[:, 1] - g[1])
    th = np.abs((out[:, 2] - g[2] + np.pi) % (2 * np.pi) - np.pi)
    # first order: the Monte-Carlo maximum stays below the bound (second-order terms are
    # ~tolerance^2 here) and the bound is not vacuous
    assert pos.max() <= b.position_m * (1 + 1e-3), (pos.max(), b)
    assert th.max() <= b.theta_rad * (1 + 1e-3) + 1e-15, (th.max(), b)
    assert pos.max() >= 0.3 * b.position_m


def test_tolerances_validated():
    with pytest.raises(ValueError, match="tau_v"):
        GeometryTolerance(tau_v=-1.0)
    with pytest.raises(ValueError, match="fence_angle"):
        ExecutionTolerance(fence_angle=float("nan"))


@pytest.mark.slow
def test_tumble_first_order_bound_vs_monte_carlo():
    cube = make_polyhedron([[x, y, z] for x in (0, 0.02) for y in (0, 0.02) for z in (0, 0.02)])
    seq = []
    f = 0
    for _ in range(6):  # a walk over neighbouring faces
        f = cube.neighbors(f)[0] if not seq or cube.neighbors(f)[0] != seq[-1] else cube.neighbors(f)[1]
        seq.append(f)
    start = make_config(0.0, 0.0, 0.0, 0, dtype=jnp.float64)
    tau = 1e-6
    b = tumble_first_order_bound(cube.vertices, cube.com, cube.topology, start, seq, tau)
    rng = np.random.default_rng(3)
    V = cube.vertices[None] + rng.uniform(-tau, tau, (2000,) + cube.vertices.shape)
    geoms = jax.vmap(tumble_geometry, in_axes=(0, None, None))(jnp.asarray(V), jnp.asarray(cube.com),
                                                               cube.topology)
    final, ok = jax.vmap(replay, in_axes=(0, None, None))(geoms, start, jnp.asarray(seq, jnp.int32))
    nominal, _ = replay(tumble_geometry(jnp.asarray(cube.vertices), jnp.asarray(cube.com), cube.topology),
                        start, jnp.asarray(seq, jnp.int32))
    dpos = np.hypot(*(np.asarray(final.xy) - np.asarray(nominal.xy)).T)
    dth = np.abs((np.asarray(final.theta) - float(nominal.theta) + np.pi) % (2 * np.pi) - np.pi)
    assert bool(np.all(ok))
    assert dpos.max() <= b.position_m * (1 + 1e-3)
    assert dth.max() <= b.theta_rad * (1 + 1e-3)
    assert dpos.max() >= 0.2 * b.position_m


@pytest.mark.slow
def test_paper_bounds_confronted_with_monte_carlo():
    """The Marigo-Bicchi bounds (eqs. 5, 6) against the Monte-Carlo maximum on the same part,
    plan and vertex tolerance.  Findings, asserted so that a change shows up:
    on the 10 cm cube both hold; on the irregular polyhedron eq. (5) holds (vacuously, ~1e10 rad)
    but eq. (6) evaluated in metres (d_max < 1 raised to the power 2N) collapses to ~1e-140 m and
    is violated by the real error; the first-order bound holds on both."""
    import warnings

    from planning.tumbling.planner import plan_tumble
    from robustness.bounds import tumble_plan_paper_bounds
    from robustness import (BoundViolation, ExecutionTolerance, FrictionRange, GeometryTolerance,
                            Sampler, evaluate)
    from tests.polyhedra import example

    tau = 1e-5
    sampler = Sampler(GeometryTolerance(tau_v=tau), FrictionRange(), ExecutionTolerance())
    cases = {"cube": ((0.2, 0.0, 0.0, 0), True), "irregular_polyhedron": ((0.1, 0.05, 1.0, 2), False)}
    for name, (goal, paper_holds) in cases.items():
        v, com = example(name)
        plan = plan_tumble(v, goal, com=com, eps=1e-3)
        assert plan.verdict == "solved"
        pb = tumble_plan_paper_bounds(plan, tau)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            ev = evaluate(plan, sampler, 256, jax.random.PRNGKey(0), SuccessCriterion(1e-2, 1e-2),
                          model="exact")
            s = ev.summary   # the summary (built when first read) confronts the bounds
        assert s["paper_bound_position_m"] == pytest.approx(pb["Delta_C_f"])
        assert s["bound_violated"] is False          # first order holds
        assert s["paper_bound_violated"] is (not paper_holds)
        loud = [w for w in caught if issubclass(w.category, BoundViolation)]
        assert bool(loud) is (not paper_holds)
        if not paper_holds:
            assert "eq. 6" in str(loud[0].message)
