"""The pose planner's options and the hard inputs: model-based reorient
distances (``support``), slip-aware plans (``min_fence_mu``), a workspace, the
effort budget, safety factor exactly 1 from unwrapped starts, near-marginal
parts, parts at every scale (millimetres, 1e9 m), one by one and batched."""
from __future__ import annotations

import math
import pathlib
import warnings

import numpy as np
import pytest

from kernels import polygon as pg
from planning.pushing import batch as pb
from planning.pushing import planner as pp
from planning.pushing.options import PushOptions
from tests import strategies as S
from tests.test_pose_planner import (_agree, _batch, _fixed_parts, _pairs, _plan, _plan_or_budget, _size,
                                     check_plan)
from oracles import push_numpy as oracle

pytestmark = pytest.mark.float64  # calls kernels on float64 arrays directly


@pytest.mark.slow
@pytest.mark.parametrize("name, options", [
    ("nice", dict(support={"c": [0.4, 0.8]}, min_fence_mu=0.5)),   # c in units of the part's radius
    ("biplus", dict(support={"c": [0.2, 0.6]})),
    ("uni", dict(workspace=1.5)),                                  # half-width, in metres
    ("nice", dict(workspace=0.1, strategy="paper")),
])
def test_batch_agrees_with_single_with_options(name, options):
    """The options give the same plans one by one and in a batch."""
    pts, com = _fixed_parts()[name]
    starts, goals = (a[:40:2 if name == "uni" else 1] for a in _pairs())   # uni: 0.5 s a plan
    body = oracle.body_from_part(pts, com)[0]
    kw = dict(options)
    if "support" in kw:
        radius = float(np.max(np.hypot(*body.T)))
        kw["support"] = {"c": [x * radius for x in kw["support"]["c"]]}
    if "workspace" in kw:
        h = kw.pop("workspace")
        starts, goals = starts * [0.1, 0.1, 1.0], goals * [0.1, 0.1, 1.0]
        kw["workspace"] = (-h, h, -h, h)
    singles = []
    for s, g in zip(starts, goals):
        try:
            singles.append(_plan(pts, s, g, com=com, **kw))
        except pp.PlanningError:
            singles.append(None)
    batch = _batch(pts, starts, goals, com=com, chunk=64, **kw)
    assert [p is not None for p in singles] == batch.ok.tolist()
    assert batch.ok.mean() > 0.25
    if "workspace" in kw:
        assert batch.replanned   # the constrained LP was needed somewhere
    _agree(batch, singles, (name, options))
    c = kw.get("support", {}).get("c")
    for b in np.flatnonzero(batch.ok)[::5]:
        check_plan(batch.plan(b), pts, com, starts[b], goals[b], support_c=c,
                   min_mu=kw.get("min_fence_mu"), workspace=kw.get("workspace"))



RECT = [[-0.03, -0.01], [0.03, -0.01], [0.03, 0.01], [-0.03, 0.01]]
RECT_40_20 = [[0.0, 0.0], [0.04, 0.0], [0.04, 0.02], [0.0, 0.02]]   # examples/rectangle.yaml


@pytest.mark.parametrize("goal", [[0.22878430364261387, 0.0064239033261871414, -0.9783187754826552],
                                  [0.04283736027346463, -0.2961546704014139, 1.7131054551536122],
                                  [0.12505125414831963, 0.17349277422308756, 1.8799062969936164]])
def test_safety_factor_one_from_an_unwrapped_start(goal):
    """safety_factor = 1 leaves a reorient push no slack when the LP adds none:
    the replay's rounding of the (unwrapped, 6.2590 rad) start angle made such a
    push a hair short ("push 4 ended on edge -1 instead of 2").  Every reorient
    push now turns REORIENT_GUARD rad beyond its plan; tested on the paper's
    strategy (where it was found) and the default one."""
    start = [0.01, 0.02, 6.2590]
    for kw in ({}, {"strategy": "paper"}):
        plan = pp.plan_pose(RECT_40_20, start, goal,
                            options=PushOptions(margin_deg=10, safety_factor=1.0, **kw))
        check_plan(plan, RECT_40_20, None, start, goal, margin_deg=10, safety=1.0)


