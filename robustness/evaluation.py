"""Monte-Carlo evaluation of push and tumble plans on perturbed parts.

``evaluate(plan, sampler, n, key, criterion)`` draws ``n`` perturbations
(:mod:`robustness.samplers`), replays the plan on every one of them in
jit-compiled batches (no per-sample host work: the Python loop is over
chunks of ``chunk`` samples), and returns an :class:`Evaluation`: a
per-sample table and a summary.

Compilation: once per shape bucket, not per plan or configuration.  Plans
are padded to a length bucket (pushes: the next power of two >= 2; padding
pushes are skipped by ``lax.cond``; tumbles: >= 16, padding steps are
identities), the caller's vertex list to a power of two >= 4, the last
partial chunk to a power of two >= 8; the plan's numbers and index tables are
traced arguments and every per-sample input is broadcast to a leading sample
axis, so the compiled push batch serves every plan of every part with the
same hull size in one length bucket, at any tolerances and sample counts
(tumbles: every plan of one part, the topology being static).  The sampler
is compiled once per structure (:mod:`robustness.samplers`).  Inside a
compiled call the samples run in blocks of ``BLOCK`` (``lax.map``) so that
their intermediates stay in cache.

Push plans (:class:`planning.pushing.plan.PushPlan`)
-------------------------------------------------
Per sample: the caller's vertices and the centre of mass are offset, the
hull (in the NOMINAL order) is re-expressed about the perturbed centre of mass
and its push geometry rebuilt (:func:`kernels.polygon.polygon_geometry`); the
start pose is offset; each push direction is rotated by its fence angle error;
each distance becomes ``max(0, distance (1 + rel) + abs)``.  Then either

* ``model="quasistatic"``: :func:`kernels.quasistatic.simulate_pushes` with the
  sample's limit-surface ratio ``c`` and fence friction ``mu_f`` (incomplete
  reorientation, slip and a wrong landing edge can happen), or
* ``model="exact"``: :func:`kernels.push.replay_pushes` (the paper's model:
  no slip, the slowest rotation support friction allows).

**Reference point.**  Poses are those of the part's frame with the NOMINAL
centre of mass as reference point (as in :mod:`robustness.bounds`): the robot
places the physical part by its nominal frame, so the perturbed centre of mass
starts at ``start_xy + R(theta0) dcom`` and the reported final position is the
simulated centre of mass minus ``R(theta_f) dcom``.  With zero tolerances the
reported pose is exactly the plan's prediction.

Tumble plans (:class:`planning.tumbling.plan.TumblePlan`)
-------------------------------------------------------
Per sample: :func:`kernels.polyhedron.tumble_geometry` on the perturbed
vertices and centre of mass (``jax.vmap``), then the tumbles are replayed,
each followed by the sample's planar slip ``(dx, dy, dtheta)`` (world frame,
the part turning about its face frame's origin).  The replay is
:func:`kernels.tumble.tumble`'s, regrouped (:func:`_tumble_block`): the faces
visited do not depend on the sample, so each directed edge's planar motion is
computed once per sample and the plan multiplies them (a test checks it
against the kernel, sample by sample, to 1e-13).  The kernel always uses the
nominal face cycles; the same compiled call checks every perturbed hull
(:func:`kernels.hulls.polyhedron_hull_verdict_batch`, in float64, equal to
the host reference :func:`kernels.polyhedron.combinatorics_changed`, which
is asked only for the rare samples the JAX check leaves undecided), and a
sample whose hull has other faces is marked ``combinatorics_changed`` (never
silently counted as a success).  ``model`` does not apply (tumbling is pure
geometry): the exact replay is used and recorded.

**Reference frames.**  A configuration names the pose of a face frame, which
is defined by the vertices and the centre of mass; a perturbed part's own face
frames are shifted and turned by O(tolerance).  The robot places the physical
part by the NOMINAL frame of the start face, and the goal is a pose of the
NOMINAL frame of the goal face.  So the start configuration is converted into
the perturbed face frame's configuration, and the final configuration back
into the nominal frame of the face on the plane.  A centre-of-mass offset
therefore moves nothing (tumbling about edges does not depend on it).

Success, failure modes
----------------------
The :class:`~robustness.SuccessCriterion` judges every model's rows (its
:meth:`~robustness.SuccessCriterion.classify`, each model naming its own faults
in order).  A sample succeeds when its kernel model is valid (no hull /
combinatorics change) and its final pose is within ``pos_eps_m`` (Euclidean, m)
AND ``theta_eps_rad`` (|wrapped difference|) of the goal, and (tumbles) the goal
face is on the plane.  A failed sample gets the first failure mode that
applies, in this order: ``hull_changed`` (polygon no longer convex in the
nominal order, or its centre of mass outside) / ``combinatorics_changed``
(polyhedron); ``incomplete_reorientation`` (a push ended before an edge lay
flush); ``wrong_edge`` (a push ended flush on another edge than planned);
``wrong_face`` (tumbles: an invalid tumble or another face on the plane at the
end); ``slip`` (slip distance at least ``slip_fraction`` x ``pos_eps_m``; for
tumbles the summed execution slip); ``position`` (above ``pos_eps_m``, or not a
number); ``orientation``.  Success
has ``failure_mode = "none"``.

A push still moving at the quasi-static kernel's phase cap (never seen) is
warned about and counted as ``incomplete_reorientation``, outside the model.

Summary: success rate with its two-sided Clopper-Pearson interval
(``ci_low``, ``ci_high``) and the ONE-sided lower bound at the same
confidence (``ci_low_one_sided``: what a probability claim uses), quantiles of the
errors, the worst sample (largest ``max(err_pos / pos_eps, |err_theta| /
theta_eps)``), failure counts, and the analytic bound of
:mod:`robustness.bounds` beside the empirical maximum over the samples that
satisfy the bound's assumptions (``in_bound_model``: valid model, every push
complete on its planned edge, no slip at the fence; tumbles: valid tumbles on
the planned faces, combinatorics unchanged; the tumble bound covers the vertex
tolerance, the start error and the slips, see :func:`robustness.bounds.tumble_plan_bound`).  An
empirical maximum above the bound is ``bound_violated``: a FINDING, warned
loudly (:class:`BoundViolation`) and stored, never clipped.  The comparison allows only rounding: a relative
1e-9 and an absolute ``1e3 eps sqrt(steps + 1)`` (times the plan's length scale
for positions), ``eps`` the kernels' dtype's machine epsilon.
"""
from __future__ import annotations

