"""The success criterion (issue 39): one frozen value with the per-kind defaults and
the one classification every model's rows use, carried down whole (no loose eps
numbers, no second default); the confidence's default is one named value."""
import ast
import dataclasses
import math
import pathlib
import types

import jax
import numpy as np
import pytest
from hypothesis import given, strategies as st

from planning.pushing.planner import plan_pose
from robustness import (CONFIDENCE, REQUIRED_PROBABILITY, FrictionRange, GeometryTolerance,
                        Sampler, SuccessCriterion, evaluate, stats)
from robustness.tolerances import ExecutionTolerance

ROOT = pathlib.Path(__file__).resolve().parents[1]
LAYERS = ("kernels", "planning", "robustness", "sweeps")
PE, TE = 2e-3, 0.03
CRIT = SuccessCriterion(pos_eps_m=PE, theta_eps_rad=TE, slip_fraction=0.25)
PUSH = types.SimpleNamespace(kind="push", pushes=())
TUMBLE = types.SimpleNamespace(kind="tumble", tumbles=(), eps=4e-4)


# --------------------------------------------------------------------------
# the value: defaults by kind, validation
# --------------------------------------------------------------------------
def test_defaults_by_plan_kind():
    assert SuccessCriterion.for_plan(PUSH) == SuccessCriterion() == SuccessCriterion(
        1e-3, math.radians(1.0), 0.25)
    t = SuccessCriterion.for_plan(TUMBLE)
    assert (t.pos_eps_m, t.theta_eps_rad, t.slip_fraction) == (4e-4, 4e-4, 0.25)
    with pytest.raises(TypeError, match="PushPlan or a TumblePlan"):
        SuccessCriterion.for_plan(object())


def test_defaults_of_a_real_plan_and_of_evaluate():
    plan = plan_pose([[0.0, 0.0], [0.03, 0.0], [0.005, 0.02]], (0, 0, 0), (0.05, 0.02, 0.5))
    assert SuccessCriterion.for_plan(plan) == SuccessCriterion()
    ev = evaluate(plan, Sampler(), 2, jax.random.key(0), model="exact", bound=False)
    assert (ev.summary["pos_eps_m"], ev.summary["theta_eps_rad"]) == (1e-3, math.radians(1.0))
    assert ev.summary["confidence"] == CONFIDENCE


@pytest.mark.parametrize("field", ["pos_eps_m", "theta_eps_rad"])
@pytest.mark.parametrize("bad", [0.0, -1e-3, math.nan, math.inf, True, "1e-3", None])
def test_a_tolerance_must_be_a_finite_positive_number(field, bad):
    with pytest.raises(ValueError, match=f"^{field}: expected a finite number > 0"):
        SuccessCriterion(**{field: bad})


@pytest.mark.parametrize("bad", [-0.1, math.nan, math.inf])
def test_the_slip_fraction_must_be_finite_and_not_negative(bad):
    with pytest.raises(ValueError, match="^slip_fraction: "):
        SuccessCriterion(slip_fraction=bad)
    assert SuccessCriterion(slip_fraction=0).slip_fraction == 0.0


def test_it_is_a_frozen_value():
    with pytest.raises(dataclasses.FrozenInstanceError):
        CRIT.pos_eps_m = 1.0
    assert CRIT == SuccessCriterion(PE, TE) and hash(CRIT) == hash(SuccessCriterion(PE, TE))
    assert isinstance(SuccessCriterion(1, 1).pos_eps_m, float)


def test_the_named_defaults():
    assert (CONFIDENCE, REQUIRED_PROBABILITY) == (0.95, 0.9)
    assert stats.one_sided_lower(50, 50) == stats.one_sided_lower(50, 50, CONFIDENCE)


# --------------------------------------------------------------------------
# the classification
# --------------------------------------------------------------------------
def _one(ep, et, slip=0.0, valid=True, faults=()):
    ok, mode = CRIT.classify(np.array([ep]), np.array([et]), np.array([slip]), valid=valid,
                             faults=tuple((m, np.array([c])) for m, c in faults))
    return bool(ok[0]), str(mode[0])


def test_exactly_at_eps_succeeds_and_just_beyond_fails():
    assert _one(PE, TE) == (True, "none")
    assert _one(PE, -TE) == (True, "none")
    assert _one(0.0, 0.0) == (True, "none")
    assert _one(np.nextafter(PE, 1.0), 0.0) == (False, "position")
    assert _one(0.0, np.nextafter(TE, 1.0)) == (False, "orientation")
    assert _one(0.0, -np.nextafter(TE, 1.0)) == (False, "orientation")
    assert _one(2 * PE, 2 * TE) == (False, "position")   # position is named first


def test_a_pose_that_is_not_a_number_fails():
    assert _one(math.nan, 0.0) == (False, "position")
    assert _one(0.0, math.nan) == (False, "orientation")
    assert _one(math.nan, math.nan) == (False, "position")
    assert _one(math.inf, 0.0) == (False, "position")


