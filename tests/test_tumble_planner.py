"""Tests for the Marigo-Bicchi tumble planner (plan_tumble, TumblePlan).

Every returned plan is re-checked here independently of the planner: its
tumbles are replayed by the JAX kernel from the start, each tumble's edge must
be the edge shared by the face on the plane and the landing face, and the
error is recomputed in the paper's metric.
"""
from __future__ import annotations

import json
import math

import jax


import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from kernels.polyhedron import make_polyhedron  # noqa: E402
from kernels.tumble import make_config, replay  # noqa: E402
from planning.tumbling.plan import Tumble, TumblePlan, config_error  # noqa: E402
from planning.tumbling.planner import analyze_polyhedron, plan_tumble  # noqa: E402

from tests.polyhedra import box, example, random_polyhedron

pytestmark = pytest.mark.float64  # calls kernels on float64 arrays directly
A_CUBE = 0.1




def check_plan(plan: TumblePlan, V, com=None):
    """Independent verification: edges, kernel replay, error."""
    P = make_polyhedron(V, com)
    f = plan.start[3]
    for t in plan.tumbles:
        assert t.face in P.neighbors(f)
        assert t.edge == P.shared_edge(f, t.face)
        f = t.face
    n = len(plan.tumbles)
    size = 256
    while size < n:  # pad with no-ops to a few fixed lengths: one compilation each
        size *= 16
    faces = np.full(size, -1, dtype=np.int32)
    faces[:n] = [t.face for t in plan.tumbles]
    s = plan.start
    final, ok = replay(P.geometry(jnp.float64), make_config(*s, dtype=jnp.float64), jnp.asarray(faces))
    assert bool(ok)
    cfg = (float(final.xy[0]), float(final.xy[1]), float(final.theta), int(final.face))
    assert config_error(cfg, plan.predicted_final) < 1e-9
    err = config_error(cfg, plan.goal)
    assert err == pytest.approx(plan.error, abs=1e-9)
    if plan.verdict == "solved":
        assert err <= plan.eps
    return err


def reachable_goal(A, rng, length=30):
    w, f = [], A.start_face
    for _ in range(length):
        f = int(rng.choice(A.table.neighbors[f]))
        w.append(f)
    m = A.table.word_motion(A.start_face, w)
    return (m.z.real, m.z.imag, math.remainder(m.angle, 2 * math.pi), f)


# ---------------------------------------------------------------------------
def test_cube_two_edges_exact():
    V, com = example("cube")
    plan = plan_tumble(V, (2 * A_CUBE, 0.0, 0.0, 0), com=com, eps=1e-3)
    assert plan.verdict == "solved"
    assert plan.error < 1e-12
    assert plan.n_tumbles <= 8
    assert plan.n_tumbles < plan.n_tumbles_paper
    assert plan.reachable_class == "discrete"
    check_plan(plan, V, com)


def test_cube_parity_and_headings():
    V, com = example("cube")
    # one edge away with the same heading: the checkerboard forbids it
    p = plan_tumble(V, (A_CUBE, 0.0, 0.0, 0), com=com, eps=1e-3)
    assert p.verdict == "not_solvable" and "position residual" in p.reason
    assert "lattice mesh too coarse" in p.reason
    check_plan(p, V, com)
    # ... but with a quarter turn it is reachable
    q = plan_tumble(V, (A_CUBE, 0.0, math.pi / 2, 0), com=com, eps=1e-3)
    assert q.verdict == "solved" and q.error < 1e-12 and q.n_tumbles <= 4
    check_plan(q, V, com)
    # a heading that is not a multiple of pi/2
    r = plan_tumble(V, (2 * A_CUBE, 0.0, 0.3, 0), com=com, eps=1e-3)
    assert r.verdict == "not_solvable" and "orientation residual" in r.reason
    assert "beta = pi/2" in r.reason and "orientation grid too coarse" in r.reason
    # a coarse eps accepts the nearest lattice point
    s = plan_tumble(V, (2 * A_CUBE + 0.01, 0.0, 0.0, 0), com=com, eps=0.02)
    assert s.verdict == "solved" and s.error == pytest.approx(0.01, abs=1e-12)


@pytest.mark.parametrize("name", ["cube", "tetrahedron", "octahedron"])
def test_discrete_reachable_goals_solved_exactly(name):
    V, com = example(name)
    A = analyze_polyhedron(V, com)
    rng = np.random.default_rng(11)
    for _ in range(4):
        goal = reachable_goal(A, rng)
        plan = plan_tumble(V, goal, com=com, eps=1e-6)
        assert plan.verdict == "solved", plan.reason
        assert plan.error < 1e-9
        assert plan.n_tumbles <= plan.n_tumbles_paper
        check_plan(plan, V, com)


