"""Support families (kernels.support): one definition drawn by the
quasi-static sampler and realised by the MuJoCo scene.

References: scipy's linear programme for the rigid corner loads, a
non-negative least-squares solve for the equal-spring loads, geometry for
"inside the outline", and the C engine's own contact forces for the scene.
"""
import itertools
import pathlib
import warnings

import hypothesis.strategies as st
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import assume, given, settings
import cvxpy as cp
from scipy.optimize import linprog

from kernels import families as kf
from kernels import polygon as pg
from kernels import support as ks
from planning import plan_pose
from robustness import FrictionRange, GeometryTolerance, Sampler
from robustness.physics import PhysicsSettings, rollout_push_plan
from robustness.samplers import parameter_columns
from sweeps.partfile import load_part

EXAMPLES = pathlib.Path(__file__).resolve().parents[1] / "examples"
POLYGONS = ("rectangle", "nice_stable", "biplus_stable", "unistable")


def _body(name):
    part = load_part(EXAMPLES / f"{name}.yaml")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", pg.PartWarning)
        poly = pg.make_polygon(part.vertices, part.com)
    return part, np.asarray(poly.body, np.float64)


_JITTED: dict = {}


def _x64(f, *a):
    """``f(*a)`` compiled, in float64 (one compilation per function and shape: the
    op-by-op dispatch of the kernels' Newton loops took seconds per call)."""
    with jax.enable_x64(True):
        jf = _JITTED.setdefault(f, jax.jit(f))
        return np.asarray(jf(*(jnp.asarray(x) for x in a)))


@pytest.mark.slow
@pytest.mark.parametrize("name", POLYGONS)
def test_every_foot_lies_inside_the_outline(name):
    """No foot of any family outside any bundled part (by FOOT_INSET at least)."""
    _, body = _body(name)
    e = np.roll(body, -1, axis=0) - body
    n = np.stack([e[:, 1], -e[:, 0]], -1) / np.linalg.norm(e, axis=1, keepdims=True)
    d = np.einsum("ei,ei->e", n, body)
    fit = float(_x64(ks.tripod_fit, body))
    assert fit > 0
    sets = [_x64(ks.uniform_points, body), _x64(ks.ring_points, body),
            _x64(lambda b: ks.tripod_points(fit, b), body)]
    for pts in sets:
        depth = d[:, None] - n @ pts.T
        assert depth.min() >= ks.FOOT_INSET - 1e-9
    # a tripod just larger than the fit pokes out
    big = _x64(lambda b: ks.tripod_points(1.05 * fit, b), body)
    assert (d[:, None] - n @ big.T).min() < ks.FOOT_INSET


def _polygon(seed, h):
    rng = np.random.default_rng(seed)
    ang = np.sort(rng.uniform(0, 2 * np.pi, h))
    r = rng.uniform(0.01, 0.03, h)
    pts = np.c_[r * np.cos(ang), r * np.sin(ang)]
    from scipy.spatial import ConvexHull
    hull = pts[ConvexHull(pts).vertices]
    com = rng.dirichlet(np.full(len(hull), 0.3)) @ hull      # anywhere inside, often off-centre
    body = hull - com
    e = np.roll(body, -1, axis=0) - body
    depth = (e[:, 1] * body[:, 0] - e[:, 0] * body[:, 1]) / np.linalg.norm(e, axis=1)   # COM's edge distances
    assume(depth.min() > 2 * ks.FOOT_INSET)                  # a part that stands (not on a corner)
    return body