def test_slip_names_a_failure_but_never_fails_a_success():
    at = CRIT.slip_fraction * PE
    assert _one(2 * PE, 0.0, slip=at) == (False, "slip")                       # at the fraction
    assert _one(2 * PE, 0.0, slip=np.nextafter(at, 0.0)) == (False, "position")
    assert _one(0.0, 2 * TE, slip=10 * at) == (False, "slip")
    assert _one(0.0, 0.0, slip=10 * at) == (True, "none")
    zero = SuccessCriterion(PE, TE, slip_fraction=0.0)
    ok, mode = zero.classify(np.array([2 * PE]), np.array([0.0]), np.array([0.0]))
    assert (bool(ok[0]), str(mode[0])) == (False, "slip")                     # 0 >= 0


def test_faults_in_their_order_and_only_valid_samples_succeed():
    faults = (("hull_changed", False), ("wrong_edge", True), ("wrong_face", True))
    assert _one(0.0, 0.0, valid=True, faults=faults) == (True, "none")       # a flag, not a failure
    assert _one(0.0, 0.0, valid=False, faults=faults) == (False, "wrong_edge")
    assert _one(2 * PE, 0.0, slip=1.0, faults=faults) == (False, "wrong_edge")  # before slip
    assert _one(0.0, 0.0, valid=False, faults=(("hull_changed", True), ("wrong_face", True))) \
        == (False, "hull_changed")
    ok, mode = CRIT.classify(np.zeros(0), np.zeros(0), np.zeros(0), faults=(("x", np.zeros(0, bool)),))
    assert ok.shape == mode.shape == (0,)


def _reference(ep, et, slip, valid, faults):
    """The rule written out for one sample, independently of the vectorised one."""
    if valid and ep <= PE and abs(et) <= TE:
        return True, "none"
    for name, hit in faults:
        if hit:
            return False, name
    if slip >= 0.25 * PE:
        return False, "slip"
    return False, "position" if not ep <= PE else "orientation"


_err = st.one_of(st.floats(0.0, 3 * PE), st.sampled_from([0.0, PE, math.nan, math.inf]))
_ang = st.one_of(st.floats(-3 * TE, 3 * TE), st.sampled_from([TE, -TE, math.nan]))
_slip = st.one_of(st.floats(0.0, PE), st.sampled_from([0.25 * PE, 0.0]))


@given(st.lists(st.tuples(_err, _ang, _slip, st.booleans(), st.booleans(), st.booleans()),
                min_size=1, max_size=40))
def test_classify_is_the_rule_sample_by_sample(rows):
    ep, et, slip, valid, f1, f2 = (np.array(c) for c in zip(*rows))
    ok, mode = CRIT.classify(ep, et, slip, valid=valid,
                             faults=(("hull_changed", f1), ("wrong_face", f2)))
    for i, r in enumerate(rows):
        want = _reference(r[0], r[1], r[2], r[3], (("hull_changed", r[4]), ("wrong_face", r[5])))
        assert (bool(ok[i]), str(mode[i])) == want, r
    assert np.array_equal(ok, mode == "none")


# --------------------------------------------------------------------------
# carried down whole
# --------------------------------------------------------------------------
def test_evaluate_judges_by_the_criterion_it_is_given():
    """The criterion reaches the kernels' rows: a slip fraction of 0 names every failed
    sample that slipped at all ``slip`` (and nothing else changes); tighter
    tolerances fail more samples, each by the criterion's own rule."""
    plan = plan_pose([[0.0, 0.0], [0.03, 0.0], [0.005, 0.02]], (0, 0, 0), (0.1, 0.05, 1.0))
    slippy = Sampler(GeometryTolerance(tau_v=2e-5, tau_com=5e-4), FrictionRange(mu_f=(0.1, 0.4)),
                     ExecutionTolerance(start_xy=5e-4, fence_angle=2e-2, distance_rel=2e-2))
    key = jax.random.key(3)
    base = SuccessCriterion(3e-3, 0.05)
    a = evaluate(plan, slippy, 64, key, base, "quasistatic", bound=False).samples
    b = evaluate(plan, slippy, 64, key, dataclasses.replace(base, slip_fraction=0.0),
                 "quasistatic", bound=False).samples
    assert a["success"].equals(b["success"]) and a["err_pos_m"].equals(b["err_pos_m"])
    structural = a["failure_mode"].isin(["hull_changed", "incomplete_reorientation", "wrong_edge"])
    moved = ~a["success"] & ~structural
    assert moved.any() and (a["slip_m"] > 0).any()
    assert (b.loc[moved, "failure_mode"] == "slip").all()
    assert (b.loc[~moved, "failure_mode"] == a.loc[~moved, "failure_mode"]).all()
    tight = SuccessCriterion(1e-4, 1e-3)
    c = evaluate(plan, slippy, 64, key, tight, "quasistatic", bound=False)
    s = c.samples
    want = tight.success(s["err_pos_m"], s["err_theta_rad"], s["model_valid"])
    assert np.array_equal(s["success"].to_numpy(), want)
    assert c.summary["pos_eps_m"] == 1e-4 and s["success"].sum() <= a["success"].sum()


