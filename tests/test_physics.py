"""Physics rollouts (robustness.physics) on the C engine: tiny batches.

The MJX backend has its own file (tests/test_physics_mjx.py: one CPU smoke
test, the rest need an accelerator).
"""
import dataclasses
import inspect
import math
import pathlib
import re
import warnings

import jax
import numpy as np
import pytest

from kernels import polygon as pg
from planning import plan_pose, plan_tumble
from robustness import ExecutionTolerance, FrictionRange, GeometryTolerance, Sampler, evaluate
from robustness.physics import (PhysicsSettings, PushRollout, RolloutVerdict, TumbleRollout,
                                rollout_push_plan, rollout_tumble_plan)
from robustness.physics import geometry as geo
from robustness.physics.monitor import mat_to_quat, quat_to_mat, yaw_tilt
from robustness.physics.schedule import Phase, Schedule
from sweeps.partfile import load_part

EXAMPLES = pathlib.Path(__file__).resolve().parents[1] / "examples"


def _part(name):
    return load_part(EXAMPLES / f"{name}.yaml")


def _push_params(plan, sampler, n=1, seed=0):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", pg.PartWarning)
        poly = pg.make_polygon(np.asarray(plan.vertices), np.asarray(plan.com))
    return sampler.sample(jax.random.key(seed), n, n_vertices=len(plan.vertices), dim=2,
                          n_pushes=plan.n_pushes, body=poly.body)


def _single_push(plan, k, distance=None):
    """Plan made of push ``k`` of ``plan`` alone (optionally another distance)."""
    start = plan.start if k == 0 else plan.pushes[k - 1].pose_after
    push = plan.pushes[k]
    if distance is not None:
        push = dataclasses.replace(push, distance=float(distance))
    return dataclasses.replace(plan, start=tuple(start), goal=tuple(push.pose_after), pushes=(push,))


@pytest.fixture(scope="module")
def rectangle():
    return _part("rectangle")


@pytest.fixture(scope="module")
def reorient_plan(rectangle):
    """A single reorient push of the rectangle from the planner."""
    plan = plan_pose(rectangle.vertices, (0.0, 0.0, 0.0), (0.05, 0.05, 1.0), com=rectangle.com)
    k = next(i for i, p in enumerate(plan.pushes) if p.kind == "reorient")
    return _single_push(plan, k)


# --------------------------------------------------------------------------
# Pushes
# --------------------------------------------------------------------------
@pytest.mark.slow
def test_translating_box_neither_turns_nor_walks(rectangle):
    plan = plan_pose(rectangle.vertices, (0.0, 0.0, 0.0), (0.1, 0.0, 0.0), com=rectangle.com)
    assert [p.kind for p in plan.pushes] == ["translate"]
    sam = Sampler(friction=FrictionRange(mu_f=(0.8, 0.8), mu_s=(0.5, 0.5)))
    r = rollout_push_plan(plan, _push_params(plan, sam), backend="c")
    d = np.asarray(plan.pushes[0].direction)
    sideways = abs(-d[1] * r.x[0] + d[0] * r.y[0])
    assert sideways < 1e-4                       # < 0.1 mm over 10 cm
    assert abs(r.theta[0]) < math.radians(0.05)
    assert r.edges[0, 0] == r.planned_edges[0]
    assert r.success[0] and r.failure_mode[0] == "none"
    assert r.slip[0] < 1e-4 and not r.fence_strike[0] and not r.tipped[0]


@pytest.fixture(scope="module")
def reorient_rollout(reorient_plan):
    """The reorient push rolled out once (one sample, sticking friction)."""
    sam = Sampler(friction=FrictionRange(mu_f=(1.5, 1.5), mu_s=(0.5, 0.5)))
    return rollout_push_plan(reorient_plan, _push_params(reorient_plan, sam), backend="c")


def test_reorient_push_ends_flush_on_planned_edge(reorient_rollout):
    r = reorient_rollout
    assert r.complete[0, 0] and r.edges[0, 0] == r.planned_edges[0]
    assert abs(r.err_theta[0]) < math.radians(0.2)
    assert r.err_pos[0] < 1e-3


