"""Push plans rolled out in MuJoCo: :func:`rollout_push_plan`.

One row per sample, comparable row by row with
:func:`robustness.evaluation.evaluate`'s quasi-static and exact rows of the
same draws: the same perturbed hull (nominal order) and centre of mass, the
same support family (the part on its own underside or on the family's feet,
:mod:`robustness.physics.geometry`), ``mu_f``, ``mu_s``, start error, fence
angle and push-distance errors; poses reported for the NOMINAL reference point
(the simulated centre of mass minus ``R(theta) dcom``).  How the cell runs
the plan: :mod:`robustness.physics.pushing`.
"""
from __future__ import annotations

import time
from typing import Optional

import numpy as np

from kernels import wrap_angle_np, FAMILIES
from robustness.physics import geometry as geo, scene
from robustness.physics.monitor import Recorder, flush_edge, planar_pose, yaw_quat
from robustness.physics.pushing import FenceStrokes, PushTracker, nominal_polygon, push_parts
from robustness.physics.rollouts import PushRollout
from robustness.physics.runner import check_batch, make_engine, resolve_backend, run_schedule
from robustness.physics.settings import STROKES, PhysicsSettings
from robustness.tolerances import SuccessCriterion

#: the centre of mass may lie this far (m) outside the support contacts' hull and
#: still stand on them (a rigid rectangle's rests on a diagonal: on the hull's edge)
SUPPORT_OK_TOL = 1e-5
#: failure modes of a physics row, in the order they are assigned
PUSH_FAILURE_MODES = ("none", "hull_changed", "left_workspace", "toppled", "fence_strike",
                      "incomplete_reorientation", "wrong_edge", "slip", "position", "orientation")


def _workspace(plan, poly, s) -> tuple:
    """Default workspace: the planned centre-of-mass positions and the fence's
    planned strokes, grown by the part's radius, the push offset and 5 cm."""
    pts = [plan.start[:2]] + [q.pose_after[:2] for q in plan.pushes]
    xy = np.asarray(pts, np.float64)
    grow = float(np.max(np.linalg.norm(poly.body, axis=1))) + s.push_offset + 0.05
    return (xy[:, 0].min() - grow, xy[:, 0].max() + grow, xy[:, 1].min() - grow,
            xy[:, 1].max() + grow)


def _models(parts, idx, s, impratio):
    models = []
    for i in idx:
        mass, inertia = geo.prism_mass_properties(parts.body[i], s.part_thickness, s.part_density)
        drop = s.flatness * parts.lift[i] if parts.n_feet[i] == 0 else np.zeros(parts.lift.shape[1])
        models.append(scene.push_model(parts.body[i], parts.feet[i], int(parts.n_feet[i]), drop,
                                       mass, inertia, float(parts.mu_f[i]), float(parts.mu_s[i]),
                                       s, impratio))
    return models


def _initial_state(parts, idx, layout, schedule, s) -> np.ndarray:
    st = np.zeros((len(idx), layout.nstate))
    pq, tq = layout.part_qpos, layout.tool_qpos
    st[:, pq:pq + 2] = parts.start[idx, :2]
    rests = np.where(parts.n_feet[idx] > 0, s.foot_radius, s.flatness * parts.lift[idx].max(axis=1))
    st[:, pq + 2] = rests
    st[:, pq + 3:pq + 7] = yaw_quat(parts.start[idx, 2])
    st[:, tq:tq + 4] = np.broadcast_to(schedule.phases[0].start, (len(idx), 4))
    return st