@pytest.mark.slow
@settings(max_examples=40, deadline=None, derandomize=True)
@given(st.integers(0, 10 ** 6), st.integers(3, 8))
def test_corner_loads_solve_the_resting_linear_programme(seed, h):
    """The corners a rigid part rests on: max sum lam lift over the convex
    combinations of corners whose centroid is the centre of mass (scipy LP)."""
    body = _polygon(seed, h)
    if len(body) < 3:
        return
    lift = np.random.default_rng(seed + 1).uniform(size=len(body))
    w = _x64(ks.corner_weights, body, lift)
    A = np.vstack([body.T, np.ones(len(body))])
    ref = linprog(-lift, A_eq=A, b_eq=[0, 0, 1], bounds=(0, None), method="highs")
    assert ref.status == 0
    assert w @ lift == pytest.approx(-ref.fun, abs=1e-9)
    np.testing.assert_allclose(w @ body, 0.0, atol=1e-12)
    assert (w > 1e-12).sum() <= 3 and w.min() >= 0 and w.sum() == pytest.approx(1.0)


@pytest.mark.slow
@settings(max_examples=40, deadline=None, derandomize=True)
@given(st.integers(0, 10 ** 6), st.integers(3, 8))
def test_equal_spring_loads_are_the_least_norm_balance(seed, h):
    """Equal springs that can lift off: the minimum-norm non-negative loads
    that balance the weight (cvxpy QP reference), also when the centre of
    mass is far off-centre and some feet lift off."""
    body = _polygon(seed, h)
    pts = _x64(ks.uniform_points, body)
    w = _x64(ks.equilibrium_weights, pts)
    np.testing.assert_allclose(w @ pts, 0.0, atol=1e-9)
    q = cp.Variable(len(pts))
    prob = cp.Problem(cp.Minimize(cp.sum_squares(q)),
                      [cp.sum(q) == 1, (pts / 0.01).T @ q == 0, q >= 0])
    prob.solve(solver="CLARABEL")     # interior point: OSQP stops at its iteration limit
    assert prob.status == "optimal"   # when three feet carry the part
    assert w @ w <= prob.value * (1 + 1e-5) + 1e-9
    np.testing.assert_allclose(w, q.value, atol=1e-4)


def _holds_origin(pts):
    """Whether the origin is a convex combination of ``pts`` (scipy LP)."""
    A = np.vstack([np.asarray(pts).T, np.ones(len(pts))])
    return linprog(np.zeros(len(pts)), A_eq=A, b_eq=[0, 0, 1], bounds=(0, None),
                   method="highs").status == 0


@pytest.mark.slow
@settings(max_examples=40, deadline=None, derandomize=True)
@given(st.integers(0, 10 ** 6), st.integers(3, 8), st.integers(3, 12),
       st.floats(0.0, 1.0))
def test_feet_take_corners_only_when_the_centre_of_mass_overhangs_them(seed, h, f, spread):
    """standing_feet: the feet unchanged when their hull holds the centre of
    mass (scipy LP), else the corners at their spread indices and the rest
    unchanged; either way the centre of mass stands inside (half the cases
    put every foot on one side of it)."""
    body = _polygon(seed, h)
    assume(len(body) <= f)
    rng = np.random.default_rng(seed + 2)
    ang = rng.uniform(0.0, np.pi * (1.0 + spread), f)          # spread < 1: one side
    feet = np.c_[np.cos(ang), np.sin(ang)] * rng.uniform(0.002, 0.01, (f, 1))
    out = _x64(ks.standing_feet, feet, body)
    assert _holds_origin(out)
    idx = np.round(np.arange(len(body)) * f / len(body)).astype(int)
    rest = np.setdiff1d(np.arange(f), idx)
    np.testing.assert_array_equal(out[rest], feet[rest])
    if _holds_origin(feet):
        np.testing.assert_array_equal(out, feet)
    else:
        np.testing.assert_array_equal(out[idx], body)