@pytest.mark.slow
def test_push_shorter_than_half_peshkin_stays_incomplete(reorient_plan):
    push = reorient_plan.pushes[0]
    peshkin = push.min_distance / reorient_plan.options.safety_factor
    plan = _single_push(reorient_plan, 0, distance=0.45 * peshkin)
    body = pg.make_polygon(np.asarray(plan.vertices), np.asarray(plan.com)).body
    a = float(np.max(np.linalg.norm(body, axis=1)))
    sam = Sampler(friction=FrictionRange(mu_f=(1.5, 1.5), c=(a, a)))   # the slowest rotation
    r = rollout_push_plan(plan, _push_params(plan, sam), backend="c")
    assert not r.complete[0, 0] and r.edges[0, 0] == -1
    assert r.failure_mode[0] == "incomplete_reorientation"
    qs = evaluate(plan, sam, 1, jax.random.key(0), model="quasistatic", bound=False).samples
    assert qs["n_incomplete"].iloc[0] == 1


@pytest.mark.slow
def test_sticking_push_agrees_with_quasistatic_model(reorient_plan):
    sam = Sampler(friction=FrictionRange(mu_f=(1.5, 1.5), mu_s=(0.5, 0.5)))
    key = jax.random.key(3)
    qs = evaluate(reorient_plan, sam, 1, key, model="quasistatic", bound=False).samples
    assert qs["slip_m"].iloc[0] == 0.0               # the model predicts sticking
    params = _push_params(reorient_plan, sam, seed=3)
    r = rollout_push_plan(reorient_plan, params, backend="c", stroke="contact")
    dpos = math.hypot(r.x[0] - qs["final_x_m"].iloc[0], r.y[0] - qs["final_y_m"].iloc[0])
    assert dpos < 2e-4
    assert abs(r.theta[0] - qs["final_theta_rad"].iloc[0]) < math.radians(0.2)


@pytest.mark.slow
def test_row_semantics_match_the_exact_model(rectangle):
    """Centre-of-mass offset, start and fence errors: the physics row of a
    sample and its exact-model row describe the same part and execution."""
    plan = plan_pose(rectangle.vertices, (0.0, 0.0, 0.0), (0.08, 0.0, 0.0), com=rectangle.com)
    sam = Sampler(geometry=GeometryTolerance(tau_com=0.002),
                  friction=FrictionRange(mu_f=(1.5, 1.5), mu_s=(0.5, 0.5)),
                  execution=ExecutionTolerance(start_xy=0.001, start_theta=math.radians(2),
                                               fence_angle=math.radians(0.5)))
    key = jax.random.key(7)
    ex = evaluate(plan, sam, 2, key, model="exact", bound=False).samples
    params = sam.sample(key, 2, n_vertices=4, dim=2, n_pushes=1,
                        body=pg.make_polygon(rectangle.vertices, rectangle.com).body)
    r = rollout_push_plan(plan, params, backend="c", stroke="contact")
    np.testing.assert_allclose(r.x, ex["final_x_m"], atol=3e-4)
    np.testing.assert_allclose(r.y, ex["final_y_m"], atol=3e-4)
    np.testing.assert_allclose(r.theta, ex["final_theta_rad"], atol=math.radians(0.2))


# --------------------------------------------------------------------------
# Tumbles
# --------------------------------------------------------------------------
@pytest.fixture(scope="module")
def cube_plan():
    cube = _part("cube")
    plan = plan_tumble(cube.vertices, (-0.2, 0.0, -math.pi / 2, 5), com=cube.com, eps=1e-3)
    assert plan.verdict == "solved" and plan.n_tumbles == 2
    return plan


@pytest.fixture(scope="module")
def cube_rollout(cube_plan):
    """The cube's two tumbles rolled out once (one sample, the pads gripping)."""
    sam = Sampler(friction=FrictionRange(mu_f=(1.5, 1.5), mu_s=(1.5, 1.5)))
    params = sam.sample(jax.random.key(0), 1, n_vertices=8, dim=3, n_tumbles=cube_plan.n_tumbles)
    return rollout_tumble_plan(cube_plan, params, backend="c")


