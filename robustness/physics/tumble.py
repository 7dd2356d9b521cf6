"""Tumble plans rolled out in MuJoCo: :func:`rollout_tumble_plan`.

One row per sample, comparable row by row with
:func:`robustness.evaluation.evaluate`'s rows of the same draws: the same
perturbed vertices and centre of mass (the nominal faces), start error
(the part placed by the NOMINAL frame of its start face) and slips after the
tumbles; the final configuration is that of the NOMINAL frame of the face on
the support.  The device and its open-loop schedule:
:mod:`robustness.physics.tumbling`.
"""
from __future__ import annotations

import math
import time
from typing import Optional

import numpy as np

from kernels import wrap_angle_np
from robustness.physics import geometry as geo, scene, tumbling as tb
from robustness.physics.monitor import Recorder, mat_to_quat
from robustness.physics.rollouts import TumbleRollout
from robustness.physics.runner import check_batch, make_engine, resolve_backend, run_schedule
from robustness.physics.settings import PhysicsSettings
from robustness.tolerances import SuccessCriterion

#: failure modes of a physics row, in the order they are assigned
TUMBLE_FAILURE_MODES = ("none", "combinatorics_changed", "left_workspace", "wrong_face", "slip",
                        "position", "orientation")


def _workspace(configs, diam: float) -> tuple:
    grow = 2.0 * diam + 0.05
    xy = configs[:, :2]
    return (xy[:, 0].min() - grow, xy[:, 0].max() + grow, xy[:, 1].min() - grow,
            xy[:, 1].max() + grow)


def _final_config(state, lay, parts, idx, poly, face_tol):
    """Faces on the support and the final configurations (nominal frames)."""
    R, t = tb.body_pose(state, lay)
    faces = np.array([tb.face_down(R[j:j + 1], parts.normals[i:i + 1], face_tol)[0]
                      for j, i in enumerate(idx)])
    out = np.full((len(idx), 3), np.nan)
    for j, f in enumerate(faces):
        if f < 0:
            continue
        o = R[j] @ poly.face_origins[f] + t[j]
        xa = R[j] @ poly.face_rotations[f][0]
        out[j] = (o[0], o[1], math.atan2(xa[1], xa[0]))
    return faces, out


def _simulate(plan, poly, parts, idx, s, backend, workspace):
    hull = list(poly.hull_vertices)
    mass0 = tb.part_mass(poly, s)
    sched, plate_half, jaw, grip = tb.tumble_schedule(plan, poly, s, mass0)
    models = []
    impratio = s.impratio
    for i in idx:
        mass, inertia = geo.polyhedron_mass_properties(parts.vertices[i][hull], parts.com[i],
                                                       s.polyhedron_density)
        models.append(scene.tumble_model(parts.vertices[i][hull], parts.com[i], mass, inertia,
                                         float(parts.mu_f[i]), float(parts.mu_s[i]), plate_half,
                                         jaw, grip, s, impratio))
    lay = scene.layout(models[0])
    st0 = np.zeros((len(idx), lay.nstate))
    pq, tq = lay.part_qpos, lay.tool_qpos
    for j, i in enumerate(idx):
        Rb, tb0 = tb.start_pose(parts, poly, int(plan.start[3]), i)
        st0[j, pq:pq + 3] = tb0
        st0[j, pq + 3:pq + 7] = mat_to_quat(Rb[None])[0]
    st0[:, tq:tq + 4] = sched.phases[0].start
    dwell = [p for p, ph in enumerate(sched.phases) if ph.kind == "dwell"]
    holds = [p for p, ph in enumerate(sched.phases) if ph.kind == "hold"]
    lifts = [p for p, ph in enumerate(sched.phases) if ph.kind == "lift"]
    pts = np.stack([parts.vertices[i][hull] for i in idx])
    rec = Recorder(sched, lay, len(idx), workspace, keep=dwell + holds + lifts,
                   support=(pts, jaw.rectangle))
    L = plan.n_tumbles
    faces = np.full((len(idx), L), -1, np.int64)

    def after_lift(state, p):
        k = sched.phases[p].step
        R, _ = tb.body_pose(rec.ends[p], lay)
        faces[:, k] = [tb.face_down(R[j:j + 1], parts.normals[i:i + 1], s.face_tol)[0]
                       for j, i in enumerate(idx)]
        return tb.apply_slip(state, lay, parts, idx, k, faces[:, k])

    engine = make_engine(backend, models, s)
    try:
        final = run_schedule(engine, sched, st0, [rec], s.chunk_steps,
                             hooks={p: after_lift for p in lifts})
    finally:
        engine.close()
    slip = np.zeros((len(idx), L))
    for k, (pd, ph) in enumerate(zip(dwell, holds)):
        a, b = plan.tumbles[k].edge
        mids = []
        for p in (pd, ph):
            R, t = tb.body_pose(rec.ends[p], lay)
            mids.append(np.stack([R[j] @ (0.5 * (parts.vertices[i][a] + parts.vertices[i][b]))
                                  + t[j] for j, i in enumerate(idx)]))
        slip[:, k] = np.linalg.norm(mids[1][:, :2] - mids[0][:, :2], axis=1)
    face_f, cfg = _final_config(final, lay, parts, idx, poly, s.face_tol)
    return dict(faces=faces, slip_per_tumble=slip, final_face=face_f, cfg=cfg,
                left_workspace=rec.left, steps=sched.total, grip=grip)


