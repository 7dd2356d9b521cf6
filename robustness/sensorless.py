"""Monte Carlo of sensorless plans (issue 40): a
:class:`~planning.SensorlessPlan` replayed on perturbed parts, friction and
robot errors from starts drawn over the plan's own start set.

**The start.**  A known-start plan's sample starts at the plan's start plus the
sampler's start error (:mod:`robustness.evaluation`).  A sensorless plan has no
start: it claims to work "from any heading in ``[a, b]`` and any position in
the region".  So each sample's start heading is drawn uniformly from the
plan's heading interval (``[-pi, pi)`` for any heading) and its position
uniformly from the region (``(xmin, xmax) x (ymin, ymax)``, m, world), and
that draw REPLACES the sampler's start error (``execution.start_xy``,
``start_theta`` are not applied: no robot places the part; the region and the
interval are the start's whole uncertainty, and a start outside them is
outside the claim).  The draw uses its own key (``fold_in(key,``
:data:`START_STREAM` ``)``), so the sampler's other draws are those a
known-start plan of the same key gets.  The ``samples`` table's
``start_dx_m``, ``start_dy_m``, ``start_dtheta_rad`` hold the drawn start
minus the plan's reference start (:attr:`planning.SensorlessPlan.start`: the
region's centre, the interval's middle or 0), so every sample's start can be
read back.

**The pushes.**  Every push of a sensorless plan is a fence that stops at a
line (:class:`planning.FencePush`: ``direction . q = line``), not a distance:
the fence's travel after contact is ``line - min_i(direction . p_i)`` over the
part's vertices at the pose it has when that push starts (the nominal
direction: the robot commands the line), times ``1 + distance_rel`` plus
``distance_abs`` (the sampler's distance errors, floored at 0), along the
direction turned by the sample's fence-angle error.  Each push runs the
model's kernel for one push (quasi-static :func:`kernels.simulate_push`, the
exact limit surface :func:`kernels.simulate_push_on_points`, or the exact
replay :func:`kernels.replay_push`); the part's perturbed geometry and the
reference point (the nominal centre of mass) are those of
:mod:`robustness.evaluation`.

**Success.**  The final pose against the plan's goal, the heading modulo the
part's symmetry period when the part looks the same turned by it (the
``final_theta_rad`` column is reported folded to within half a period of the
goal's heading); a push that ends flush on none of the edges the plan allows
for it (:attr:`planning.FencePush.edges`) is ``wrong_edge``, one that ends on
a vertex ``incomplete_reorientation``.  No analytic bound is computed (the
first-order bound linearises about one nominal start).

**MuJoCo** (``model="mujoco"``, :func:`sensorless_physics_rows`): each sample
is the plan from its drawn start (:func:`start_plan`: the exact replay's
in-contact travel of every fence to its line) rolled out on its perturbed part,
friction and fence errors with contact strokes, one rollout a sample; its final
heading folded as above and judged against the goal turned by the period.

Units: metres, radians, world frame.
"""
from __future__ import annotations

import dataclasses
import functools
import math
import warnings

import jax
import jax.numpy as jnp
import numpy as np

from kernels import PartWarning, rot2, wrap_angle_np

#: ``jax.random.fold_in(key, START_STREAM)`` draws a sensorless sample's start
START_STREAM = 0x5E0540


def is_sensorless(plan) -> bool:
    """Whether ``plan`` is a :class:`planning.SensorlessPlan`."""
    from planning import SensorlessPlan

    return isinstance(plan, SensorlessPlan)


def start_set(plan) -> str:
    """The starts a sensorless plan claims, in words: ``any heading in [a, b]
    deg and any position in [xmin, xmax] x [ymin, ymax] m``."""
    lo, hi = (-math.pi, math.pi) if plan.start_heading is None else plan.start_heading
    r = plan.region
    return (f"any heading in [{math.degrees(lo):.4g}, {math.degrees(hi):.4g}] deg and any "
            f"position in [{r[0]:.4g}, {r[1]:.4g}] x [{r[2]:.4g}, {r[3]:.4g}] m")