def test_tetrahedron_headings_and_positions():
    """Heading 0: 2 L; heading pi: 2 c0 + 2 L (see test_tumble_reachability)."""
    V, com = example("tetrahedron")
    A = analyze_polyhedron(V, com)
    C = np.asarray(A.polyhedron.geometry(jnp.float64).corners_2d)[0]
    c0, c1 = complex(*C[0]), complex(*C[1])
    e1 = c1 - c0
    ok = plan_tumble(V, ((2 * e1).real, (2 * e1).imag, 0.0, 0), eps=1e-6)
    assert ok.verdict == "solved" and ok.error < 1e-9
    bad = plan_tumble(V, (e1.real, e1.imag, 0.0, 0), eps=1e-6)
    assert bad.verdict == "not_solvable" and "position residual" in bad.reason
    half = plan_tumble(V, ((2 * c0).real, (2 * c0).imag, math.pi, 0), eps=1e-6)
    assert half.verdict == "solved" and half.error < 1e-9
    no = plan_tumble(V, (0.0, 0.0, math.pi, 0), eps=1e-6)
    assert no.verdict == "not_solvable"
    no2 = plan_tumble(V, (0.0, 0.0, math.pi / 2, 0), eps=1e-6)
    assert no2.verdict == "not_solvable" and "orientation residual" in no2.reason
    for p in (ok, bad, half, no):
        check_plan(p, V, com)


@pytest.mark.parametrize("name", ["truncated_pyramid", "box_incommensurable"])
def test_dense_random_goals(name):
    if name == "box_incommensurable":
        V, com = box(0.1, 0.1 * math.sqrt(2), 0.1 * math.sqrt(3)), None
    else:
        V, com = example(name)
    A = analyze_polyhedron(V, com)
    assert A.reachable_class == "dense"
    rng = np.random.default_rng(7)
    for _ in range(5):
        G = int(rng.integers(A.polyhedron.n_faces))
        th = rng.uniform(-math.pi, math.pi)
        if A.all_rational:  # headings of face G: development angle + k pi/2
            aL = A.development[G][2]
            th = aL + round((th - aL) / (math.pi / 2)) * math.pi / 2
        goal = (rng.uniform(-0.4, 0.4), rng.uniform(-0.4, 0.4), math.remainder(th, 2 * math.pi), G)
        plan = plan_tumble(V, goal, com=com, eps=1e-2)
        assert plan.verdict == "solved", plan.reason
        assert plan.n_tumbles_paper > 100 * plan.n_tumbles
        check_plan(plan, V, com)


@pytest.mark.parametrize("seed", range(4))
def test_random_polyhedra_plans_verified(seed):
    V = random_polyhedron(seed, (6, 8)[seed % 2])
    rng = np.random.default_rng(100 + seed)
    A = analyze_polyhedron(V)
    for _ in range(3):
        G = int(rng.integers(A.polyhedron.n_faces))
        goal = (rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3), rng.uniform(-3, 3), G)
        plan = plan_tumble(V, goal, eps=1e-2)
        err = check_plan(plan, V)
        if plan.verdict == "solved":
            assert err <= 1e-2
        else:
            assert plan.reason
    # irregular polyhedron of the examples too
    V2, com2 = example("irregular_polyhedron")
    plan = plan_tumble(V2, (0.2, -0.1, 1.0, 4), com=com2, eps=1e-2)
    assert plan.verdict == "solved"
    check_plan(plan, V2, com2)


def test_shortening_never_breaks_verification():
    V, com = example("octahedron")
    A = analyze_polyhedron(V, com)
    rng = np.random.default_rng(5)
    for _ in range(4):
        goal = reachable_goal(A, rng, length=20)
        short = plan_tumble(V, goal, com=com, eps=1e-6)
        paper = plan_tumble(V, goal, com=com, eps=1e-6, shorten=False)
        assert paper.verdict == "solved" and short.verdict == "solved"
        assert paper.n_tumbles == paper.n_tumbles_paper
        assert short.n_tumbles <= paper.n_tumbles
        check_plan(short, V, com)
        check_plan(paper, V, com)


def test_start_face_and_pose():
    V, com = example("cube")
    start = (0.3, -0.2, 0.7, 3)
    A = analyze_polyhedron(V, com, start_face=3)
    assert A.start_face == 3 and A.transit_paths[3] == ()
    # goal = start moved by a reachable word, expressed in the world
    rng = np.random.default_rng(2)
    x, y, th, f = reachable_goal(A, rng)
    c, s = math.cos(start[2]), math.sin(start[2])
    goal = (start[0] + c * x - s * y, start[1] + s * x + c * y, math.remainder(start[2] + th, 2 * math.pi), f)
    plan = plan_tumble(V, goal, start=start, com=com, eps=1e-6)
    assert plan.verdict == "solved" and plan.error < 1e-9
    check_plan(plan, V, com)


