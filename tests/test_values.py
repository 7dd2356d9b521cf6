"""The values handed down (issue 39): :class:`robustness.Model`,
:class:`robustness.Requirement`, :class:`robustness.Selection`; the library's
``certify`` through them; the public calls' parameter counts."""
import inspect

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from planning import plan_pose, plan_pose_batch
from robustness import (CONFIDENCE, REQUIRED_PROBABILITY, ExecutionTolerance, GeometryTolerance,
                        Model, Requirement, Sampler, Schedule, Selection, SuccessCriterion,
                        auto_schedule, certify, evaluate, score_candidates, synthesize)
from robustness import DesignJudge

TRIANGLE = np.array([[0.0, 0.0], [0.1, 0.0], [0.03, 0.06]])
SAMPLER = Sampler(GeometryTolerance(tau_v=2e-4), execution=ExecutionTolerance(start_xy=2e-4))
CRIT = SuccessCriterion(pos_eps_m=3e-3, theta_eps_rad=0.05)


@pytest.fixture(scope="module")
def plan():
    return plan_pose(TRIANGLE, (0.0, 0.0, 0.0), (0.08, 0.03, 0.0))


@pytest.mark.parametrize("fields, field", [
    (dict(name="ellipse"), "model"), (dict(name="exact", dtype="int32"), "dtype"),
    (dict(name="exact", dtype="float16"), "dtype"), (dict(name="exact", chunk=0), "chunk"),
    (dict(name="exact", chunk=2.5), "chunk"), (dict(name="exact", merge_factor=-1.0), "merge_factor"),
    (dict(name="exact", merge_factor=float("nan")), "merge_factor"),
])
def test_a_bad_model_field_is_refused_in_one_line_naming_it(fields, field):
    with pytest.raises(ValueError) as e:
        Model(**fields)
    assert str(e.value).startswith(f"{field}: expected") and "\n" not in str(e.value)


def test_a_model_name_stands_for_its_value():
    assert Model.of("exact") == Model("exact") == Model("exact", dtype="float64")
    assert Model("exact", dtype="float32").dtype == jnp.dtype(jnp.float32)
    m = Model("quasistatic", dtype=jnp.float32)
    assert Model.of(m) is m and Model.of(m, chunk=64) == Model("quasistatic", "float32", chunk=64)
    with pytest.raises(ValueError, match="^model: expected one of"):
        Model.of(3)
    # a tumble has no quasi-static model: it is evaluated exact, the rest kept
    assert Model("quasistatic", dtype="float32").for_kind("tumble") == Model("exact", "float32")
    assert Model("mujoco").for_kind("tumble") == Model("mujoco")


@pytest.mark.parametrize("fields, field", [
    (dict(probability=1.0), "probability"), (dict(probability=0), "probability"),
    (dict(confidence=1.5), "confidence"), (dict(confidence=True), "confidence"),
    (dict(criterion=0.001), "criterion"),
])
def test_a_bad_requirement_is_refused_in_one_line_naming_it(fields, field):
    with pytest.raises(ValueError) as e:
        Requirement(**fields)
    assert str(e.value).startswith(f"{field}: expected") and "\n" not in str(e.value)


def test_a_requirement_takes_the_plan_kinds_criterion_unless_given(plan):
    r = Requirement()
    assert (r.probability, r.confidence) == (REQUIRED_PROBABILITY, CONFIDENCE)
    assert r.for_plan(plan).criterion == SuccessCriterion.for_plan(plan)
    assert Requirement(criterion=CRIT).for_plan(plan).criterion is CRIT


def test_a_bad_selection_is_refused_in_one_line_naming_it():
    for fields, field in [(dict(sampler=None), "sampler"), (dict(n=0), "n"),
                          (dict(objective="cheapest"), "objective")]:
        kw = dict(sampler=SAMPLER, n=10, key=jax.random.key(0)) | fields
        with pytest.raises(ValueError, match=f"^{field}: expected"):
            Selection(**kw)


def test_certify_draws_the_blocks_evaluate_draws(plan):
    """The library's ``certify``: one look of 64 samples is ``evaluate``'s 64 on
    block 0's key, judged by the requirement's criterion; the verdict is the
    one-sided bound's against the requirement."""
    key = jax.random.key(3)
    req = Requirement(0.5, 0.9, CRIT)
    cert, samples, summary = certify(plan, SAMPLER, key, req, samples=64, model="exact")
    ev = evaluate(plan, SAMPLER, 64, jax.random.fold_in(key, 0), CRIT, "exact")
    assert cert.n_samples == 64 == len(samples)
    assert cert.n_success == int(ev.samples["success"].sum()) == summary["n_success"]
    np.testing.assert_array_equal(samples["final_x_m"], ev.samples["final_x_m"])
    assert cert.confidence == 0.9 and cert.required_probability == 0.5
    assert (cert.verdict == "certified") is (summary["ci_low_one_sided"] >= 0.5)
    assert summary["pos_eps_m"] == CRIT.pos_eps_m


def test_certify_grows_by_its_schedule_and_refuses_another_confidence(plan):
    key = jax.random.key(4)
    req = Requirement(0.5, 0.9, CRIT)
    sched = auto_schedule(0.5, 0.9, 64)
    cert, samples, _ = certify(plan, SAMPLER, key, req, samples=sched, model="exact")
    assert cert.n_samples in sched.counts and len(samples) == cert.n_samples
    with pytest.raises(ValueError, match="^samples: the schedule's confidence"):
        certify(plan, SAMPLER, key, req, samples=Schedule((8,), 0.95), model="exact")
    with pytest.raises(ValueError, match="^samples: expected"):
        certify(plan, SAMPLER, key, req, samples=0, model="exact")
    with pytest.raises(ValueError, match="^requirement: expected"):
        certify(plan, SAMPLER, key, 0.9)


def test_the_public_calls_take_at_most_eight_parameters():
    """Issue 39's rule: a call that grows a ninth parameter wants a value instead."""
    for fn in (evaluate, certify, synthesize, score_candidates, plan_pose, plan_pose_batch):
        params = inspect.signature(inspect.unwrap(fn)).parameters
        assert len(params) <= 8, (fn.__name__, list(params))
    assert len(inspect.signature(DesignJudge).parameters) <= 8