def test_cube_tumbles_land_the_planned_faces(cube_plan, cube_rollout):
    r = cube_rollout
    assert r.faces_ok[0] and list(r.faces[0]) == list(cube_plan.faces)
    assert r.face[0] == cube_plan.goal[3]
    assert r.err_pos[0] < 1.5e-3 and abs(r.err_theta[0]) < math.radians(0.2)
    assert np.all(r.slip_per_tumble[0] < 1e-3)


def test_rollouts_are_frozen_records_of_the_documented_fields(reorient_rollout, cube_rollout):
    """The rollouts' records (robustness.physics.rollouts): typed, frozen, and exactly
    the fields their docstrings list (a field added or dropped fails here first)."""
    verdict = ("err_x", "err_y", "err_pos", "err_theta", "success", "failure_mode", "backend",
               "steps", "seconds")
    push = verdict + ("x", "y", "theta", "pose_after", "edges", "complete", "planned_edges",
                      "slip", "slip_per_push", "contact", "max_tilt", "final_tilt", "tipped",
                      "toppled", "fence_strike", "left_workspace", "hull_changed", "simulated",
                      "support_ok", "support", "c", "c_support", "c_physical")
    tumble = verdict + ("x", "y", "theta", "face", "faces", "planned_faces", "faces_ok",
                        "n_wrong_faces", "slip", "slip_per_tumble", "left_workspace",
                        "combinatorics_changed", "simulated", "grip_n")

    def documented(cls):
        doc = inspect.cleandoc(cls.__doc__).split("Attributes", 1)[1].split(":\n", 1)[1]
        return tuple(n for m in re.finditer(r"^  (\w+(?:, \w+)*): ", doc, re.M)
                     for n in m.group(1).split(", "))

    assert documented(RolloutVerdict) == verdict
    for r, cls, names in ((reorient_rollout, PushRollout, push),
                          (cube_rollout, TumbleRollout, tumble)):
        assert type(r) is cls and isinstance(r, RolloutVerdict)
        assert tuple(f.name for f in dataclasses.fields(r)) == names
        assert verdict + documented(cls) == names   # each field documented, in order
        with pytest.raises(dataclasses.FrozenInstanceError):
            r.x = np.zeros(1)
        with pytest.raises(TypeError):   # a missing (or extra) field fails loudly
            cls(**{n: getattr(r, n) for n in names[1:]})
    assert reorient_rollout.backend == "c" and isinstance(reorient_rollout.steps, int)


def test_tumble_rows_match_the_exact_model(cube_plan):
    """Perturbed centre of mass, start position error and slips after each
    tumble: the physics row lands where the exact model's does, up to the
    pivot slips (~0.4 mm per tumble)."""
    sam = Sampler(geometry=GeometryTolerance(tau_com=0.003),
                  friction=FrictionRange(mu_f=(1.5, 1.5), mu_s=(1.5, 1.5)),
                  execution=ExecutionTolerance(start_xy=0.002, tumble_slip_xy=0.001))
    key = jax.random.key(5)
    ex = evaluate(cube_plan, sam, 1, key, bound=False).samples
    params = sam.sample(key, 1, n_vertices=8, dim=3, n_tumbles=cube_plan.n_tumbles)
    r = rollout_tumble_plan(cube_plan, params, backend="c")
    assert r.face[0] == ex["final_face"].iloc[0]
    dpos = math.hypot(r.x[0] - ex["final_x_m"].iloc[0], r.y[0] - ex["final_y_m"].iloc[0])
    assert dpos <= 1.5e-3
    assert abs(r.theta[0] - ex["final_theta_rad"].iloc[0]) < math.radians(0.1)


def test_rolling_plate_squares_a_yawed_cube(cube_plan):
    """A finding, not a model: dragged along the planned direction, a cube
    placed 0.44 degrees off turns square to the plate's motion; the exact
    kinematics keep the error."""
    sam = Sampler(friction=FrictionRange(mu_f=(1.5, 1.5), mu_s=(1.5, 1.5)),
                  execution=ExecutionTolerance(start_theta=math.radians(1)))
    key = jax.random.key(5)
    ex = evaluate(cube_plan, sam, 1, key, bound=False).samples
    params = sam.sample(key, 1, n_vertices=8, dim=3, n_tumbles=cube_plan.n_tumbles)
    r = rollout_tumble_plan(cube_plan, params, backend="c")
    assert abs(ex["err_theta_rad"].iloc[0]) > math.radians(0.3)
    assert abs(r.err_theta[0]) < 0.25 * abs(ex["err_theta_rad"].iloc[0])


