"""What each model says became of every sample of a plan, by plan kind: the
kinematic replays' outcomes (:func:`push_rows`, :func:`tumble_rows`) and the
physics rollouts' (:func:`push_physics_rows`, :func:`tumble_physics_rows`), and
the success of many candidates of one task on the same draws (robust synthesis:
:func:`push_success_many`, :func:`tumble_success_many`), each sample classified by the evaluation's :class:`~robustness.SuccessCriterion`, as a
:class:`SampleOutcomes`.  The dispatch table :data:`robustness.kinds.KINDS` names
them per plan kind; :func:`robustness.evaluate` calls them through it.  Frames,
reference points and the failure modes: :mod:`robustness.evaluation`.
"""
from __future__ import annotations

import dataclasses
import warnings
from typing import Optional

import jax.numpy as jnp
import numpy as np

from kernels import wrap_angle_np
from robustness.hulls import face_merge_tol
from robustness.replay import (edge_pairs, push_nominal, run_push, run_push_many, run_tumble,
                               run_tumble_many, tumble_nominal)


@dataclasses.dataclass(frozen=True, eq=False)
class SampleOutcomes:
    """What a model says became of each of ``n`` samples (numpy arrays of
    length n), the input of the ``samples`` rows.

    Attributes:
      x, y, theta: final pose of the plan's reference point (m, m, rad; world
        frame, CCW positive).
      final_edge_a, final_edge_b, planned_edge_a, planned_edge_b: the caller's
        vertex indices of the edge on the fence after the last push, and of
        the planned one (-1: none, or a tumble plan).
      final_face, planned_face: the face on the plane after the last tumble,
        and the planned one (-1 for push plans).
      slip: summed slip (m).
      n_incomplete: pushes that did not finish reorienting (tumbles: the plan's
        steps that were invalid); first_wrong_step: the first push that
        landed another edge (-1: none).
      hull_changed: the perturbed part is not the nominal part's combinatorics;
        model_valid: the model's assumptions hold for the sample;
        in_bound_model: inside the analytic bound's model.
      success, failure_mode: the samples classified by the evaluation's
        :class:`~robustness.SuccessCriterion` (:meth:`~robustness.SuccessCriterion.classify`,
        with the model's own faults).
      max_tilt_rad: physics: the largest tilt of the part (rad; None: NaN).
      c_physical_m: physics, push: the limit-surface ratio that MuJoCo's support
        loads realise after the part settled (m; None: NaN), beside the drawn ``c``.
      support_ok: physics, push: the centre of mass stood inside the loaded support
        contacts after settling (None: null).
    """

    x: np.ndarray
    y: np.ndarray
    theta: np.ndarray
    final_edge_a: np.ndarray
    final_edge_b: np.ndarray
    planned_edge_a: np.ndarray
    planned_edge_b: np.ndarray
    final_face: np.ndarray
    planned_face: np.ndarray
    slip: np.ndarray
    n_incomplete: np.ndarray
    first_wrong_step: np.ndarray
    hull_changed: np.ndarray
    model_valid: np.ndarray
    in_bound_model: np.ndarray
    success: np.ndarray
    failure_mode: np.ndarray
    max_tilt_rad: Optional[np.ndarray] = None
    c_physical_m: Optional[np.ndarray] = None
    support_ok: Optional[np.ndarray] = None


def _warn_truncated(r, task) -> None:
    """A push still moving at the kernel's phase cap is reported, never silently kept."""
    k = int(np.sum(np.asarray(r.truncated)))
    if k:
        warnings.warn(f"task {task!r}: {k} sample(s) had a push still moving at the quasi-static "
                      "kernel's phase cap (kernels.quasistatic.phase_cap); they are counted as "
                      "incomplete_reorientation failures, outside the kernel's model",
                      RuntimeWarning, stacklevel=4)


def push_rows(plan, draws, criterion, *, model, dtype, chunk, task, sampler=None,
              merge_factor=None, key=None) -> SampleOutcomes:
    """Per-sample outcomes of a push plan under the quasi-static or exact kernel,
    classified by ``criterion`` (faults: ``hull_changed``,
    ``incomplete_reorientation``, ``wrong_edge``; a success whose intermediate push
    was incomplete or landed another edge stays a success, its flags visible in
    its columns).  ``sampler``, ``merge_factor``: not used (the table's one
    signature)."""
    P, n = len(plan.pushes), draws.n
    poly, planned, r = run_push(plan, draws, model, dtype, chunk)
    _warn_truncated(r, task)
    edges = np.asarray(r.edges).reshape(n, P)
    complete = np.asarray(r.complete).reshape(n, P).astype(bool)
    wrong = complete & (edges != np.asarray(planned, np.int64)[None, :])
    n_incomplete = (~complete).sum(axis=1)
    changed = np.asarray(r.changed).astype(bool)
    trunc = np.asarray(r.truncated).astype(bool)
    slip = np.asarray(r.slip, np.float64)
    fa, fb = edge_pairs(poly, edges[:, -1] if P else np.full(n, -1))
    pa, pb = edge_pairs(poly, np.full(n, planned[-1] if P else -1))
    valid = ~changed & ~trunc
    *_, ep, et = goal_errors(r.x, r.y, r.theta, plan.goal)
    success, mode = criterion.classify(ep, et, slip, valid=valid, faults=(
        ("hull_changed", changed), ("incomplete_reorientation", (n_incomplete > 0) | trunc),
        ("wrong_edge", wrong.any(axis=1))))
    return SampleOutcomes(
        x=r.x, y=r.y, theta=r.theta, final_edge_a=fa, final_edge_b=fb,
        planned_edge_a=pa, planned_edge_b=pb, final_face=np.full(n, -1, np.int64),
        planned_face=np.full(n, -1, np.int64), slip=slip, n_incomplete=n_incomplete,
        first_wrong_step=np.where(wrong.any(axis=1), np.argmax(wrong, axis=1), -1),
        hull_changed=changed, model_valid=valid,
        in_bound_model=(~changed) & (n_incomplete == 0) & (~wrong.any(axis=1)) & (slip == 0.0)
        & ~trunc, success=success, failure_mode=mode)