@pytest.mark.slow
@pytest.mark.parametrize("family", ["uniform", "ring"])
def test_a_part_overhanging_its_feet_stands_on_its_corners(family):
    """A centre of mass 0.5 mm from a corner of a 100 x 20 mm plate lies
    outside the pad's and the rim's feet: the corners take the place of some
    feet and the equal-spring loads balance the weight on them."""
    body = np.array([[0.0, 0.0], [0.1, 0.0], [0.1, 0.02], [0.0, 0.02]]) - [0.0995, 0.0195]
    pts = _x64(getattr(ks, f"{family}_points"), body)
    assert pts.shape == (ks.UNIFORM_FEET if family == "uniform" else ks.RING_FEET, 2)
    w = _x64(ks.equilibrium_weights, pts)
    np.testing.assert_allclose(w @ pts, 0.0, atol=1e-12)
    assert w.min() >= 0 and w.sum() == pytest.approx(1.0)
    lam = min(1.0, max(0.5, 1.0 - ks.FOOT_INSET / 0.0005))       # the inset's scale
    for corner in body:
        assert np.min(np.linalg.norm(pts - lam * corner, axis=1)) < 1e-15


@pytest.mark.slow
def test_a_part_of_more_corners_than_feet_stands_on_both():
    """A rounded outline (a 40-gon ellipse, more corners than the pad's and the
    rim's feet) stands on its corners and the feet: the count
    family_point_count gives, balanced loads, and a limit-surface evaluation
    under ``any`` runs (it raised before the count was handled)."""
    from robustness import evaluate

    a = np.linspace(0.0, 2.0 * np.pi, 40, endpoint=False)
    outline = np.c_[0.03 * np.cos(a), 0.02 * np.sin(a)]
    for family in ("uniform", "ring"):
        pts = _x64(getattr(ks, f"{family}_points"), outline)
        assert pts.shape == (ks.family_point_count(family, 40, 0), 2)
        assert len(pts) == 40 + (ks.UNIFORM_FEET if family == "uniform" else ks.RING_FEET)
        np.testing.assert_allclose(_x64(ks.equilibrium_weights, pts) @ pts, 0.0, atol=1e-12)
    plan = plan_pose(outline, (0.0, 0.0, 0.0), (0.05, 0.02, 1.0))
    sampler = Sampler(GeometryTolerance(tau_v=1e-5), FrictionRange(mu_f=(0.5, 0.8), support="any"))
    ev = evaluate(plan, sampler, 8, jax.random.key(0), None, "limit_surface")
    assert ev.n == 8 and np.all(np.isfinite(ev.samples["final_x_m"]))


def test_rigid_rectangle_rests_on_a_diagonal():
    """A centred rectangle on its corners: two opposite corners carry it, c is
    the corner radius (Peshkin's worst case) whatever the flatness errors."""
    body = np.array([[-0.02, -0.01], [0.02, -0.01], [0.02, 0.01], [-0.02, 0.01]])
    for lift in itertools.permutations([0.1, 0.4, 0.7, 0.9]):
        w = _x64(ks.corner_weights, body, np.array(lift))
        assert sorted(np.round(w, 12))[-2:] == [0.5, 0.5]
    assert ks.family_c_range("rigid", body) == pytest.approx((np.hypot(0.02, 0.01),) * 2)


@pytest.mark.slow
@pytest.mark.parametrize("name", POLYGONS)
def test_sampler_draws_each_family_in_its_range(name):
    _, body = _body(name)
    n = 400
    for fam in kf.PLAN_SUPPORTS:   # the families whose c range the part determines, and any
        lo, hi = ks.family_c_range(fam, body)
        s = Sampler(friction=FrictionRange(support=fam))
        draws = s.sample(jax.random.key(3), n, n_vertices=len(body), dim=2, body=body)
        cols = parameter_columns(draws, n_vertices=len(body), dim=2)
        c = cols["c_m"]
        assert c.min() >= lo - 1e-12 and c.max() <= hi + 1e-12, fam
        names = set(cols["support"])
        if fam == "any":
            assert names == set(kf.ANY_COMPONENTS)
            fit = float(_x64(ks.tripod_fit, body))
            tri = c[cols["support"] == "tripod"]
            assert tri.min() >= ks.TRIPOD_MIN_FRACTION * fit - 1e-12 and tri.max() <= fit + 1e-12
        else:
            assert names == {fam}