def draw_starts(plan, key, n: int) -> np.ndarray:
    """(n, 3) float64 start poses ``(x, y, theta)`` (m, m, rad; world), uniform
    over the plan's region and heading interval (any heading: ``[-pi, pi)``),
    drawn with ``fold_in(key, START_STREAM)``."""
    lo, hi = (-math.pi, math.pi) if plan.start_heading is None else plan.start_heading
    r = plan.region
    with jax.enable_x64(True):
        u = np.asarray(jax.random.uniform(jax.random.fold_in(key, START_STREAM), (int(n), 3),
                                          jnp.float64))
    low = np.array([r[0], r[2], lo])
    return low + u * (np.array([r[1], r[3], hi]) - low)


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class FenceNominal:
    """A sensorless plan's numbers, padded to its buckets (traced): ``V0`` (mp, 2)
    caller's vertices (m), ``com0`` (2,), ``ang`` (Pp,) fence directions (rad),
    ``line`` (Pp,) the fences' final lines (m), ``active`` (Pp,) real pushes,
    ``hull`` the hull's vertex indices."""

    V0: jax.Array
    com0: jax.Array
    ang: jax.Array
    line: jax.Array
    active: jax.Array
    hull: jax.Array


def _fence_one(nom: FenceNominal, q, start, model):
    """One sample: the fence-line pushes from ``start`` (module docstring)."""
    from robustness.replay import PushReplay, perturbed_polygon

    dt = nom.V0.dtype
    geom, changed = perturbed_polygon(nom, q)
    th0 = start[2]
    pose0 = jnp.concatenate([start[:2] + rot2(th0) @ q.dc, th0[None]])
    if isinstance(model, tuple):
        from kernels import family_support

        pts, wts = family_support(model[1], q.family, geom.body, q.c, q.lift, q.points, q.weights)

    def step(p, xs):
        a, line, act, fe, rel, ab = xs
        dn = jnp.stack([jnp.cos(a), jnp.sin(a)])
        world = p[:2] + geom.body @ rot2(p[2]).T
        s = line - jnp.min(world @ dn)
        dist = jnp.where(act, jnp.maximum(s * (1.0 + rel) + ab, 0.0), 0.0)
        d = jnp.stack([jnp.cos(a + fe), jnp.sin(a + fe)])
        if model == "exact":
            from kernels import replay_push

            out = replay_push(geom, p, d, dist)
            slip, trunc = jnp.zeros((), dt), ~out.finished
        elif isinstance(model, tuple):
            from kernels import simulate_push_on_points

            out = simulate_push_on_points(geom, p, d, dist, pts, wts, q.mu)
            slip, trunc = out.slip, out.truncated
        else:
            from kernels import simulate_push

            out = simulate_push(geom, p, d, dist, q.c, q.mu)
            slip, trunc = out.slip, out.truncated
        new = jnp.where(act, out.pose, p)
        return new, (out.edge, out.complete, jnp.where(act, slip, 0.0), act & trunc)

    xs = (nom.ang, nom.line, nom.active, q.fence, q.rel, q.abs)
    final, (edges, complete, slip, trunc) = jax.lax.scan(step, pose0.astype(dt), xs)
    ref = final[:2] - rot2(final[2]) @ q.dc
    return PushReplay(x=ref[0], y=ref[1], theta=final[2], edges=edges, complete=complete,
                      slip=jnp.sum(slip), changed=changed, truncated=jnp.any(trunc))


@functools.partial(jax.jit, static_argnames=("model",))
def _fence_batch(nom, rows, model):
    from robustness.replay import _block, _blocks

    def one(r):
        return _fence_one(nom, r[0], r[1], model)

    return _blocks(lambda b: jax.vmap(one)(b), rows, _block(model))


def allowed_edges(plan) -> tuple:
    """``(poly, allowed)``: the plan's nominal polygon and, per push, the hull
    edges it may end flush on (a list of sets, hull order)."""
    poly = plan.nominal_part()
    return poly, [{poly.caller_edge_to_hull(e) for e in p.edges} for p in plan.pushes]


def wrong_pushes(edges, complete, allowed) -> np.ndarray:
    """(n, P) bool: push ``k`` ended flush (``complete``) on none of ``allowed[k]``."""
    ok = np.stack([np.isin(edges[:, k], sorted(a)) for k, a in enumerate(allowed)], axis=1)
    return np.asarray(complete, bool) & ~ok


