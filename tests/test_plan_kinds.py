"""The plan interface and the dispatch table of plan kinds (issue 39): every plan
class declares its kind and the interface, and every kind has a complete row of
the evaluation's table (or a stated reason why not), so that a new plan kind
cannot be half wired."""
import dataclasses
import inspect
import types

import pytest

import planning
import robustness
from planning import PLAN_TYPES, Plan
from planning.kinds import INTERFACE
from robustness import KINDS, NOT_EVALUATED, kind_for_part, kind_of, model_for, plan_kind
from robustness.kinds import FUNCTIONS, MODELS, PlanKind

TRIANGLE = [[0.0, 0.0], [0.03, 0.0], [0.005, 0.02]]


def _plan_classes() -> dict:
    """Every class ``planning`` exports whose name ends in ``Plan`` (a plan type),
    by name: what a new plan type added to the door shows up as (not the
    interface itself, :class:`planning.Plan`)."""
    return {name: obj for name in planning.__all__
            if name.endswith("Plan") and inspect.isclass(obj := getattr(planning, name))
            and obj is not Plan}


def test_every_exported_plan_class_declares_its_kind_and_is_listed():
    classes = _plan_classes()
    assert {"PushPlan", "TumblePlan", "SensorlessPlan"} <= set(classes)
    for name, cls in classes.items():
        kind = getattr(cls, "kind", None)
        assert isinstance(kind, str) and kind, f"{name}: no class attribute kind"
        assert "kind" not in {f.name for f in dataclasses.fields(cls)}, \
            f"{name}: kind is a class attribute, not a field (to_dict stays as it was)"
        assert PLAN_TYPES.get(kind) is cls, f"{name}: kind {kind!r} not in planning.PLAN_TYPES"
    assert set(PLAN_TYPES.values()) == set(classes.values())
    assert len({c.kind for c in classes.values()}) == len(classes), "two plan types, one kind"


@pytest.mark.parametrize("kind", sorted(PLAN_TYPES))
def test_every_plan_type_implements_the_interface(kind):
    cls = PLAN_TYPES[kind]
    fields = {f.name for f in dataclasses.fields(cls)}
    for name in INTERFACE:
        assert hasattr(cls, name) or name in fields, f"{cls.__name__}: no {name} (the plan interface)"
    for name in ("nominal_part", "draw_shape", "to_dict"):
        assert callable(getattr(cls, name)), f"{cls.__name__}.{name}"
    assert isinstance(inspect.getattr_static(cls, "n_steps"), property)


@pytest.mark.parametrize("kind", sorted(PLAN_TYPES))
def test_every_plan_kind_has_a_complete_row_of_the_dispatch_table(kind):
    """The failure this table exists for: a plan kind missing from it, or a row
    missing a function.  A kind without a row must say why (NOT_EVALUATED)."""
    if kind in NOT_EVALUATED:
        assert kind not in KINDS
        assert NOT_EVALUATED[kind].strip()
        return
    assert kind in KINDS, f"plan kind {kind!r} has no row in robustness.KINDS"
    row = KINDS[kind]
    assert isinstance(row, PlanKind) and row.kind == kind
    assert row.plan_type is PLAN_TYPES[kind]
    for name in FUNCTIONS:
        assert callable(getattr(row, name)), f"KINDS[{kind!r}].{name} is not a function"
    assert set(row.models) <= set(MODELS) and "exact" in row.models
    assert set(row.references) <= set(row.models) - {"mujoco"}
    assert isinstance(row.paper_bounds, bool) and isinstance(row.cost_needs_bound, bool)


def test_the_table_declares_every_function_and_no_row_is_for_an_unknown_kind():
    assert set(FUNCTIONS) >= {"draw", "rows", "physics_rows", "nominal_final", "bound",
                              "default_eps", "sources", "success_many", "candidate_cost"}
    assert set(KINDS) <= set(PLAN_TYPES)
    assert set(NOT_EVALUATED) <= set(PLAN_TYPES) and not set(NOT_EVALUATED) & set(KINDS)
    # a part's plans from one known start are the first row of its part kind
    firsts = {}
    for k in KINDS.values():
        firsts.setdefault(k.part_kind, k.kind)
    assert firsts == {"polygon": "push", "polyhedron": "tumble"}
    for part_kind, kind in firsts.items():
        assert kind_for_part(part_kind) == kind


def test_the_other_tables_keyed_by_kind_cover_every_kind():
    """Tables outside robustness.kinds that are keyed by plan kind: a new kind
    fails here, not at run time."""
    from robustness import tolerance_design as td
    from robustness.models import THROUGHPUT

    for kind, row in KINDS.items():
        assert kind in td.AXES
        for model in row.models:
            assert (kind, model, "*") in THROUGHPUT, (kind, model)