def _accepted(model, docs) -> set:
    from sweeps.config import ConfigError, validate

    out = set()
    for name, doc in docs.items():
        try:
            validate(model, doc)
            out.add(name)
        except ConfigError:
            pass
    return out


def _friction(name) -> dict:
    given = name in kf.FAMILY and kf.FAMILY[name].c_given
    return {"support": name, **({"c": [0.004, 0.008]} if given else {})}


def test_every_list_of_supports_reads_the_one_table():
    """kernels.families.TABLE is the one declaration: the names a config accepts,
    those the sampler draws, those the MuJoCo scene stands, those a plan's
    distances can assume (config, planner, command line) are the table's; a
    family added to the table but missed by the sampler or the scene fails here."""
    from planning.pushing.part import check_support
    from robustness.physics.geometry import support_of
    from sweeps.config import Evaluation, Planner
    from sweeps.plan_push import build_parser

    names = kf.SUPPORT_FAMILIES + ("foam",)
    assert kf.FAMILIES == tuple(f.name for f in kf.TABLE) and len(set(kf.FAMILIES)) == len(kf.TABLE)
    assert [kf.CODES[n] for n in kf.FAMILIES] == list(range(len(kf.TABLE)))
    # the config's friction.support, and under model: mujoco only what the scene stands
    assert _accepted(Evaluation, {n: {"friction": _friction(n)} for n in names}) \
        == set(kf.SUPPORT_FAMILIES)
    assert _accepted(Evaluation, {n: {"friction": _friction(n), "model": "mujoco"}
                                  for n in names}) == set(kf.REALISABLE_SUPPORTS)
    # what a plan's distances may assume: the config, planning and the command line
    assert _accepted(Planner, {n: {"support": n} for n in names}) == set(kf.PLAN_SUPPORTS)
    planned = set()
    for n in names:
        try:
            check_support(n)
            planned.add(n)
        except ValueError:
            pass
    assert planned == set(kf.PLAN_SUPPORTS)
    (cli,) = [a for a in build_parser()._actions if "--support" in a.option_strings]
    assert tuple(cli.choices) == kf.PLAN_SUPPORTS
    _, body = _body("rectangle")
    for n in kf.PLANNED_FAMILIES:
        lo, hi = ks.family_c_range(n, body)
        assert 0 < lo <= hi, n
    # the sampler draws every name, the any mixture's components
    for n in kf.SUPPORT_FAMILIES:
        fr = FrictionRange(**{k: tuple(v) if k == "c" else v for k, v in _friction(n).items()})
        draws = Sampler(friction=fr).sample(jax.random.key(3), 64, n_vertices=len(body), dim=2,
                                            body=body)
        cols = parameter_columns(draws, n_vertices=len(body), dim=2)
        assert set(cols["support"]) == (set(kf.ANY_COMPONENTS) if n == "any" else {n}), n
        assert np.all(np.isfinite(cols["c_m"]) & (cols["c_m"] > 0)), n
    # the scene stands exactly the families with feet
    lift = np.arange(len(body), dtype=np.float64)
    for n in kf.FAMILIES:
        if kf.FAMILY[n].feet:
            feet, w = support_of(kf.CODES[n], body, 0.004, lift)
            assert np.isclose(np.sum(w), 1.0) and np.all(np.asarray(w) >= -1e-12), n
        else:
            with pytest.raises(ValueError, match="cannot be realised"):
                support_of(kf.CODES[n], body, 0.004, lift)


def test_family_validation_names_the_field():
    with pytest.raises(ValueError, match="support: expected one of"):
        FrictionRange(support="foam")
    with pytest.raises(ValueError, match="tripod.*c: \\[lo, hi\\]"):
        FrictionRange(support="tripod")
    with pytest.raises(ValueError, match="c: .*tripod"):
        FrictionRange(support="rigid", c=(0.004, 0.008))
    with pytest.raises(ValueError, match="support_points: .*points"):
        FrictionRange(support="rigid", support_points=8)
    assert FrictionRange().support == "any"
    assert FrictionRange(c=(0.004, 0.008)).support == "tripod"