def test_evaluate_refuses_loose_numbers():
    plan = plan_pose([[0.0, 0.0], [0.03, 0.0], [0.005, 0.02]], (0, 0, 0), (0.05, 0.02, 0.5))
    with pytest.raises(TypeError, match="criterion: expected a robustness.SuccessCriterion"):
        evaluate(plan, Sampler(), 2, jax.random.key(0), 1e-3, model="exact")
    with pytest.raises(TypeError):
        evaluate(plan, Sampler(), 2, jax.random.key(0), pos_eps_m=1e-3)


def test_a_config_validates_eps_into_the_criterion():
    from sweeps.config import ConfigError, Evaluation, validate

    cfg = validate(Evaluation, {"eps": {"pos_eps_m": "2 mm", "theta_eps_rad": 0.05}})
    assert cfg.eps == SuccessCriterion(2e-3, 0.05)
    assert validate(Evaluation, {}).eps == SuccessCriterion()
    assert (validate(Evaluation, {}).required.probability,
            validate(Evaluation, {}).required.confidence) == (REQUIRED_PROBABILITY, CONFIDENCE)
    with pytest.raises(ConfigError, match=r"^eps\.pos_eps_m: expected a finite number > 0, got "
                                          r"0\.0; give the position accuracy"):
        validate(Evaluation, {"eps": {"pos_eps_m": 0}})
    with pytest.raises(ConfigError, match=r"unknown key 'pos' in eps; allowed keys: pos_eps_m, "
                                          r"theta_eps_rad, slip_fraction"):
        validate(Evaluation, {"eps": {"pos": 1}})


# --------------------------------------------------------------------------
# no second home (AST, over the layers' sources)
# --------------------------------------------------------------------------
LOOSE = {"pos_eps_m", "theta_eps_rad", "slip_fraction"}
NAMED = {"confidence": "CONFIDENCE", "required_probability": "REQUIRED_PROBABILITY",
         "probability": "REQUIRED_PROBABILITY"}


def _sources(paths=None):
    for path in paths or sorted(p for layer in LAYERS for p in (ROOT / layer).rglob("*.py")):
        yield path, ast.parse(path.read_text(), str(path))


def _second_homes(trees):
    """Where a success tolerance travels as a loose parameter, a confidence or
    probability default is a literal, or an eps default by plan kind is written
    (``plan.eps if ... is None else ...``) outside :class:`SuccessCriterion`."""
    bad = []
    for path, tree in trees:
        rel = path.relative_to(ROOT) if path.is_relative_to(ROOT) else path
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                a = node.args
                params = a.posonlyargs + a.args + a.kwonlyargs
                bad += [f"{rel}:{node.lineno} {node.name}({p.arg}=...): pass a SuccessCriterion"
                        for p in params if p.arg in LOOSE]
                defaults = list(zip(a.args[len(a.args) - len(a.defaults):], a.defaults)) + [
                    (p, d) for p, d in zip(a.kwonlyargs, a.kw_defaults) if d is not None]
                bad += [f"{rel}:{node.lineno} {node.name}({p.arg}={ast.unparse(d)}): use "
                        f"{NAMED[p.arg]}" for p, d in defaults
                        if p.arg in NAMED and isinstance(d, ast.Constant) and d.value is not None]
            elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) \
                    and node.target.id in NAMED and isinstance(node.value, ast.Call) \
                    and node.value.args and isinstance(node.value.args[0], ast.Constant):
                bad.append(f"{rel}:{node.lineno} {node.target.id} = Field(literal): use "
                           f"{NAMED[node.target.id]}")
            elif isinstance(node, ast.IfExp) and "tolerances.py" not in str(rel):
                test = ast.unparse(node.test)
                branches = [n for b in (node.body, node.orelse) for n in ast.walk(b)]
                if "is None" in test and any(isinstance(n, ast.Attribute) and n.attr == "eps"
                                             for n in branches):
                    bad.append(f"{rel}:{node.lineno} an eps default by plan kind: "
                               "SuccessCriterion.for_plan")
    return bad


def test_the_criterion_and_the_confidence_have_one_home():
    bad = _second_homes(_sources())
    assert not bad, "\n".join(bad)


def test_the_check_finds_a_second_home(tmp_path):
    """The test above can fail: each pattern it forbids is found in a module."""
    mod = tmp_path / "mod.py"
    mod.write_text("def f(plan, pos_eps_m=None, confidence=0.95):\n"
                   "    return float(plan.eps) if pos_eps_m is None else pos_eps_m\n"
                   "class C:\n    confidence: float = Field(0.95, gt=0)\n"
                   "def g(*, required_probability: float = 0.9, theta_eps_rad=1.0):\n    pass\n")
    bad = _second_homes(_sources([mod]))
    assert len(bad) == 6, bad
