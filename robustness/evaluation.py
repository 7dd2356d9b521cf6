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
from typing import Optional

import jax.numpy as jnp
import numpy as np
import pandas as pd

from kernels import wrap_angle_np, float64
from robustness.compiled import release_executables
from robustness.kinds import kind_of
from robustness.models import MODELS, Model
from robustness.outcomes import SampleOutcomes, goal_errors  # noqa: F401  (goal_errors: read here by others)
from robustness.samplers import Sampler, parameter_columns, parameter_lists
from robustness.sensorless import draw_starts, is_sensorless
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
      param_columns: names of the sampled-parameter columns of ``samples``.
      kind: ``"push"`` or ``"tumble"``; model: the model used (its name).
      lists: the per-vertex and per-push draws as ``(n, k)`` arrays, one per
        list column of the ``samples`` table
        (:func:`robustness.samplers.parameter_lists`).
      samples: ``columns`` as a pandas frame, one row per sample (built when
        first read).
      summary: the ``summary`` table's row at the default confidence (built
        when first read, :meth:`summarise`; an empirical maximum above the
        analytic bound warns then, :class:`BoundViolation`).
    """

    columns: dict
    param_columns: tuple
    kind: str
    model: str
    lists: dict = dataclasses.field(default_factory=dict)
    #: what the summary needs: (plan, sampler, criterion, dtype name, task, bound)
    _of: tuple = dataclasses.field(default=(), repr=False)

    @functools.cached_property
    def samples(self) -> pd.DataFrame:
        return pd.DataFrame(self.columns)

    @functools.cached_property
    def summary(self) -> dict:
        return self.summarise(warn_stacklevel=6)

    def summarise(self, confidence: float = CONFIDENCE, warn_stacklevel: int = 4) -> dict:
        """The ``summary`` table's row of these samples, its Clopper-Pearson
        bounds at ``confidence`` (:func:`robustness.summarise`)."""
        plan, sampler, criterion, dtype, task, bound = self._of
        return summarise(self.samples, plan, sampler, kind=self.kind, model=self.model,
                         dtype=dtype, criterion=criterion, confidence=confidence, task=task,
                         bound=bound and self.model != "mujoco", warn_stacklevel=warn_stacklevel)

    @property
    def n(self) -> int:
        """The number of samples."""
        return len(self.columns["sample_id"])


# --------------------------------------------------------------------------
# Public API
# --------------------------------------------------------------------------
@float64
def evaluate(plan, sampler: Sampler, n: int, key, criterion: Optional[SuccessCriterion] = None,
             model="quasistatic", *, task: str = "task", bound: bool = True) -> Evaluation:
    """Evaluate a plan on ``n`` perturbed samples.

    Args:
      plan: a :class:`~planning.pushing.plan.PushPlan`, a
        :class:`~planning.SensorlessPlan` (its starts drawn over its region and
        heading interval, :mod:`robustness.sensorless`; no analytic bound) or a
        :class:`~planning.tumbling.plan.TumblePlan`.
      sampler: the :class:`~robustness.samplers.Sampler` (tolerances).
      n: number of samples (>= 1).
      key: a ``jax.random`` key.
      criterion: the :class:`~robustness.SuccessCriterion` that judges each
        sample (default :meth:`SuccessCriterion.for_plan`: the tumble plan's eps
        for both tolerances; 1 mm and 1 degree for push plans).
      model: a :class:`~robustness.Model` (the model's name, the kernels' dtype,
        MuJoCo's settings, the chunk size) or a model's name: ``"quasistatic"``,
        ``"limit_surface"`` or ``"exact"`` (push plans; tumbles are exact), or
        ``"mujoco"``: the plan rolled out in MuJoCo (:mod:`robustness.physics`;
        push and tumble plans; slow: seconds of CPU per sample).  A float32
        evaluation sees the float64 one's samples (compare them row by row).
      task: the task name written in the tables.
      bound: the summary holds the analytic bound (False: skip it).

    Returns:
      :class:`Evaluation` (its ``summary`` built when first read).
    """
    ops = kind_of(plan)   # the plan's row of the dispatch table (robustness.kinds)
    kind = ops.kind
    spec = Model.of(model)
    if spec.name == "mujoco" and spec.name not in ops.models:
        ops.physics_rows(plan)   # says why this kind is not rolled out
    if not (isinstance(n, (int, np.integer)) and n >= 1):
        raise ValueError(f"n: expected an integer >= 1, got {n!r}")
    spec = spec.for_kind(kind)
    model, dtype, chunk, merge_factor = spec.name, spec.dtype, spec.chunk, spec.merge_factor
    crit = SuccessCriterion.for_plan(plan) if criterion is None else criterion
    if not isinstance(crit, SuccessCriterion):
        raise TypeError(f"criterion: expected a robustness.SuccessCriterion, got {crit!r}")
    release_executables()   # a long run of many plan shapes stays under the map limit
    shape = plan.draw_shape()
    draws = ops.draw(plan, sampler, key, n, model)
    if model == "mujoco":
        rows, dtype = _physics_rows(plan, ops, draws, sampler, crit, merge_factor, spec.physics,
                                    key)
    else:
        rows = ops.rows(plan, draws, crit, model=model, dtype=dtype, chunk=chunk, task=task,
                        sampler=sampler, merge_factor=merge_factor, key=key)
    cast = draws.astype(dtype)   # a float32 evaluation sees the float64 one's samples
    cols = parameter_columns(cast, **shape)
    if is_sensorless(plan):   # the drawn start replaces the start error: its offset from plan.start
        off = np.asarray(draw_starts(plan, key, n) - np.asarray(plan.start)[None, :], dtype)
        cols["start_dx_m"], cols["start_dy_m"], cols["start_dtheta_rad"] = off.T.astype(np.float64)
    lists = parameter_lists(cast, **shape)
    data = _columns(rows, cols, plan, kind, model, dtype, task)
    if model == "mujoco":
        _compare_with_kinematics(data, plan, ops, draws, crit, chunk, task, sampler, merge_factor,
                                 key)
    return Evaluation(columns=data, param_columns=tuple(cols), kind=kind, model=model,
                      lists=lists, _of=(plan, sampler, crit, dtype.name, task, bool(bound)))


def _physics_rows(plan, ops, draws, sampler, criterion, merge_factor, physics, key) -> tuple:
    """Per-sample outcomes of a plan rolled out in MuJoCo (:mod:`robustness.physics`;
    the kind's half: ``ops.physics_rows`` of the dispatch table):
    the physics layer classifies every sample by ``criterion`` itself (tipping,
    toppling, a fence strike, leaving the workspace come on top of the kernels'
    failure modes);
    no sample is inside an analytic bound's model (physics always slips a
    little), so the bound columns stay empty.  Returns ``(SampleOutcomes, dtype)``
    (float32 under MJX)."""
    from robustness.physics import PhysicsRun

    run = physics or PhysicsRun()
    if not isinstance(run, PhysicsRun):
        raise ValueError(f"physics: expected a robustness.physics.PhysicsRun, got {run!r}")
    common = dict(backend=run.backend, settings=run.settings, criterion=criterion)
    n = draws.n
    r, extra = ops.physics_rows(plan, draws, sampler, criterion, merge_factor, run, common,
                                key=key)
    out = SampleOutcomes(
        x=r.x, y=r.y, theta=r.theta, slip=np.asarray(r.slip, np.float64),
        model_valid=np.asarray(r.simulated, bool), in_bound_model=np.zeros(n, bool),
        success=np.asarray(r.success, bool), failure_mode=np.asarray(r.failure_mode), **extra)
    return out, jnp.dtype(jnp.float32 if r.backend == "mjx" else jnp.float64)


def _compare_with_kinematics(data, plan, ops, draws, criterion, chunk, task, sampler,
                             merge_factor, key) -> None:
    """Physics rows get the kinematic models' answers on the same draws beside them
    (float64, into the columns ``data``): ``dpos_vs_<model>_m`` (m) and
    ``dtheta_vs_<model>_rad`` (rad, wrapped), the physics final pose minus the
    model's, and ``success_<model>``, for each of the kind's ``references`` (push
    rows against ``quasistatic`` and ``exact``, tumble rows against ``exact``)."""
    f64 = jnp.dtype(jnp.float64)
    kind = ops.kind
    for ref in ops.references:
        rr = ops.rows(plan, draws, criterion, model=ref, dtype=f64, chunk=chunk, task=task,
                      sampler=sampler, merge_factor=merge_factor, key=key)
        other = _columns(rr, {}, plan, kind, ref, f64, task)
        data[f"dpos_vs_{ref}_m"] = np.hypot(data["final_x_m"] - other["final_x_m"],
                                            data["final_y_m"] - other["final_y_m"])
        data[f"dtheta_vs_{ref}_rad"] = wrap_angle_np(data["final_theta_rad"]
                                                     - other["final_theta_rad"])
        data[f"success_{ref}"] = pd.array(other["success"], dtype="boolean")


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