@pytest.mark.slow
@pytest.mark.parametrize("name", POLYGONS)
def test_the_scene_realises_the_drawn_support(name):
    """Each family drawn by the sampler, stood in MuJoCo (C engine): the loads
    MuJoCo puts on the support after settling realise the family's c on the
    perturbed part (c_physical vs c_support), which is the sampled c to
    within the perturbation (the sampler's c is on the nominal part)."""
    part, body = _body(name)
    goal = (0.01, 0.0, 0.0)
    plan = plan_pose(part.vertices, (0.0, 0.0, 0.0), goal, com=part.com)
    n = 12
    sam = Sampler(GeometryTolerance(tau_v=5e-5), FrictionRange(mu_f=(0.5, 0.5)))
    params = sam.sample(jax.random.key(5), n, n_vertices=len(part.vertices), dim=2,
                        n_pushes=plan.n_pushes, body=body)
    r = rollout_push_plan(plan, params, backend="c", settings=PhysicsSettings(batch=n))
    assert set(r.support) == set(kf.ANY_COMPONENTS)
    sim = r.simulated
    assert sim.all()
    tol = np.where(r.support == "rigid", 1e-3, 2e-4)      # rigid rocks on its corners
    np.testing.assert_array_less(np.abs(r.c_physical - r.c_support), tol)
    np.testing.assert_allclose(r.c_support, r.c, atol=2e-4)
    assert r.support_ok.all()


@pytest.mark.slow
def test_plans_name_the_support_their_distances_assume(tmp_path):
    """planner.support through ``nudge certify`` and ``nudge plan-push``: the
    plans table, the certificate and the printed plan name the support."""
    from tests.commandline import nudge_here

    cfg = tmp_path / "cert.yaml"
    cfg.write_text("""part: rectangle
planner: {support: rigid}
friction: {mu_f: [0.8, 0.8], support: rigid}
tolerances: {tau_com: 1.0e-4}
eps: {pos_eps_m: 0.002, theta_eps_rad: 0.05}
required: {probability: 0.5, confidence: 0.5}
n_samples: 20
tasks:
  - {name: turn, start: [0, 0, 0], goal: [0.05, 0.02, 1.0]}
""")
    out = tmp_path / "out"
    r = nudge_here("certify", cfg, "--out", out, "--quiet")
    assert r.returncode in (0, 1), r.stderr
    import pandas as pd

    plans = pd.read_parquet(out / "plans")
    assert (plans["support"] == "rigid").all() and (plans["distance_rule"] == "quasi-static").all()
    cert = pd.read_parquet(out / "certificates")
    assert "support (rigid)" in cert["claim"].iloc[0], cert["claim"].iloc[0]
    s = pd.read_parquet(out / "samples")
    assert (s["support"] == "rigid").all()
    r = nudge_here("plan-push", "rectangle", "--start", "0,0,0", "--goal", "0.05,0.02,1.0",
              "--support", "rigid")
    assert r.returncode == 0, r.stderr
    assert "valid for rigid support, c in [22.4, 22.4] mm only" in r.stdout, r.stdout
    r = nudge_here("plan-push", "rectangle", "--start", "0,0,0", "--goal", "0.05,0.02,1.0",
              "--support", "rigid", "--support-c", "0.004", "0.008")
    assert r.returncode == 2 and "--support" in r.stderr
    cfg.write_text(cfg.read_text().replace("planner: {support: rigid}",
                                           "planner: {support: rigid, support_c: [0.004, 0.008]}"))
    r = nudge_here("certify", cfg, "--out", tmp_path / "o2", "--quiet")
    assert r.returncode == 2 and "support" in r.stderr, r.stderr