def test_tumble_cell_is_a_gripper(cube_plan):
    """The upper plate and the lower jaw are a gripper's plates (a few part
    diameters across, not the floor); the jaw covers every hull vertex's
    nominal path over the plan."""
    from robustness.physics import scene
    from robustness.physics import tumbling as tb

    s = PhysicsSettings()
    poly = tb.nominal_polyhedron(cube_plan)
    _, plate_half, jaw, grip = tb.tumble_schedule(cube_plan, poly, s, tb.part_mass(poly, s))
    diam = math.sqrt(3) * 0.1
    assert 1.0 * diam < 2 * plate_half < 3.0 * diam
    assert all(0.1 + 0.2 * diam <= 2 * h + 1e-9 and 2 * h < 4.0 * diam for h in jaw.half)
    lo = np.subtract(jaw.centre, jaw.half)
    hi = np.add(jaw.centre, jaw.half)
    for cfg in tb.nominal_configs(cube_plan, poly):
        R, t = tb.face_pose(poly.face_origins[int(cfg[3])], poly.face_rotations[int(cfg[3])], cfg)
        xy = (np.asarray(poly.vertices) @ R.T + t)[:, :2]
        assert np.all(xy >= lo) and np.all(xy <= hi)
    m = scene.tumble_model(np.asarray(poly.vertices), np.asarray(poly.com), 1.0, [1e-3] * 3 + [0] * 3,
                           1.5, 1.5, plate_half, jaw, grip, s, s.impratio)
    assert np.allclose(m.geom("support").size[:2], jaw.half)
    assert np.allclose(m.geom("support").pos[:2], jaw.centre)


def test_support_contact_off_the_jaw_leaves_the_workspace():
    """The monitor's jaw: a point at the support's height outside the jaw's
    rectangle leaves the workspace; inside it, or lifted, it does not."""
    from robustness.physics.monitor import Recorder
    from robustness.physics.scene import Layout

    lay = Layout(nstate=8, nu=0, nsensordata=0, part_qpos=0, tool_qpos=0, part_qvel=0,
                 tool_contact=0, foot_pairs=(), tool_pair=0)
    sched = Schedule((Phase("final", -1, 2, np.zeros(4), np.zeros(4)),), 0.001)
    pts = np.array([[[0.05, 0.0, 0.0], [0.0, 0.0, 0.3]]] * 3)
    rec = Recorder(sched, lay, 3, (-10, 10, -10, 10), keep=[], support=(pts, (-0.1, 0.1, -0.1, 0.1)))
    st = np.zeros((3, 2, 8))
    st[:, :, 3] = 1.0                       # identity quaternions
    st[0, 1, 0] = 0.02                      # the low point at x = 0.07: on the jaw
    st[1, 1, 0] = 0.08                      # at x = 0.13: off the jaw, touching
    st[2, 1, 0], st[2, 1, 2] = 0.08, 0.01   # off the jaw but 1 cm up
    rec.update(0, st, np.zeros((3, 2, 0)))
    assert list(rec.left) == [False, True, False]


def test_tumble_slipped_off_the_jaw_is_reported(cube_plan):
    """End to end: a slip after the first tumble that carries the cube past
    the jaw's edge is a left_workspace failure even when the centre of mass's
    workspace is the whole world (the support the part lands on is the jaw,
    not an infinite floor)."""
    sam = Sampler(friction=FrictionRange(mu_f=(1.5, 1.5), mu_s=(1.5, 1.5)),
                  execution=ExecutionTolerance(tumble_slip_xy=0.4))
    params = sam.sample(jax.random.key(3), 2, n_vertices=8, dim=3, n_tumbles=cube_plan.n_tumbles)
    slip = np.broadcast_to(np.asarray(params.params.execution.tumble_slip), (2, cube_plan.n_tumbles, 3))
    assert np.all(np.abs(slip[:, 0, :2]).max(axis=1) > 0.08)   # past the jaw's 1.7 cm margin
    r = rollout_tumble_plan(cube_plan, params, backend="c", workspace=(-10, 10, -10, 10))
    assert r.left_workspace.all() and list(r.failure_mode) == ["left_workspace"] * 2