def rollout_tumble_plan(plan, draws, *, backend: str = "auto",
                        settings: Optional[PhysicsSettings] = None, workspace=None,
                        criterion: Optional[SuccessCriterion] = None,
                        merge_factor: float = 8.0,
                        tau_v: Optional[float] = None) -> TumbleRollout:
    """Roll a tumble plan out in MuJoCo on sampled parts and executions.

    Args:
      plan: a :class:`planning.TumblePlan` with at least one tumble.
      draws: the ``n`` samples, ``robustness.Sampler(...).sample(key, n,
        n_vertices=m, dim=3, n_tumbles=L)``; ``mu_f`` is the upper pad's
        coefficient and ``mu_s`` the lower pad's (the device needs them well
        above 1, see :mod:`robustness.physics.tumbling`).
      backend: ``"c"``, ``"mjx"`` or ``"auto"`` (as :func:`rollout_push_plan`).
      settings: :class:`PhysicsSettings`.
      workspace: ``(xmin, xmax, ymin, ymax)`` (m); default the planned
        configurations grown by twice the part's diameter and 5 cm.
      criterion: the :class:`~robustness.SuccessCriterion` that classifies the
        samples (default: the plan's eps for both tolerances); a failed sample
        whose pivots slipped at least its ``slip_fraction`` times ``pos_eps_m``
        in all fails by ``slip``.
      merge_factor, tau_v: the combinatorics check's face-merging tolerance
        (``robustness.hulls.face_merge_tol(tau_v, diameter, merge_factor)``,
        as in the evaluation; ``tau_v`` defaults to the largest sampled
        vertex offset: pass the sampler's ``tau_v`` for the evaluation's
        exact check).

    Returns:
      a :class:`~robustness.physics.rollouts.TumbleRollout` (its fields, one row
      per sample, with their units and frames documented there).
    """
    s = settings or PhysicsSettings()
    backend = resolve_backend(backend, s)
    check_batch(draws)
    n = draws.n
    if not plan.tumbles:
        raise ValueError("plan: has no tumbles; nothing to roll out")
    t0 = time.perf_counter()
    poly = tb.nominal_polyhedron(plan)
    parts = tb.tumble_parts(plan, poly, draws, merge_factor, tau_v)
    hull = poly.vertices[list(poly.hull_vertices)]
    diam = float(np.max(np.linalg.norm(hull[:, None] - hull[None], axis=-1)))
    ws = tuple(workspace) if workspace is not None else _workspace(tb.nominal_configs(plan, poly),
                                                                     diam)
    idx = np.flatnonzero(parts.valid)
    L = plan.n_tumbles
    res = {"x": np.full(n, np.nan), "y": np.full(n, np.nan), "theta": np.full(n, np.nan),
           "face": np.full(n, -1, np.int64), "faces": np.full((n, L), -1, np.int64),
           "slip_per_tumble": np.full((n, L), np.nan), "left_workspace": np.zeros(n, bool)}
    steps, grip = 0, math.nan
    for lo in range(0, idx.size, s.batch):
        grp = idx[lo:lo + s.batch]
        out = _simulate(plan, poly, parts, grp, s, backend, ws)
        steps, grip = out["steps"], out["grip"]
        res["x"][grp], res["y"][grp], res["theta"][grp] = out["cfg"].T
        res["face"][grp] = out["final_face"]
        res["faces"][grp] = out["faces"]
        res["slip_per_tumble"][grp] = out["slip_per_tumble"]
        res["left_workspace"][grp] = out["left_workspace"]
    _classify(res, plan, parts, criterion or SuccessCriterion.for_plan(plan))
    res.update(backend=backend, steps=int(steps), seconds=time.perf_counter() - t0, grip_n=grip)
    return TumbleRollout(**res)


def _classify(res, plan, parts, criterion) -> None:
    """Flags, errors, success and failure mode (``criterion``'s classification, the
    faults in ``TUMBLE_FAILURE_MODES`` order; a success lands on the goal face,
    whatever faces it passed)."""
    sim = parts.valid.copy()
    planned = np.asarray(plan.faces, np.int64)
    goal = np.asarray(plan.goal, np.float64)
    res["planned_faces"] = planned
    wrong = res["faces"] != planned[None, :]
    res["n_wrong_faces"] = np.where(sim, wrong.sum(axis=1), -1)
    res["faces_ok"] = sim & ~wrong.any(axis=1)
    res["slip"] = np.nansum(res["slip_per_tumble"], axis=1)
    res["combinatorics_changed"] = ~parts.valid
    res["simulated"] = sim
    res["err_x"], res["err_y"] = res["x"] - goal[0], res["y"] - goal[1]
    res["err_pos"] = np.hypot(res["err_x"], res["err_y"])
    res["err_theta"] = wrap_angle_np(res["theta"] - goal[2])
    on_goal = res["face"] == int(goal[3])
    faults = (~sim, res["left_workspace"], ~on_goal | wrong.any(axis=1))
    res["success"], res["failure_mode"] = criterion.classify(
        res["err_pos"], res["err_theta"], res["slip"],
        valid=sim & on_goal & ~res["left_workspace"],
        faults=tuple(zip(TUMBLE_FAILURE_MODES[1:4], faults)))


__all__ = ["rollout_tumble_plan", "TUMBLE_FAILURE_MODES"]