import dataclasses
import functools
import warnings
from typing import Optional

import jax.numpy as jnp
import numpy as np
import pandas as pd

from kernels import polygon as pg, wrap_angle_np, float64
from robustness.compiled import release_executables
from robustness.hulls import face_merge_tol
from robustness.models import MODELS, model_for, plan_kind
from robustness.replay import edge_pairs, push_nominal, run_push, run_tumble, tumble_nominal
from robustness.samplers import Sampler, parameter_columns, parameter_lists
from robustness.sensorless import draw_starts, is_sensorless, sensorless_rows
from robustness.stats import CONFIDENCE
from robustness.summary import summarise
from robustness.summary import BoundViolation
from robustness.tolerances import SuccessCriterion


@dataclasses.dataclass(frozen=True, eq=False)
class Evaluation:
    """Result of :func:`evaluate`.

    Attributes:
      columns: the per-sample columns (``results/README.md``, table
        ``samples``; parameter columns in ``param_columns``) as ``{name: (n,)
        array}`` (a constant column, ``task``..., as one scalar): what a writer
        builds its table from (:func:`robustness.tables.samples_columns`).
      summary: dict, the ``summary`` table's row (None when not asked for).
      param_columns: names of the sampled-parameter columns of ``samples``.
      kind: ``"push"`` or ``"tumble"``; model: the model used.
      lists: the per-vertex and per-push draws as ``(n, k)`` arrays, one per
        list column of the ``samples`` table
        (:func:`robustness.samplers.parameter_lists`).
      samples: ``columns`` as a pandas frame, one row per sample (built when
        first read).
    """

    columns: dict
    summary: dict
    param_columns: tuple
    kind: str
    model: str
    lists: dict = dataclasses.field(default_factory=dict)

    @functools.cached_property
    def samples(self) -> pd.DataFrame:
        return pd.DataFrame(self.columns)

    @property
    def n(self) -> int:
        """The number of samples."""
        return len(self.columns["sample_id"])


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