@pytest.mark.slow
def test_safety_factor_one():
    """safety_factor = 1 is allowed (>= 1) and gives valid plans, one and many at once."""
    start, goal = [0.0, 0.0, 0.0], [0.1, 0.2, 2.5]
    plan = pp.plan_pose(RECT, start, goal, options=PushOptions(safety_factor=1.0))
    check_plan(plan, RECT, None, start, goal, safety=1.0)
    rng = np.random.default_rng(5)
    starts = np.c_[rng.uniform(-0.2, 0.2, (64, 2)), rng.uniform(-8, 8, 64)]
    goals = np.c_[rng.uniform(-0.2, 0.2, (64, 2)), rng.uniform(-math.pi, math.pi, 64)]
    batch = pb.plan_pose_batch(RECT, starts, goals, chunk=64,
                               options=PushOptions(margin_deg=10, safety_factor=1.0))
    assert batch.ok.all()


def test_margin_zero_is_rejected():
    """margin_deg = 0 would need infinite pushes from the divergent orientation."""
    with pytest.raises(ValueError, match="^margin_deg"):
        pp.plan_pose(RECT, [0.0, 0.0, 0.0], [0.1, 0.2, 2.5], options=PushOptions(margin_deg=0.0))


# --------------------------------------------------------------------------
# near-marginal parts, scale, the effort budget
# --------------------------------------------------------------------------
def _marginal_parts(delta, count=7, seed=21):
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < count:
        pts, com = S.numpy_random_part(rng, max_points=7)
        body, _, _ = oracle.body_from_part(pts, com)
        e = int(rng.integers(len(body)))
        new = S.near_marginal(pts, com, e, int(rng.integers(2)), delta, bool(rng.integers(2)))
        if new is not None:
            out.append((pts, new))
    return out


class _Timeout(Exception):
    pass


@pytest.mark.parametrize("delta", [1e-7, 1e-9])
def test_near_marginal_parts_plan_in_the_usual_time(delta):
    """A foot of the centre of mass within ``delta`` of an edge end (relative to
    the edge) makes that edge's maximum reorient angle in one sense tiny; the
    margin rule halves it, and angle-eating used to plan ~1e7 steps (a hang, or
    MemoryError).  Now no plan has more than ``max_reorients`` reorient pushes:
    such a step is simply not used.  Seven parts, each within 20 s (the alarm
    turns a hang into a failure)."""
    import signal

    def alarm(*_):
        raise _Timeout()

    old = signal.signal(signal.SIGALRM, alarm)
    try:
        for pts, com in _marginal_parts(delta):
            start, goal = np.array([0.0, 0.0, 0.3]), np.array([0.1, -0.05, -2.2])
            signal.alarm(20)
            try:
                for strategy in ("search", "paper"):
                    plan = _plan_or_budget(pts, com, start, goal, strategy=strategy)
                    if plan is not None:
                        check_plan(plan, pts, com, start, goal)
            finally:
                signal.alarm(0)
    finally:
        signal.signal(signal.SIGALRM, old)


def test_effort_budget_error_says_so():
    """A part whose step angles cannot make a turn within max_reorients gets a
    PlanningError that names the budget."""
    with pytest.raises(pp.PlanningError, match="max_reorients=2"):
        pp.plan_pose(RECT, [0.0, 0.0, 0.0], [0.1, 0.2, 3.0],
                     options=PushOptions(max_reorients=2, strategy="paper"))