# --------------------------------------------------------------------------
# Bad input
# --------------------------------------------------------------------------
def test_bad_input_is_named(reorient_plan, cube_plan):
    sam = Sampler()
    params = _push_params(reorient_plan, sam)
    with pytest.raises(ValueError, match="backend"):
        rollout_push_plan(reorient_plan, params, backend="gpu")
    with pytest.raises(ValueError, match="stroke"):
        rollout_push_plan(reorient_plan, params, stroke="closed")
    with pytest.raises(ValueError, match="draws: expected at least one sample"):
        rollout_push_plan(reorient_plan, params.slice(0, 0))
    with pytest.raises(ValueError, match="draws: expected the Draws of Sampler.sample"):
        rollout_push_plan(reorient_plan, params.params)
    with pytest.raises(ValueError, match="plan: has no pushes"):
        rollout_push_plan(dataclasses.replace(reorient_plan, pushes=()), params)
    with pytest.raises(ValueError, match="plan: has no tumbles"):
        rollout_tumble_plan(dataclasses.replace(cube_plan, tumbles=()), params)
    with pytest.raises(ValueError, match="timestep"):
        PhysicsSettings(timestep=0.0)
    with pytest.raises(ValueError, match="foot_radius"):
        PhysicsSettings(foot_radius=0.002)
    with pytest.raises(ValueError, match="noslip_iterations: 0"):
        rollout_push_plan(reorient_plan, params, backend="mjx")


# --------------------------------------------------------------------------
# Helpers (fast)
# --------------------------------------------------------------------------
def test_mass_properties_of_a_box_and_a_cube():
    b = np.array([[-0.02, -0.01], [0.02, -0.01], [0.02, 0.01], [-0.02, 0.01]])
    m, inertia = geo.prism_mass_properties(b, 0.003, 7800.0)
    assert m == pytest.approx(0.04 * 0.02 * 0.003 * 7800.0)
    np.testing.assert_allclose(inertia[:3], m / 12 * np.array([0.02 ** 2 + 0.003 ** 2,
                                                               0.04 ** 2 + 0.003 ** 2,
                                                               0.04 ** 2 + 0.02 ** 2]))
    V = np.array([[x, y, z] for x in (-0.05, 0.05) for y in (-0.05, 0.05) for z in (-0.05, 0.05)])
    m, inertia = geo.polyhedron_mass_properties(V, np.zeros(3), 500.0)
    assert m == pytest.approx(0.5)
    np.testing.assert_allclose(inertia, [m * 0.1 ** 2 / 6] * 3 + [0, 0, 0], atol=1e-12)


def test_schedule_controls_are_linear_targets_with_their_velocity():
    a = np.array([[0.0, 0.0, 0.01, 0.0], [1.0, 0.0, 0.01, 0.5]])
    b = a + np.array([0.01, -0.02, 0.0, 0.1])
    sched = Schedule([Phase("push", 0, 10, a, b), Phase("dwell", 0, 6, b, b, hook=True)], 0.01)
    assert sched.total == 16 and sched.hook_ends() == {16: 1}
    u = np.concatenate([sched.controls(0, 7, 2), sched.controls(7, 16, 2)], axis=1)
    np.testing.assert_allclose(u[:, 9, :4], b)
    np.testing.assert_allclose(u[:, 10:, :4], np.repeat(b[:, None], 6, axis=1))
    np.testing.assert_allclose(u[:, :10, 4:], np.repeat(((b - a) / 0.1)[:, None], 10, axis=1))
    np.testing.assert_allclose(u[:, 10:, 4:], 0.0)
    # targets integrate their velocities
    np.testing.assert_allclose(a + u[:, :10, 4:].sum(axis=1) * 0.01, b)