# --------------------------------------------------------------------------
# Public API
# --------------------------------------------------------------------------
def _warn_truncated(r, task) -> None:
    """A push still moving at the kernel's phase cap is reported, never silently kept."""
    k = int(np.sum(np.asarray(r.truncated)))
    if k:
        warnings.warn(f"task {task!r}: {k} sample(s) had a push still moving at the quasi-static "
                      "kernel's phase cap (kernels.quasistatic.phase_cap); they are counted as "
                      "incomplete_reorientation failures, outside the kernel's model",
                      RuntimeWarning, stacklevel=4)


@float64
def evaluate(plan, sampler: Sampler, n: int, key, criterion: Optional[SuccessCriterion] = None,
             model: str = "quasistatic", dtype=jnp.float64, *, confidence: float = CONFIDENCE,
             chunk: int = 4096, task: str = "task", bound: bool = True,
             merge_factor: float = 8.0, physics=None, summary: bool = True) -> Evaluation:
    """Evaluate a plan on ``n`` perturbed samples.

    Args:
      plan: a :class:`~planning.pushing.plan.PushPlan`, a
        :class:`~planning.SensorlessPlan` (its starts drawn over its region and
        heading interval, :mod:`robustness.sensorless`; no analytic bound, no
        MuJoCo) or a :class:`~planning.tumbling.plan.TumblePlan`.
      sampler: the :class:`~robustness.samplers.Sampler` (tolerances).
      n: number of samples (>= 1).
      key: a ``jax.random`` key.
      criterion: the :class:`~robustness.SuccessCriterion` that judges each
        sample (default :meth:`SuccessCriterion.for_plan`: the tumble plan's eps
        for both tolerances; 1 mm and 1 degree for push plans).
      model: ``"quasistatic"`` or ``"exact"`` (push plans; tumbles are exact),
        or ``"mujoco"``: the plan rolled out in MuJoCo (:mod:`robustness.physics`;
        push and tumble plans; slow: seconds of CPU per sample).
      dtype: float dtype of the kernels (``jnp.float64`` or ``jnp.float32``); the
        perturbations are drawn in float64 and cast, so both dtypes see the same
        samples (compare them row by row).  MuJoCo: float64 on the C engine,
        float32 under MJX, whatever ``dtype``.
      confidence: of the Clopper-Pearson interval.
      chunk: samples per compiled call (bounds memory; the last, partial
        chunk is padded to a power of two, so sample counts share compilations).
      task: the task name written in the tables.
      bound: compute the analytic bound (set False to skip it).
      merge_factor: polyhedra: face-merging tolerance factor for the
        combinatorics check (:func:`robustness.samplers.face_merge_tol`).
      physics: ``model="mujoco"`` only: a :class:`robustness.physics.PhysicsRun`
        (backend, stroke, cell settings); default ``PhysicsRun()``.
      summary: summarise the samples (``Evaluation.summary``); False for a
        caller that summarises several evaluations together (a task's blocks:
        :func:`robustness.summarise`), then ``summary`` is None.

    Returns:
      :class:`Evaluation`.
    """
    kind = plan_kind(plan)
    if model not in MODELS:
        raise ValueError(f"model: expected one of {MODELS}, got {model!r}")
    if not (isinstance(n, (int, np.integer)) and n >= 1):
        raise ValueError(f"n: expected an integer >= 1, got {n!r}")
    dtype = jnp.dtype(dtype)
    model = model_for(model, kind)
    crit = SuccessCriterion.for_plan(plan) if criterion is None else criterion
    if not isinstance(crit, SuccessCriterion):
        raise TypeError(f"criterion: expected a robustness.SuccessCriterion, got {crit!r}")
    chunk = max(1, int(chunk))
    release_executables()   # a long run of many plan shapes stays under the map limit
    m = len(plan.vertices)
    if kind == "push":
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", pg.PartWarning)
            poly0 = pg.make_polygon(np.asarray(plan.vertices), np.asarray(plan.com))
        shape = dict(n_vertices=m, dim=2, n_pushes=len(plan.pushes))
        draws = sampler.sample(key, n, body=poly0.body, dtype=jnp.float64,
                               keep_support=model in ("mujoco", "limit_surface"), **shape)
    else:
        shape = dict(n_vertices=m, dim=3, n_tumbles=plan.n_tumbles)
        # the replay and the columns read the plan's tumbles of the drawn ones (no copy)
        draws = sampler.sample(key, n, dtype=jnp.float64, exact_steps=model == "mujoco", **shape)
    sensorless = kind == "push" and is_sensorless(plan)
    if sensorless and model == "mujoco":
        raise ValueError("model: mujoco does not roll out sensorless plans here (bench/"
                         "sensorless.py does); use quasistatic, limit_surface or exact")
    if model == "mujoco":
        from robustness.physics.settings import check_pad_friction

        if kind == "tumble":
            from robustness.physics.tumbling import nominal_polyhedron

            grip = (physics.settings.grip_ratio if physics is not None else 2.0)
            check_pad_friction(sampler.friction, kind, nominal_polyhedron(plan), grip)
        rows, dtype = _physics_rows(plan, kind, draws, sampler, crit, merge_factor, physics)
    elif sensorless:   # the start drawn over the plan's start set (robustness.sensorless)
        starts = draw_starts(plan, key, n)
        rows = sensorless_rows(plan, draws, starts, crit, model, dtype, chunk)
    elif kind == "push":
        rows = _push_rows(plan, draws, crit, model, dtype, chunk, task)
    else:
        rows = _tumble_rows(plan, draws, crit, dtype, chunk, sampler, merge_factor)
    cast = draws.astype(dtype)   # a float32 evaluation sees the float64 one's samples
    cols = parameter_columns(cast, **shape)
    if sensorless:   # the drawn start replaces the start error: its offset from plan.start
        off = np.asarray(starts - np.asarray(plan.start)[None, :], dtype)
        cols["start_dx_m"], cols["start_dy_m"], cols["start_dtheta_rad"] = off.T.astype(np.float64)
    lists = parameter_lists(cast, **shape)
    data = _columns(rows, cols, plan, kind, model, dtype, task)
    if model == "mujoco":
        _compare_with_kinematics(data, plan, kind, draws, crit, chunk, task, sampler, merge_factor)
    ev = Evaluation(columns=data, summary=None, param_columns=tuple(cols), kind=kind,
                    model=model, lists=lists)
    if summary:
        s = summarise(ev.samples, plan, sampler, kind=kind, model=model, dtype=dtype.name,
                      criterion=crit, confidence=confidence, task=task,
                      bound=bound and model != "mujoco", warn_stacklevel=5)
        frame = ev.samples
        ev = dataclasses.replace(ev, summary=s)
        ev.__dict__["samples"] = frame   # built once (the cached property's slot)
    return ev