def tumble_rows(plan, draws, criterion, *, model="exact", dtype, chunk, task=None, sampler,
                merge_factor, key=None) -> SampleOutcomes:
    """Per-sample outcomes of a tumble plan under the exact tumble kinematics,
    classified by ``criterion`` (faults: ``combinatorics_changed``, ``wrong_face``:
    an invalid tumble or another face on the plane at the end, which rules a
    success out).  ``model``: tumbles are exact; ``task``: not used (the
    table's one signature)."""
    poly = tumble_nominal(plan)
    tol = None
    if sampler.geometry.tau_v > 0:   # the perturbed hulls, checked in the same compiled call
        v = np.asarray(poly.vertices)
        diam = float(np.max(np.linalg.norm(v[:, None] - v[None], axis=-1)))
        tol = face_merge_tol(sampler.geometry.tau_v, diam, merge_factor)
    n = draws.n
    poly, r = run_tumble(plan, draws, dtype, chunk, merge_tol=tol,
                         slip_theta=sampler.execution.tumble_slip_theta)
    changed = np.asarray(r.changed).astype(bool)
    face = np.asarray(r.face, np.int64)
    ok = np.asarray(r.ok).astype(bool)
    pface = np.full(n, int(plan.goal[3]), np.int64)
    bad_face = (~ok) | (face != pface)
    none = np.full(n, -1, np.int64)
    slip = np.asarray(r.slip, np.float64)
    *_, ep, et = goal_errors(r.x, r.y, r.theta, plan.goal)
    success, mode = criterion.classify(ep, et, slip, valid=~changed & ~bad_face, faults=(
        ("combinatorics_changed", changed), ("wrong_face", bad_face)))
    return SampleOutcomes(
        x=r.x, y=r.y, theta=r.theta, final_edge_a=none, final_edge_b=none,
        planned_edge_a=none, planned_edge_b=none, final_face=face, planned_face=pface,
        slip=slip, n_incomplete=(~ok).astype(np.int64),
        first_wrong_step=none, hull_changed=changed, model_valid=~changed,
        in_bound_model=(~changed) & (~bad_face), success=success, failure_mode=mode)


def push_physics_rows(plan, draws, sampler, criterion, merge_factor, run, common,
                      key=None) -> tuple:
    """A push plan rolled out in MuJoCo (:func:`robustness.physics.rollout_push_plan`):
    ``(its PushRollout, the push columns of its SampleOutcomes)``."""
    from robustness.physics import rollout_push_plan

    r = rollout_push_plan(plan, draws, stroke=run.stroke, **common)
    poly, planned = push_nominal(plan)
    edges = np.asarray(r.edges)
    complete = np.asarray(r.complete, bool)
    wrong = complete & (edges != np.asarray(planned, np.int64)[None, :])
    return r, push_physics_columns(r, poly, edges, complete, wrong, planned[-1])


def push_physics_columns(r, poly, edges, complete, wrong, planned_last: int) -> dict:
    """The push columns of a MuJoCo rollout's :class:`SampleOutcomes` (known-start
    and sensorless plans; ``r`` a :class:`robustness.physics.PushRollout`): the
    final and planned edges' vertex pairs, the pushes that ended on no edge
    (``complete`` (n, P) False) or on another than planned (``wrong`` (n, P)),
    the rollout's hull check, largest tilt (rad), realised ``c`` (m) and support
    check."""
    n = len(edges)
    none = np.full(n, -1, np.int64)
    fa, fb = edge_pairs(poly, edges[:, -1])
    pa, pb = edge_pairs(poly, np.full(n, planned_last))
    return dict(final_edge_a=fa, final_edge_b=fb, planned_edge_a=pa, planned_edge_b=pb,
                final_face=none, planned_face=none, n_incomplete=(~complete).sum(axis=1),
                first_wrong_step=np.where(wrong.any(axis=1), np.argmax(wrong, axis=1), -1),
                hull_changed=np.asarray(r.hull_changed, bool),
                max_tilt_rad=np.asarray(r.max_tilt, np.float64),
                c_physical_m=np.asarray(r.c_physical, np.float64),
                support_ok=np.asarray(r.support_ok, bool))