def test_tau_v_step5_checks():
    V, com = example("cube")
    goal = (2 * A_CUBE, 0.0, 0.0, 0)
    tight = plan_tumble(V, goal, com=com, eps=1e-3, tau_v=1e-6)
    assert tight.error < 1e-12  # the plan itself is exact ...
    assert tight.verdict == "not_solvable" and "step 5" in tight.reason  # ... but not certifiable
    assert tight.bounds["Delta_beta"] == pytest.approx(2 * 5 * 1e-6 / 0.1)
    assert tight.bounds["Delta_theta_f"] > 1e-3
    loose = plan_tumble(V, goal, com=com, eps=0.05, tau_v=1e-6)
    assert loose.verdict == "solved"
    for key in ("Delta_D", "Delta_beta", "Delta_gen", "E", "U_max", "Delta_theta_f", "Delta_C_f",
                "tumbles_L_f", "tumbles_R_bar_k", "tumbles_translation", "lattice_mesh_Delta", "beta"):
        assert isinstance(loose.bounds[key], float)


def test_tau_g_lattice_approximation():
    V, com = example("irregular_polyhedron")
    A = analyze_polyhedron(V, com, tau_g=1e-2)
    assert A.tau_g_used == 1e-2 and A.rank == 2 and A.mesh_area > 0
    for g in A.translation_generators:
        a, b = g["vector_rational"]
        va = np.array(A.translation_generators[A.coefficient_basis[0]]["vector_closed_form"])
        vb = np.array(A.translation_generators[A.coefficient_basis[1]]["vector_closed_form"])
        coef = np.linalg.solve(np.stack([va, vb], 1), np.array(g["vector_closed_form"]))
        assert abs(float(a) - coef[0]) <= 1e-2 + 1e-12 and abs(float(b) - coef[1]) <= 1e-2 + 1e-12
    plan = plan_tumble(V, (0.1, 0.1, 0.5, 2), com=com, eps=1e-2, tau_g=1e-2)
    check_plan(plan, V, com)


def test_plan_round_trip_and_summary():
    V, com = example("octahedron")
    plan = plan_tumble(V, (0.0, 0.0, 0.0, 5), com=com, eps=1e-3)
    d = json.loads(json.dumps(plan.to_dict()))
    back = TumblePlan.from_dict(d)
    assert back == plan
    assert back.n_tumbles == plan.n_tumbles
    assert Tumble.from_dict(plan.tumbles[0].to_dict()) == plan.tumbles[0] if plan.tumbles else True
    s = plan.summary()
    assert plan.verdict in s and "paper" in s
    # huge paper counts survive JSON as exact ints
    V2, com2 = example("irregular_polyhedron")
    p2 = plan_tumble(V2, (0.1, 0.0, 0.0, 1), com=com2, eps=1e-2)
    back2 = TumblePlan.from_dict(json.loads(json.dumps(p2.to_dict())))
    assert back2.n_tumbles_paper == p2.n_tumbles_paper > 10**12


def test_analysis_is_cached():
    V, com = example("cube")
    assert analyze_polyhedron(V, com) is analyze_polyhedron(np.array(V), com)
    assert analyze_polyhedron(V, com, start_face=2) is not analyze_polyhedron(V, com)


@pytest.mark.parametrize("kwargs, match", [
    (dict(goal=(0.1, 0.0, 0.0)), "goal: expected 4 entries"),
    (dict(goal=(0.1, float("nan"), 0.0, 0)), "goal: y"),
    (dict(goal=(0.1, 0.0, 0.0, 6)), "goal: face 6 is out of range"),
    (dict(goal=(0.1, 0.0, 0.0, 1.5)), "goal: face"),
    (dict(goal=(0.1, 0.0, 0.0, 0), start=(0.0, 0.0, 0.0, -1)), "start: face -1"),
    (dict(goal=(0.1, 0.0, 0.0, 0), start=(0.0, 0.0)), "start: expected 4"),
    (dict(goal=(0.1, 0.0, 0.0, 0), eps=0.0), "eps: must be"),
    (dict(goal=(0.1, 0.0, 0.0, 0), eps=float("nan")), "eps: must be"),
    (dict(goal=(0.1, 0.0, 0.0, 0), tau_v=-1e-6), "tau_v: must be"),
    (dict(goal=(0.1, 0.0, 0.0, 0), tau_g=-0.1), "tau_g: must be"),
    (dict(goal=(0.1, 0.0, 0.0, 0), tau_v=float("inf")), "tau_v: must be"),
])
def test_bad_inputs(kwargs, match):
    V, com = example("cube")
    with pytest.raises(ValueError, match=match):
        plan_tumble(V, com=com, **kwargs)


def test_bad_parts_use_kernel_errors():
    with pytest.raises(ValueError, match="vertices"):
        plan_tumble([[0, 0, 0], [1, 0, 0], [0, 1, 0]], (0, 0, 0, 0))
    with pytest.raises(ValueError, match="com"):
        plan_tumble(example("cube")[0], (0, 0, 0, 0), com=[1.0, 1.0, 1.0])
    with pytest.raises(ValueError, match="start_face"):
        analyze_polyhedron(example("cube")[0], start_face=9)