def test_a_plan_is_dispatched_by_its_declared_kind():
    push = planning.plan_pose(TRIANGLE, (0, 0, 0), (0.05, 0.02, 0.5))
    assert push.kind == "push" and plan_kind(push) == "push" and kind_of(push) is KINDS["push"]
    assert isinstance(push, Plan)
    assert push.n_steps == push.n_pushes and push.verdict == "solved"
    assert push.draw_shape() == dict(n_vertices=3, dim=2, n_pushes=push.n_pushes)
    assert push.nominal_part().n == 3
    assert "kind" not in push.to_dict()
    # a duck with pushes is no longer taken for a push plan: the kind is declared
    with pytest.raises(TypeError, match="PushPlan or a TumblePlan"):
        kind_of(types.SimpleNamespace(pushes=()))
    NOT_EVALUATED["gadget"] = "no replay yet"   # a kind declared without a row says why
    try:
        with pytest.raises(TypeError, match="gadget plan cannot be evaluated: no replay yet"):
            kind_of(types.SimpleNamespace(kind="gadget"))
    finally:
        del NOT_EVALUATED["gadget"]
    assert model_for("quasistatic", "push") == "quasistatic"
    assert model_for("quasistatic", "tumble") == "exact"
    assert model_for("mujoco", "tumble") == "mujoco"


def test_the_door_exports_the_table():
    for name in ("KINDS", "PlanKind", "kind_of", "kind_for_part", "plan_kind", "NOT_EVALUATED"):
        assert name in robustness.__all__
    for name in ("PLAN_TYPES", "Plan"):
        assert name in planning.__all__


def test_a_tumble_plan_reads_its_row():
    from robustness import SuccessCriterion

    cube = [[x, y, z] for x in (0, .1) for y in (0, .1) for z in (0, .1)]
    plan = planning.plan_tumble(cube, (0.2, 0.0, 0.0, 0), eps=1e-3)
    assert plan.kind == "tumble" and kind_of(plan) is KINDS["tumble"] and isinstance(plan, Plan)
    assert plan.n_steps == plan.n_tumbles and plan.verdict == "solved"
    assert plan.draw_shape() == dict(n_vertices=8, dim=3, n_tumbles=plan.n_tumbles)
    assert plan.nominal_part() is plan.nominal_part() and plan.nominal_part().n_faces == 6
    assert SuccessCriterion.for_plan(plan) == SuccessCriterion(1e-3, 1e-3)
    assert KINDS["tumble"].nominal_final(plan).tolist() == list(plan.predicted_final[:3])


@pytest.mark.slow
def test_a_sensorless_plan_is_its_own_kind_not_a_push_plan():
    """It has ``pushes``: ``hasattr(plan, "pushes")`` took it for a push plan and
    the evaluation failed deep inside; its declared kind has no row, said at once."""
    import jax

    from robustness import Sampler, evaluate

    square = [[0.0, 0.0], [0.02, 0.0], [0.02, 0.02], [0.0, 0.02]]
    plan = planning.plan_sensorless(square, (0.2, 0.2, 0.0), (0.0, 0.05, 0.0, 0.05),
                                    n_headings=36, n_side=2)
    assert plan.kind == "sensorless" and hasattr(plan, "pushes") and isinstance(plan, Plan)
    assert plan.verdict == "solved" and plan.n_steps == len(plan.pushes)
    assert plan.draw_shape() == dict(n_vertices=4, dim=2, n_pushes=len(plan.pushes))
    assert kind_of(plan) is KINDS["sensorless"]
    ev = evaluate(plan, Sampler(), 8, jax.random.key(0), model="exact")   # starts over the set
    assert (ev.samples["kind"] == "sensorless").all() and ev.samples["success"].all()
    # MuJoCo rolls each sample out as the plan from its drawn start: that plan, replayed
    # by the exact kinematics, ends at the goal turned by a multiple of the part's period
    from robustness.sensorless import draw_starts, start_plan

    for st in draw_starts(plan, jax.random.key(0), 3):
        pp = start_plan(plan, st)
        assert pp.start == tuple(st) and pp.n_pushes == plan.n_steps and pp.verdict == "solved"
        assert pp.goal[:2] == plan.goal[:2]
        turns = (pp.goal[2] - plan.goal[2]) / plan.period
        assert abs(turns - round(turns)) < 1e-9
        r = evaluate(pp, Sampler(), 1, jax.random.key(1), model="exact", bound=False).samples
        assert r["success"].all() and r["err_pos_m"].max() < 1e-9