def run_sensorless(plan, draws, starts, model, dtype, chunk):
    """Replay a sensorless plan on the samples ``draws`` from ``starts`` ((n, 3),
    m, m, rad); returns ``(poly, allowed, PushReplay)``: the nominal polygon,
    each push's allowed hull edges (a list of sets) and the per-sample outcomes
    (numpy; ``edges`` / ``complete`` (n, P))."""
    from robustness.replay import (_bucket, _push_samples_of, _run_chunks, _static_model,
                                   limit_surface_calls)

    poly, allowed = allowed_edges(plan)
    P, m = len(plan.pushes), len(plan.vertices)
    Pp, mp = _bucket(P, 8), _bucket(m, 4)
    ang = np.zeros(Pp)
    line = np.zeros(Pp)
    for i, p in enumerate(plan.pushes):
        ang[i] = math.atan2(p.direction[1], p.direction[0])
        line[i] = p.line
    V0 = np.zeros((mp, 2))
    V0[:m] = poly.vertices
    nom = FenceNominal(V0=jnp.asarray(V0, dtype), com0=jnp.asarray(poly.com, dtype),
                       ang=jnp.asarray(ang, dtype), line=jnp.asarray(line, dtype),
                       active=jnp.asarray(np.arange(Pp) < P),
                       hull=jnp.asarray(np.asarray(poly.hull_index, np.int32)))
    rows = (_push_samples_of(draws, Pp, mp, dtype), jnp.asarray(starts, dtype))
    static = _static_model(model, draws)
    call, whole = limit_surface_calls(static, draws.n, chunk)
    res = _run_chunks(_fence_batch, nom, rows, draws.n, call, static, whole=whole)
    res = dataclasses.replace(res, edges=res.edges[:, :P], complete=res.complete[:, :P])
    return poly, allowed, res


def fold_heading(plan, theta) -> np.ndarray:
    """Headings (rad) folded to within half a symmetry period of the goal's when
    the part looks the same turned by the period (else wrapped, unchanged)."""
    th = wrap_angle_np(np.asarray(theta, np.float64))
    if not plan.part_symmetric or plan.symmetry <= 1:
        return th
    g = float(plan.goal[2])
    d = wrap_angle_np(th - g)
    return wrap_angle_np(th - np.round(d / plan.period) * plan.period)


def sensorless_rows(plan, draws, starts, criterion, model, dtype, chunk):
    """Per-sample outcomes (:class:`robustness.evaluation.SampleOutcomes`) of a
    sensorless plan, classified by ``criterion`` (faults ``hull_changed``,
    ``incomplete_reorientation``, ``wrong_edge``: a push flush on none of its
    allowed edges)."""
    from robustness.outcomes import SampleOutcomes, goal_errors
    from robustness.replay import edge_pairs

    n, P = draws.n, len(plan.pushes)
    poly, allowed, r = run_sensorless(plan, draws, starts, model, dtype, chunk)
    edges = np.asarray(r.edges, np.int64).reshape(n, P)
    complete = np.asarray(r.complete).reshape(n, P).astype(bool)
    wrong = wrong_pushes(edges, complete, allowed)
    n_incomplete = (~complete).sum(axis=1)
    changed = np.asarray(r.changed).astype(bool)
    trunc = np.asarray(r.truncated).astype(bool)
    slip = np.asarray(r.slip, np.float64)
    theta = fold_heading(plan, r.theta)
    fa, fb = edge_pairs(poly, edges[:, -1])
    pa, pb = edge_pairs(poly, np.full(n, min(allowed[-1])))
    valid = ~changed & ~trunc
    *_, ep, et = goal_errors(r.x, r.y, theta, plan.goal)
    success, mode = criterion.classify(ep, et, slip, valid=valid, faults=(
        ("hull_changed", changed), ("incomplete_reorientation", (n_incomplete > 0) | trunc),
        ("wrong_edge", wrong.any(axis=1))))
    none = np.full(n, -1, np.int64)
    return SampleOutcomes(
        x=r.x, y=r.y, theta=theta, final_edge_a=fa, final_edge_b=fb, planned_edge_a=pa,
        planned_edge_b=pb, final_face=none, planned_face=none, slip=slip,
        n_incomplete=n_incomplete,
        first_wrong_step=np.where(wrong.any(axis=1), np.argmax(wrong, axis=1), -1),
        hull_changed=changed, model_valid=valid, in_bound_model=np.zeros(n, bool),
        success=success, failure_mode=mode)