def _push_rows(plan, draws, criterion, model, dtype, chunk, task) -> SampleOutcomes:
    """Per-sample outcomes of a push plan under the quasi-static or exact kernel,
    classified by ``criterion`` (faults: ``hull_changed``,
    ``incomplete_reorientation``, ``wrong_edge``; a success whose intermediate push
    was incomplete or landed another edge stays a success, its flags visible in
    its columns)."""
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


def _tumble_rows(plan, draws, criterion, dtype, chunk, sampler, merge_factor) -> SampleOutcomes:
    """Per-sample outcomes of a tumble plan under the exact tumble kinematics,
    classified by ``criterion`` (faults: ``combinatorics_changed``, ``wrong_face``:
    an invalid tumble or another face on the plane at the end, which rules a
    success out)."""
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


def _physics_rows(plan, kind, draws, sampler, criterion, merge_factor, physics) -> tuple:
    """Per-sample outcomes of a plan rolled out in MuJoCo (:mod:`robustness.physics`):
    the physics layer classifies every sample by ``criterion`` itself (tipping,
    toppling, a fence strike, leaving the workspace come on top of the kernels'
    failure modes);
    no sample is inside an analytic bound's model (physics always slips a
    little), so the bound columns stay empty.  Returns ``(SampleOutcomes, dtype)``
    (float32 under MJX)."""
    from robustness.physics import PhysicsRun, rollout_push_plan, rollout_tumble_plan

    run = physics or PhysicsRun()
    if not isinstance(run, PhysicsRun):
        raise ValueError(f"physics: expected a robustness.physics.PhysicsRun, got {run!r}")
    common = dict(backend=run.backend, settings=run.settings, criterion=criterion)
    n = draws.n
    none = np.full(n, -1, np.int64)
    if kind == "push":
        r = rollout_push_plan(plan, draws, stroke=run.stroke, **common)
        poly, planned = push_nominal(plan)
        edges = np.asarray(r["edges"])
        complete = np.asarray(r["complete"], bool)
        wrong = complete & (edges != np.asarray(planned, np.int64)[None, :])
        fa, fb = edge_pairs(poly, edges[:, -1])
        pa, pb = edge_pairs(poly, np.full(n, planned[-1]))
        extra = dict(final_edge_a=fa, final_edge_b=fb, planned_edge_a=pa, planned_edge_b=pb,
                     final_face=none, planned_face=none, n_incomplete=(~complete).sum(axis=1),
                     first_wrong_step=np.where(wrong.any(axis=1), np.argmax(wrong, axis=1), -1),
                     hull_changed=np.asarray(r["hull_changed"], bool),
                     c_physical_m=np.asarray(r["c_physical"], np.float64),
                     support_ok=np.asarray(r["support_ok"], bool))
    else:
        r = rollout_tumble_plan(plan, draws, merge_factor=merge_factor,
                                tau_v=sampler.geometry.tau_v, **common)
        extra = dict(final_edge_a=none, final_edge_b=none, planned_edge_a=none,
                     planned_edge_b=none, final_face=np.asarray(r["face"], np.int64),
                     planned_face=np.full(n, int(plan.goal[3]), np.int64),
                     n_incomplete=np.asarray(r["n_wrong_faces"], np.int64), first_wrong_step=none,
                     hull_changed=np.asarray(r["combinatorics_changed"], bool))
    out = SampleOutcomes(
        x=r["x"], y=r["y"], theta=r["theta"], slip=np.asarray(r["slip"], np.float64),
        model_valid=np.asarray(r["simulated"], bool), in_bound_model=np.zeros(n, bool),
        success=np.asarray(r["success"], bool), failure_mode=np.asarray(r["failure_mode"]),
        max_tilt_rad=np.asarray(r.get("max_tilt", np.full(n, np.nan)), np.float64), **extra)
    return out, jnp.dtype(jnp.float32 if r["backend"] == "mjx" else jnp.float64)