@pytest.mark.slow
@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e3, 1e9])
def test_plans_are_exact_at_every_scale(scale):
    """The same task at scales 1e-3 .. 1e9: every length tolerance is relative
    to the part's size, so each plan verifies (a 1e9 m part failed its own
    1e-9 m check) and lengths scale exactly; implausible sizes for metres warn."""
    pts, com = _fixed_parts()["nice"]
    start, goal = np.array([0.1, -0.2, 0.4]), np.array([0.3, 0.1, -2.0])
    ref = _plan(pts, start, goal, com=com)
    sc = np.array([scale, scale, 1.0])
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        plan = pp.plan_pose(np.asarray(pts) * scale, start * sc, goal * sc, com=np.asarray(com) * scale)
    warned = any(issubclass(w.category, pg.PartWarning) and "implausible" in str(w.message) for w in seen)
    size = _size(oracle.body_from_part(pts, com)[0]) * scale
    assert warned == (not 1e-4 <= size <= 5.0), [str(w.message) for w in seen]
    check_plan(plan, np.asarray(pts) * scale, np.asarray(com) * scale, start * sc, goal * sc)
    assert plan.total_distance == pytest.approx(ref.total_distance * scale, rel=1e-9)
    assert plan.n_pushes == ref.n_pushes
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", pg.PartWarning)
        batch = pb.plan_pose_batch(np.asarray(pts) * scale, (start * sc)[None], (goal * sc)[None],
                                   com=np.asarray(com) * scale)
    assert batch.ok.all() and batch.total_distance[0] == pytest.approx(plan.total_distance, rel=1e-9)


def test_millimetre_part_warns():
    with pytest.warns(pg.PartWarning, match="millimetres"):
        pg.make_polygon([[0, 0], [30, 0], [30, 20], [0, 20]])
    with pytest.warns(pg.PartWarning, match="implausible"):
        pg.make_polygon([[0, 0], [3e-9, 0], [3e-9, 2e-9]])




def test_uni_stable_runs_also_try_multiples_of_extra_steps(monkeypatch):
    """A uni-stable part steers only with its reorient runs: the search also
    tries 2, 3 and 4 times ``extra_steps`` more steps per run (a superset of the
    candidates, so no plan gets longer), and on the bundled uni-stable part,
    goals within 15 cm, some plans get shorter; every plan is replayed."""
    from planning.pushing import sequences as sq
    from sweeps.partfile import load_part

    assert sq.step_extras(pg.UNI_STABLE, 3) == (0, 1, 2, 3, 6, 9, 12)
    assert sq.step_extras(pg.NICE_STABLE, 3) == sq.step_extras(pg.BIPLUS_STABLE, 3) == (0, 1, 2, 3)
    assert sq.step_extras(pg.UNI_STABLE, 0) == (0,)
    part = load_part(pathlib.Path(__file__).parent.parent / "examples" / "unistable.yaml")
    rng = np.random.default_rng(3)
    r, a = 0.15 * np.sqrt(rng.uniform(0, 1, 6)), rng.uniform(-math.pi, math.pi, 6)
    starts = np.c_[np.zeros((6, 2)), rng.uniform(-math.pi, math.pi, 6)]
    goals = np.c_[r * np.cos(a), r * np.sin(a), rng.uniform(-math.pi, math.pi, 6)]

    def lengths():
        out = []
        for s, g in zip(starts, goals):
            plan = _plan(part.vertices, s, g, com=part.com)
            check_plan(plan, part.vertices, part.com, s, g)
            out.append(plan.total_distance)
        return np.array(out)

    more = lengths()
    monkeypatch.setattr(sq, "UNI_STEP_MULTIPLES", ())
    sq.candidate_table.cache_clear()
    try:
        fewer = lengths()
    finally:
        sq.candidate_table.cache_clear()
    assert np.all(more <= fewer * (1 + 1e-9))
    assert np.any(more < 0.97 * fewer), (more, fewer)


def test_no_sticking_reorient_push_says_why():
    """The bundled uni-stable part has no reorient push that sticks at fence
    friction 0.5 over its sampler's c range: the error says that only
    translations exist, and what to change, instead of asking for a larger
    reorient budget."""
    from sweeps.partfile import load_part

    part = load_part(pathlib.Path(__file__).parent.parent / "examples" / "unistable.yaml")
    kw = dict(com=part.com, support={"c": [0.0014, 0.0152]}, min_fence_mu=0.5)
    with pytest.raises(pp.PlanningError, match="only translation plans exist.*higher min_fence_mu") as err:
        _plan(part.vertices, (0, 0, 0), (0.1, 0.05, 1.0), **kw)
    assert "max_reorients" not in str(err.value) and len(str(err.value)) <= 300
    assert "min_fence_mu (--min-fence-mu, planner.min_fence_mu)" in str(err.value)
    assert _plan(part.vertices, (0, 0, 0), (0.1, 0.05, 1.0), **{**kw, "min_fence_mu": None}).n_pushes > 0