def start_plan(plan, start):
    """The sensorless plan from one start as a :class:`planning.PushPlan`: each
    fence push's in-contact travel, the edge that ends flush and the pose after it
    from the exact replay of the nominal part from ``start`` ((3,), m, m, rad,
    world); its goal the plan's goal turned by the multiple of the symmetry period
    nearest the replay's final heading (the goal itself on a part that does not
    look the same turned).  What MuJoCo rolls out with contact strokes (each
    stroke's travel counted from where the fence meets the part: the line's).

    Raises:
      ValueError: a fence that misses the part from ``start`` (outside the start set).
    """
    from planning import Push, PushPlan, prepare_part, replay_sensorless

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PartWarning)
        part = prepare_part(np.asarray(plan.vertices), np.asarray(plan.com))
    pose, pushes = np.asarray(start, np.float64), []
    for q in plan.pushes:
        d = np.asarray(q.direction, np.float64)
        final, travel, _ = replay_sensorless(part, [q], pose[None, :])
        travel = float(travel[0])   # the fence's travel after contact, to its line
        if travel < 0:
            raise ValueError(f"start: the fence of push {len(pushes)} misses the part from "
                             f"{tuple(np.round(start, 6))} (outside the plan's start set)")
        after = np.asarray(final[0], np.float64)
        turn = float(wrap_angle_np(after[2] - pose[2]))
        nu_w = part.nu + after[2]   # the edge flush: outward normal opposite to the push
        e = int(np.argmin(np.abs(wrap_angle_np(nu_w - math.atan2(-d[1], -d[0])))))
        pushes.append(Push(kind="reorient" if abs(turn) > 1e-9 else "translate",
                           direction=(float(d[0]), float(d[1])), distance=travel,
                           edge=part.polygon.edge_vertices(e), contact_vertex=None,
                           min_distance=None, pose_after=tuple(float(x) for x in after),
                           rotation=turn if abs(turn) > 1e-9 else None))
        pose = after
    g = np.asarray(plan.goal, np.float64)
    per = plan.period if plan.part_symmetric and plan.symmetry > 1 else 2 * math.pi
    goal = (float(g[0]), float(g[1]),
            float(wrap_angle_np(g[2] + np.round(wrap_angle_np(pose[2] - g[2]) / per) * per)))
    return PushPlan(vertices=tuple(map(tuple, part.polygon.vertices)), com=tuple(part.polygon.com),
                    start=tuple(float(x) for x in start), goal=goal, pushes=tuple(pushes),
                    plan_class="cw", reorient_edge=None, object_class=part.class_name,
                    objective_value=0.0, total_distance=float(sum(p.distance for p in pushes)),
                    final_error=(0.0, 0.0))


def sensorless_physics_rows(plan, draws, sampler, criterion, merge_factor, run, common,
                            key=None) -> tuple:
    """A sensorless plan rolled out in MuJoCo from the starts its kinematic rows
    draw (:func:`draw_starts` of the evaluation's ``key``, which replace the
    sampler's start error): each sample the plan from its start
    (:func:`start_plan`) on its perturbed part, friction and fence errors,
    contact strokes (:func:`robustness.physics.rollout_push_plan`), judged by
    ``criterion`` against the goal turned by the symmetry period.  One rollout
    per sample (each start its own strokes): ``(a PushRollout of the n samples,
    the push columns of its SampleOutcomes)``, the samples' rows of their
    rollouts with the final heading folded as the kinematic rows'
    (:func:`fold_heading`); ``planned_edges`` -1 (each start plans its own
    edges: :func:`allowed_edges` judges them), ``steps`` the longest rollout's,
    ``seconds`` their sum."""
    from robustness.outcomes import push_physics_columns
    from robustness.physics import rollout_push_plan
    from robustness.samplers import Draws

    n = draws.n
    starts = draw_starts(plan, key, n)
    ex = draws.params.execution   # the drawn start replaces the start error
    params = dataclasses.replace(draws.params, execution=dataclasses.replace(
        ex, start_offset=jnp.zeros_like(ex.start_offset)))
    zeroed = Draws(params, draws.in_axes, n)
    got = [rollout_push_plan(start_plan(plan, starts[i]), zeroed.slice(i, i + 1),
                             stroke="contact", **common) for i in range(n)]
    # each rollout is of one sample: its per-sample arrays have a leading axis of 1
    per_rollout = ("planned_edges", "backend", "steps", "seconds")
    rows = {f.name: np.concatenate([getattr(g, f.name) for g in got])
            for f in dataclasses.fields(got[0]) if f.name not in per_rollout}
    rows["theta"] = fold_heading(plan, rows["theta"])
    r = dataclasses.replace(got[0], **rows, planned_edges=np.full_like(got[0].planned_edges, -1),
                            steps=max(g.steps for g in got), seconds=sum(g.seconds for g in got))
    poly, allowed = allowed_edges(plan)
    edges, complete = r.edges.astype(np.int64), r.complete.astype(bool)
    return r, push_physics_columns(r, poly, edges, complete,
                                   wrong_pushes(edges, complete, allowed), min(allowed[-1]))


__all__ = ["START_STREAM", "is_sensorless", "start_set", "draw_starts", "allowed_edges",
           "wrong_pushes", "run_sensorless",
           "sensorless_rows", "fold_heading", "start_plan", "sensorless_physics_rows"]