def tumble_physics_rows(plan, draws, sampler, criterion, merge_factor, run, common,
                        key=None) -> tuple:
    """A tumble plan rolled out in MuJoCo (:func:`robustness.physics.rollout_tumble_plan`),
    after the check that the pads grip the part
    (:func:`robustness.physics.settings.check_pad_friction`): ``(its
    TumbleRollout, the tumble columns of its SampleOutcomes)``."""
    from robustness.physics import rollout_tumble_plan
    from robustness.physics.settings import check_pad_friction
    from robustness.physics.tumbling import nominal_polyhedron

    check_pad_friction(sampler.friction, "tumble", nominal_polyhedron(plan), run.settings.grip_ratio)
    n = draws.n
    none = np.full(n, -1, np.int64)
    r = rollout_tumble_plan(plan, draws, merge_factor=merge_factor,
                            tau_v=sampler.geometry.tau_v, **common)
    extra = dict(final_edge_a=none, final_edge_b=none, planned_edge_a=none,
                 planned_edge_b=none, final_face=np.asarray(r.face, np.int64),
                 planned_face=np.full(n, int(plan.goal[3]), np.int64),
                 n_incomplete=np.asarray(r.n_wrong_faces, np.int64), first_wrong_step=none,
                 hull_changed=np.asarray(r.combinatorics_changed, bool))
    return r, extra


def push_success_many(plans, sampler, n, key, *, model, dtype, criterion, chunk,
                      merge_factor=None) -> np.ndarray:
    """The success ``(K, n)`` of ``K`` push candidates of one task on the same ``n``
    draws (common random numbers, :func:`robustness.replay.run_push_many`), under
    ``model`` (the quasi-static, limit-surface or exact kinematics: the table's
    row checks it).  ``merge_factor``: not used (the table's one signature)."""
    poly0 = plans[0].nominal_part()
    P = max(len(p.pushes) for p in plans)
    draws = sampler.sample(key, n, body=poly0.body, dtype=jnp.float64,
                           n_vertices=len(plans[0].vertices), dim=2, n_pushes=P)
    r = run_push_many(plans, draws.astype(jnp.dtype(dtype)), model, jnp.dtype(dtype), chunk)
    _, _, _, ep, et = goal_errors(r.x, r.y, r.theta, plans[0].goal)
    valid = ~np.asarray(r.changed, bool) & ~np.asarray(r.truncated, bool)
    return criterion.success(ep, et, valid)


def tumble_success_many(plans, sampler, n, key, *, model="exact", dtype, criterion, chunk,
                        merge_factor) -> np.ndarray:
    """The success ``(K, n)`` of ``K`` tumble candidates of one task on the same ``n``
    draws (:func:`robustness.replay.run_tumble_many`; on the goal face, the
    perturbed hull's faces those of the nominal part).  ``model``: tumbles are exact."""
    L = max(p.n_tumbles for p in plans)
    draws = sampler.sample(key, n, dtype=jnp.float64, n_vertices=len(plans[0].vertices), dim=3,
                           n_tumbles=L)
    tol = None
    if sampler.geometry.tau_v > 0:
        v = np.asarray(tumble_nominal(plans[0]).vertices)
        diam = float(np.max(np.linalg.norm(v[:, None] - v[None], axis=-1)))
        tol = face_merge_tol(sampler.geometry.tau_v, diam, merge_factor)
    r = run_tumble_many(plans, draws, jnp.dtype(dtype), chunk, merge_tol=tol,
                        slip_theta=sampler.execution.tumble_slip_theta)
    _, _, _, ep, et = goal_errors(r.x, r.y, r.theta, plans[0].goal)
    on_face = np.asarray(r.ok, bool) & (np.asarray(r.face) == int(plans[0].goal[3]))
    return criterion.success(ep, et, ~np.asarray(r.changed, bool) & on_face)


def goal_errors(x, y, theta, goal) -> tuple:
    """Final-pose errors against a plan's goal ``(x, y, theta[, face])``:
    ``(theta wrapped, err_x, err_y, err_pos, err_theta wrapped)`` (m, rad; world
    frame), numpy float64 of the shape of ``x``."""
    g = np.asarray(goal[:3], np.float64)
    th = wrap_angle_np(np.asarray(theta, np.float64))
    ex, ey = np.asarray(x, np.float64) - g[0], np.asarray(y, np.float64) - g[1]
    return th, ex, ey, np.hypot(ex, ey), wrap_angle_np(th - g[2])


__all__ = ["SampleOutcomes", "goal_errors", "push_rows", "tumble_rows", "push_physics_rows",
           "tumble_physics_rows", "push_success_many", "tumble_success_many"]