@pytest.mark.slow
def test_workspace_error_names_a_workspace_that_holds_a_plan():
    """A uni-stable part turns on a circle of 8 cm or more: 7.8 cm from the start
    with a 24 deg turn, no plan stays inside 30 x 30 cm.  The error names the
    smallest workspace found, the given one scaled about its centre, and a plan
    does fit that one (replayed, inside)."""
    from sweeps.partfile import load_part

    part = load_part(pathlib.Path(__file__).parent.parent / "examples" / "unistable.yaml")
    start, goal = np.array([0.0, 0.0, -0.0162]), np.array([0.034, -0.0701, -0.438])
    ws = (-0.15, 0.15, -0.15, 0.15)
    with pytest.raises(pp.WorkspaceError, match=r"smallest workspace found \(this one scaled about its "
                                                r"centre, by 1\.\d+\)") as err:
        _plan(part.vertices, start, goal, com=part.com, workspace=ws)
    scale, box = err.value.scale, err.value.smallest
    assert len(str(err.value)) <= 300
    assert 1.0 < scale < 2.0
    np.testing.assert_allclose(box, np.array(ws) * scale, rtol=1e-12)
    roomy = tuple(b + d for b, d in zip(box, (-1e-6, 1e-6, -1e-6, 1e-6)))
    plan = _plan(part.vertices, start, goal, com=part.com, workspace=roomy)
    check_plan(plan, part.vertices, part.com, start, goal, workspace=roomy)
    with pytest.raises(pp.WorkspaceError):      # and it is the smallest: 1 % less holds none
        _plan(part.vertices, start, goal, com=part.com, workspace=tuple(0.99 * b for b in box))


@pytest.mark.slow
def test_uni_stable_last_step_of_its_own(monkeypatch):
    """Uni-stable main runs may end with a step of a quarter to all of the step
    angle, the steps before it sharing the rest (rule ``LAST``): on the bundled
    part this goal's plan drops from over 3x to under 2x the straight distance;
    the batch planner gives the same plan."""
    from planning.pushing import sequences as sq
    from sweeps.partfile import load_part

    part = load_part(pathlib.Path(__file__).parent.parent / "examples" / "unistable.yaml")
    start, goal = np.array([0.0, 0.0, -3.0411]), np.array([-0.1223, 0.0359, 0.9589])
    straight = math.hypot(goal[0], goal[1])
    plan = _plan(part.vertices, start, goal, com=part.com)
    check_plan(plan, part.vertices, part.com, start, goal)
    turns = [p.rotation for p in plan.pushes if p.rotation]
    step = _cw_step(part)
    assert plan.total_distance < 2.0 * straight
    assert abs(abs(turns[-1]) - 0.75 * step) < 1e-9 and len({round(t, 12) for t in turns[:-1]}) == 1
    batch = pb.plan_pose_batch(part.vertices, start[None], goal[None], com=part.com)
    assert abs(batch.total_distance[0] - plan.total_distance) <= 1e-12 * plan.total_distance
    monkeypatch.setattr(sq, "LAST_FRACTIONS", ())
    sq.candidate_table.cache_clear()
    try:
        assert _plan(part.vertices, start, goal, com=part.com).total_distance > 3.0 * straight
    finally:
        sq.candidate_table.cache_clear()


def _cw_step(part) -> float:
    """The CW step angle (rad) of a bundled uni-stable part's one stable edge."""
    p = pp.prepare_part(part.vertices, part.com)
    return float(p.step[p.stable[0], pg.CW])