def _simulate(plan, poly, parts, idx, s, backend, workspace, stroke):
    """Run the valid samples; returns the per-sample pieces for them."""
    models = _models(parts, idx, s, s.impratio)
    lay = scene.layout(models[0])
    strokes = FenceStrokes(plan, poly, parts, idx, s, stroke == "contact")
    sched = strokes.schedule
    settle = 0
    dwells = [strokes.phase_of[k]["dwell"] for k in range(len(plan.pushes))]
    rec = Recorder(sched, lay, len(idx), workspace, keep=[settle] + dwells)
    body = parts.body[idx]
    trk = PushTracker(sched, lay, body, len(plan.pushes), s)
    engine = make_engine(backend, models, s)
    out = {"c_physical": np.full(len(idx), np.nan), "support_ok": np.zeros(len(idx), bool)}
    before = {settle: 0, **{strokes.phase_of[k]["lift"]: k + 1 for k in range(len(plan.pushes) - 1)}}

    def next_push(state, i_phase):
        """Contact strokes: push k's stroke from where the part is now."""
        if stroke == "contact" and i_phase in before:
            strokes.retarget(before[i_phase], state, lay, body)
        return state

    def after_settle(state, i_phase):
        """The loads MuJoCo put on the support: the limit-surface ratio they
        realise, and whether the centre of mass stands inside the support contacts."""
        for j, m in enumerate(models):
            pts, loads = scene.support_loads(m, state[j])
            out["c_physical"][j] = geo.realised_c(pts, loads)
            out["support_ok"][j] = geo.com_inside_feet(pts, margin=-SUPPORT_OK_TOL)
        return next_push(state, i_phase)

    hooks = {p: next_push for p in before if stroke == "contact"}
    hooks[settle] = after_settle
    try:
        final = run_schedule(engine, sched, _initial_state(parts, idx, lay, sched, s), [rec, trk],
                             s.chunk_steps, hooks=hooks)
    finally:
        engine.close()
    dcom = parts.dcom[idx]
    poses, edges = [], []
    for p in dwells:
        pose, _ = planar_pose(rec.ends[p], lay, dcom)
        poses.append(pose)
        edges.append(flush_edge(rec.ends[p], lay, body, s.fence_thickness, s.flush_tol,
                                s.contact_tol))
    pose_f, tilt_f = planar_pose(final, lay, dcom)
    out.update(pose=pose_f, final_tilt=tilt_f, pose_after=np.stack(poses, 1),
               edges=np.stack(edges, 1), slip_per_push=trk.slip, contact=trk.contact,
               fence_strike=trk.strike, max_tilt=rec.max_tilt, left_workspace=rec.left,
               steps=sched.total)
    return out