def _compare_with_kinematics(data, plan, kind, draws, criterion, chunk, task, sampler,
                             merge_factor) -> None:
    """Physics rows get the kinematic models' answers on the same draws beside them
    (float64, into the columns ``data``): ``dpos_vs_<model>_m`` (m) and
    ``dtheta_vs_<model>_rad`` (rad, wrapped), the physics final pose minus the
    model's, and ``success_<model>``; push rows against ``quasistatic`` and
    ``exact``, tumble rows against ``exact``."""
    f64 = jnp.dtype(jnp.float64)
    for ref in ("quasistatic", "exact") if kind == "push" else ("exact",):
        if kind == "push":
            rr = _push_rows(plan, draws, criterion, ref, f64, chunk, task)
        else:
            rr = _tumble_rows(plan, draws, criterion, f64, chunk, sampler, merge_factor)
        other = _columns(rr, {}, plan, kind, ref, f64, task)
        data[f"dpos_vs_{ref}_m"] = np.hypot(data["final_x_m"] - other["final_x_m"],
                                            data["final_y_m"] - other["final_y_m"])
        data[f"dtheta_vs_{ref}_rad"] = wrap_angle_np(data["final_theta_rad"]
                                                     - other["final_theta_rad"])
        data[f"success_{ref}"] = pd.array(other["success"], dtype="boolean")