def test_quaternion_helpers_round_trip():
    rng = np.random.default_rng(0)
    q = rng.normal(size=(5, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    q *= np.sign(q[:, :1])
    back = mat_to_quat(quat_to_mat(q))
    back *= np.sign(back[:, :1])                 # q and -q are the same rotation
    np.testing.assert_allclose(back, q, atol=1e-12)
    yaw, tilt = yaw_tilt(np.array([[math.cos(0.3), 0, 0, math.sin(0.3)]]))
    assert yaw[0] == pytest.approx(0.6) and tilt[0] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.slow
def test_batches_do_not_change_the_rows(rectangle):
    plan = plan_pose(rectangle.vertices, (0.0, 0.0, 0.0), (0.02, 0.0, 0.0), com=rectangle.com)
    sam = Sampler(friction=FrictionRange(mu_f=(0.5, 1.0), mu_s=(0.4, 0.6)),
                  execution=ExecutionTolerance(start_xy=5e-4))
    params = _push_params(plan, sam, n=2)
    a = rollout_push_plan(plan, params, backend="c")
    b = rollout_push_plan(plan, params, backend="c", settings=PhysicsSettings(batch=1))
    for k in ("x", "y", "theta", "slip", "edges"):
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k))
    with pytest.raises(ValueError, match=r"draws: the sampled params hold \[2\] samples, not n=3"):
        rollout_push_plan(plan, dataclasses.replace(params, n=3), backend="c")


def test_auto_never_changes_the_contact_model():
    from robustness.physics.runner import resolve_backend

    assert resolve_backend("auto", PhysicsSettings()) == "c"     # noslip: only the C engine
    assert resolve_backend("c", PhysicsSettings(noslip_iterations=0)) == "c"
    with pytest.raises(ValueError, match="noslip_iterations: 0"):
        resolve_backend("mjx", PhysicsSettings())


def test_pad_friction_is_derived_per_part():
    """The tumble device's pad friction from the moments about the pivot edge
    (tumbling.pad_friction_needed): a cube needs 1 + 1/(2 ratio) on the upper
    pad, a 1 x 1 x 2 box rolled over its short edge lying flat 2 + 1/(2 ratio);
    the lower pad that times ratio / (ratio + 1)."""
    import itertools

    from kernels.polyhedron import make_polyhedron
    from robustness.physics.settings import check_pad_friction
    from robustness.physics.tumbling import pad_friction_needed

    cube = make_polyhedron(np.array(list(itertools.product([0, 0.1], repeat=3)), float))
    for r in (2.0, 4.0):
        top, bottom = pad_friction_needed(cube, r)
        assert top == pytest.approx(1 + 1 / (2 * r)) and bottom == pytest.approx(top * r / (r + 1))
    box = make_polyhedron(np.array(list(itertools.product([0, 0.1], [0, 0.1], [0, 0.2])), float))
    assert pad_friction_needed(box, 2.0)[0] == pytest.approx(2.25 + 0.25)
    check_pad_friction(FrictionRange(mu_f=(1.3, 1.3), mu_s=(0.9, 0.9)), "tumble", cube)
    with pytest.raises(ValueError, match="friction.mu_f: .*upper pad needs .* >= 2.55"):
        check_pad_friction(FrictionRange(mu_f=(1.3, 1.3), mu_s=(1.8, 1.8)), "tumble", box)


def test_pads_below_the_derived_friction_drag_the_cube(cube_plan):
    """The derivation checked in MuJoCo: the cube rolls with the upper pad at 1.3
    (>= 1.25) and does not at 1.2."""
    ok = {}
    for mu in (1.2, 1.3):
        sam = Sampler(friction=FrictionRange(mu_f=(mu, mu), mu_s=(1.5, 1.5)))
        params = sam.sample(jax.random.key(0), 1, n_vertices=8, dim=3,
                            n_tumbles=cube_plan.n_tumbles)
        ok[mu] = bool(rollout_tumble_plan(cube_plan, params, backend="c").faces_ok[0])
    assert ok == {1.2: False, 1.3: True}