def rollout_push_plan(plan, draws, *, backend: str = "auto",
                      settings: Optional[PhysicsSettings] = None, workspace=None,
                      criterion: Optional[SuccessCriterion] = None,
                      stroke: str = "planned") -> PushRollout:
    """Roll a push plan out in MuJoCo on sampled parts and executions.

    Args:
      plan: a :class:`planning.PushPlan`.
      draws: the ``n`` samples, ``robustness.Sampler(...).sample(key, n,
        n_vertices=m, dim=2, n_pushes=P, body=<nominal body polygon>)``.
      backend: ``"c"`` (C engine, ``mujoco.rollout`` threads), ``"mjx"`` (MJX,
        float32, vmapped) or ``"auto"`` (MJX on an accelerator, else C).
      settings: :class:`PhysicsSettings` (defaults documented there).
      workspace: ``(xmin, xmax, ymin, ymax)`` (m, world): leaving it fails
        the sample; default: the plan's poses and strokes grown by 5 cm and
        the part's size.
      criterion: the :class:`~robustness.SuccessCriterion` that classifies the
        samples (default: a push plan's, 1 mm and 1 degree), as in the
        evaluation.
      stroke: ``"planned"`` (open loop: every stroke from the planned pose,
        as a cell without sensing runs the plan) or ``"contact"`` (each
        stroke from where the part is before the push: the fence's
        in-contact travel is the sampled distance, the semantics of the
        quasi-static and exact models; use it to compare rows).

    Returns:
      a :class:`~robustness.physics.rollouts.PushRollout` (its fields, one row
      per sample, with their units and frames documented there).
    """
    s = settings or PhysicsSettings()
    backend = resolve_backend(backend, s)
    check_batch(draws)
    n = draws.n
    if not plan.pushes:
        raise ValueError("plan: has no pushes; nothing to roll out")
    if stroke not in STROKES:
        raise ValueError(f"stroke: expected one of {STROKES}, got {stroke!r}")
    t0 = time.perf_counter()
    poly, planned = nominal_polygon(plan)
    parts = push_parts(plan, poly, draws)
    ws = tuple(workspace) if workspace is not None else _workspace(plan, poly, s)
    idx = np.flatnonzero(parts.valid)
    P = len(plan.pushes)
    res = {"x": np.full(n, np.nan), "y": np.full(n, np.nan), "theta": np.full(n, np.nan),
           "pose_after": np.full((n, P, 3), np.nan), "edges": np.full((n, P), -1, np.int64),
           "slip_per_push": np.full((n, P), np.nan), "contact": np.zeros((n, P), bool),
           "max_tilt": np.full(n, np.nan), "final_tilt": np.full(n, np.nan),
           "fence_strike": np.zeros(n, bool), "left_workspace": np.zeros(n, bool),
           "support_ok": np.zeros(n, bool), "c_physical": np.full(n, np.nan)}
    steps = 0
    for lo in range(0, idx.size, s.batch):
        grp = idx[lo:lo + s.batch]
        out = _simulate(plan, poly, parts, grp, s, backend, ws, stroke)
        steps = out.pop("steps")
        pose = out.pop("pose")
        res["x"][grp], res["y"][grp], res["theta"][grp] = pose[:, 0], pose[:, 1], pose[:, 2]
        for k, v in out.items():
            res[k][grp] = v
    _classify(res, plan, planned, parts, criterion or SuccessCriterion.for_plan(plan), s)
    res.update(backend=backend, steps=int(steps), seconds=time.perf_counter() - t0)
    return PushRollout(**res)


def _classify(res, plan, planned, parts, criterion, s) -> None:
    """Flags, errors, success and failure mode (``criterion``'s classification, the
    faults in ``PUSH_FAILURE_MODES`` order; a fence strike, an incomplete push or
    one on another edge leaves a success a success)."""
    sim = parts.valid.copy()
    planned = np.asarray(planned, np.int64)
    res["planned_edges"] = planned
    res["complete"] = res["edges"] >= 0
    res["slip"] = np.nansum(res["slip_per_push"], axis=1)
    res["tipped"] = sim & (res["max_tilt"] > s.tip_angle)
    res["toppled"] = sim & (res["final_tilt"] > s.topple_angle)
    res["hull_changed"] = ~parts.valid
    res["simulated"] = sim
    res["c"] = np.asarray(parts.c, np.float64)
    res["c_support"] = parts.c_support
    res["support"] = np.asarray(FAMILIES, dtype=object)[parts.family]
    goal = np.asarray(plan.goal, np.float64)
    res["err_x"], res["err_y"] = res["x"] - goal[0], res["y"] - goal[1]
    res["err_pos"] = np.hypot(res["err_x"], res["err_y"])
    res["err_theta"] = wrap_angle_np(res["theta"] - goal[2])
    incomplete = (~res["complete"]).any(axis=1)
    wrong = (res["complete"] & (res["edges"] != planned[None, :])).any(axis=1)
    faults = (~sim, res["left_workspace"], res["toppled"], res["fence_strike"], incomplete, wrong)
    res["success"], res["failure_mode"] = criterion.classify(
        res["err_pos"], res["err_theta"], res["slip"],
        valid=sim & ~res["left_workspace"] & ~res["toppled"],
        faults=tuple(zip(PUSH_FAILURE_MODES[1:7], faults)))


__all__ = ["rollout_push_plan", "PUSH_FAILURE_MODES", "STROKES"]