def goal_errors(x, y, theta, goal) -> tuple:
    """Final-pose errors against a plan's goal ``(x, y, theta[, face])``:
    ``(theta wrapped, err_x, err_y, err_pos, err_theta wrapped)`` (m, rad; world
    frame), numpy float64 of the shape of ``x``."""
    g = np.asarray(goal[:3], np.float64)
    th = wrap_angle_np(np.asarray(theta, np.float64))
    ex, ey = np.asarray(x, np.float64) - g[0], np.asarray(y, np.float64) - g[1]
    return th, ex, ey, np.hypot(ex, ey), wrap_angle_np(th - g[2])


def _columns(rows: SampleOutcomes, cols: dict, plan, kind, model, dtype, task) -> dict:
    """The per-sample columns (``samples``, ``{name: (n,) array}``; ``task``,
    ``kind``, ``model``, ``dtype`` as scalars) from a model's classified
    outcomes and the errors to the goal."""
    n = len(rows.x)
    x = np.asarray(rows.x, np.float64)
    y = np.asarray(rows.y, np.float64)
    th, ex, ey, ep, et = goal_errors(x, y, rows.theta, plan.goal)
    slip = rows.slip
    success, mode = rows.success, rows.failure_mode
    data = {"task": task, "kind": kind, "model": model, "dtype": dtype.name,
            "sample_id": np.arange(n, dtype=np.int64), **{k: np.asarray(v) for k, v in cols.items()},
            "final_x_m": x, "final_y_m": y, "final_theta_rad": th}
    for c in ("final_edge_a", "final_edge_b", "planned_edge_a", "planned_edge_b", "final_face",
              "planned_face"):
        data[c] = np.asarray(getattr(rows, c), np.int64)
    data.update({
        "err_x_m": ex, "err_y_m": ey, "err_pos_m": ep, "err_theta_rad": et, "slip_m": slip,
        "n_incomplete": np.asarray(rows.n_incomplete, np.int64),
        "first_wrong_step": np.asarray(rows.first_wrong_step, np.int64),
        "hull_changed": np.asarray(rows.hull_changed, bool),
        "model_valid": np.asarray(rows.model_valid, bool),
        "in_bound_model": np.asarray(rows.in_bound_model, bool),
        "success": np.asarray(success, bool), "failure_mode": mode,
        "max_tilt_rad": np.asarray(np.full(n, np.nan) if rows.max_tilt_rad is None
                                   else rows.max_tilt_rad, np.float64),
        "c_physical_m": np.asarray(np.full(n, np.nan) if rows.c_physical_m is None
                                   else rows.c_physical_m, np.float64),
        "support_ok": pd.array([pd.NA] * n if rows.support_ok is None else
                               np.where(rows.model_valid, rows.support_ok, None).tolist(),
                               dtype="boolean"),
    })
    for ref in ("quasistatic", "exact"):   # filled for physics rows (_compare_with_kinematics)
        data.update({f"dpos_vs_{ref}_m": np.full(n, np.nan), f"dtheta_vs_{ref}_rad": np.full(n, np.nan),
                     f"success_{ref}": pd.array([pd.NA] * n, dtype="boolean")})
    return data


__all__ = ["evaluate", "Evaluation", "BoundViolation", "MODELS"]