@pytest.mark.slow
@pytest.mark.parametrize("objective", ["distance", "pushes"])
def test_workspace_bound_gives_the_plan_of_fitting_every_candidate(monkeypatch, objective):
    """With a workspace, candidates are fitted in the order of their
    unconstrained optimum and the fitting stops once none left can be chosen:
    the plans (or the WorkspaceError and its scale) are those of fitting every
    candidate, and most fits are skipped."""
    from planning.pushing import workspace as wsp
    from sweeps.partfile import load_part

    part = load_part(pathlib.Path(__file__).parent.parent / "examples" / "unistable.yaml")
    rng = np.random.default_rng(5)
    ws = (-0.15, 0.15, -0.15, 0.15)
    calls = [0]
    real_fit = wsp.fit

    def counted(*a, **k):
        calls[0] += 1
        return real_fit(*a, **k)

    monkeypatch.setattr(wsp, "fit", counted)

    def run(exhaustive):
        monkeypatch.setattr(pp, "EXHAUSTIVE_FIT", exhaustive)
        calls[0] = 0
        out = []
        for start, goal in pairs:
            try:
                out.append(_plan(part.vertices, start, goal, com=part.com, workspace=ws, objective=objective))
            except pp.WorkspaceError as err:
                out.append(err.scale)
        return out, calls[0]

    prepared = pp.prepare_part(part.vertices, part.com)
    pairs = []
    while len(pairs) < 6:   # goals within 15 cm whose pose the workspace holds
        r, a = 0.15 * math.sqrt(rng.uniform()), rng.uniform(-math.pi, math.pi)
        start = np.array([0.0, 0.0, rng.uniform(-math.pi, math.pi)])
        goal = np.array([r * math.cos(a), r * math.sin(a), rng.uniform(-math.pi, math.pi)])
        if not any(wsp.outside(wsp.pose_box(prepared, p), ws, 0.0) for p in (start, goal)):
            pairs.append((start, goal))
    pairs = [pairs[i] for i in (0, 3, 4, 5)]      # three plans (6 to 11 pushes) and one WorkspaceError
    bounded, n_bounded = run(False)
    every, n_every = run(True)
    assert n_bounded < 0.5 * n_every
    assert any(isinstance(p, float) for p in bounded) and any(not isinstance(p, float) for p in bounded)
    for (start, goal), p, q in zip(pairs, bounded, every):
        if isinstance(q, float):
            assert p == q
            continue
        assert [(x.kind, x.edge, x.distance) for x in p.pushes] == [(x.kind, x.edge, x.distance) for x in q.pushes]
        check_plan(p, part.vertices, part.com, start, goal, workspace=ws)


@pytest.mark.slow
def test_plans_float64_cannot_replay_are_not_plans(monkeypatch):
    """A sliver of a uni-stable part, half a turn in place, paper strategy: its
    lowest tier's best LP pushes 4.7e9 m (translations that nearly cancel), which
    float64 cannot replay to 1e-9 of the part's size.  Such candidates are not
    plans: the planners (one by one and batched, the same plan) fall back to a
    replayable one; where every candidate is too long the error says so."""
    from planning.pushing.part import PushPart

    pts = np.array([[0.00425469, 0.0], [-0.00273486, 0.00325928], [-0.11170408, -0.0560999],
                    [0.00531837, -0.02243996]])
    com = np.zeros(2)
    start, goal = np.array([0.0, 0.0, -4 * math.pi]), np.array([0.0, 0.0, math.pi])
    kw = dict(com=com, margin_deg=1.0, safety_factor=1.0, strategy="paper")
    plan = _plan(pts, start, goal, **kw)
    part = pp.prepare_part(pts, com, 1.0, 1.0)
    assert plan.total_distance < 1e3 < part.longest_plan < 1e4
    check_plan(plan, pts, com, start, goal, margin_deg=1.0, safety=1.0)
    batch = _batch(pts, start[None], goal[None], **kw)
    _agree(batch, [plan], "sliver")
    monkeypatch.setattr(PushPart, "longest_plan", property(lambda self: 1e-3 * self.size))
    with pytest.raises(pp.PlanningError, match=r"the shortest candidate pushes [\d.e+]+ m in all, .* more "
                                               r"than float64 can replay \([\d.e+]+ m\); strategy='search' \(--strategy "
                                               r"search, planner.strategy: search\)") as err:
        _plan(pts, start, goal, **kw)
    assert len(str(err.value)) <= 300
    pb._plan_fns.cache_clear()          # the batch's compiled planners hold the limit
    try:
        assert not _batch(pts, start[None], goal[None], **kw).ok[0]
    finally:
        pb._plan_fns.cache_clear()
