"""The summary of a plan's Monte-Carlo samples, from the per-sample frame.

:func:`robustness.evaluation.evaluate` summarises the samples it drew; a study
or a certification that draws a task's samples in several chunks (to resume
after a crash, or to grow the sample count) summarises all of them at once
with :func:`summarise`: the same fields, the same bounds.
"""
from __future__ import annotations

import math
import warnings

import jax.numpy as jnp
import numpy as np
import pandas as pd

from kernels import float64
from robustness import stats
from robustness.kinds import KINDS
from robustness.stats import CONFIDENCE
from robustness.tables import FAILURE_MODES
from robustness.tolerances import SuccessCriterion

BOUND_RTOL = 1e-9

#: The per-sample columns a summary is computed from (:func:`summarise`): what a
#: block of samples hands to its task's summary, so that the summary never reads
#: the samples back from disk.
STAT_COLUMNS = ("sample_id", "err_pos_m", "err_x_m", "err_y_m", "err_theta_rad", "slip_m",
                "success", "failure_mode", "in_bound_model", "final_x_m", "final_y_m",
                "final_theta_rad")


class BoundViolation(UserWarning):
    """A Monte-Carlo sample exceeded an analytic bound: a finding, not noise."""


@float64
def summarise(samples: pd.DataFrame, plan, sampler, *, kind: str, model: str, dtype: str,
              criterion: SuccessCriterion, confidence: float = CONFIDENCE, task: str = "task", bound: bool = True, warn_stacklevel: int = 3) -> dict:
    """The ``summary`` row of a plan's samples.

    Args:
      samples: per-sample rows (the ``samples`` columns ``sample_id``,
        ``err_pos_m``, ``err_x_m``, ``err_y_m``, ``err_theta_rad``, ``slip_m``,
        ``success``, ``failure_mode``, ``in_bound_model``), any number of chunks
        concatenated.
      plan: the :class:`~planning.PushPlan` or :class:`~planning.TumblePlan`.
      sampler: the :class:`~robustness.Sampler` the samples were drawn from.
      kind, model, dtype: as in the samples; criterion: the
        :class:`~robustness.SuccessCriterion` the samples were judged by (its
        tolerances are recorded and scale the worst sample); confidence: of the
        Clopper-Pearson bounds.
      task: the task's name; bound: compute the analytic bounds.

    Returns:
      dict with the ``summary`` table's fields (``robustness.tables``), including
      ``ci_low_one_sided``: the one-sided Clopper-Pearson lower bound of the
      success probability at ``confidence`` (what a probability claim uses).
    """
    df = samples.sort_values("sample_id", kind="stable").reset_index(drop=True)
    b = analytic_bound(plan, sampler, kind) if bound and len(df) else None
    dev_p, dev_t = deviations(df, plan, kind)
    verts = np.asarray(plan.vertices, np.float64)
    scale = (float(np.max(np.linalg.norm(verts - verts.mean(axis=0), axis=1)))
             + max(float(np.hypot(*plan.start[:2])), float(np.hypot(*plan.goal[:2]))))
    steps = plan.n_steps
    eps = 1e3 * float(jnp.finfo(jnp.dtype(dtype)).eps) * math.sqrt(steps + 1)
    s = summary_row(df, kind, model, dtype, criterion, confidence, b, task, (dev_p, dev_t),
                    atol=(eps * scale, eps), stacklevel=warn_stacklevel + 1)
    paper_bound_check(s, df, plan, sampler, kind, bound and len(df) > 0, task, (dev_p, dev_t),
                      atol=(eps * scale, eps), stacklevel=warn_stacklevel + 1)
    return s


def nominal_final(plan, kind: str) -> np.ndarray:
    """The plan's own prediction of the final pose ``(x, y, theta)`` (m, rad): the
    exact replay's pose after the last push, or the tumble plan's predicted final
    configuration (which may lie up to eps from the goal)."""
    return KINDS[kind].nominal_final(plan)


def deviations(df: pd.DataFrame, plan, kind: str) -> tuple[np.ndarray, np.ndarray]:
    """Each sample's deviation from the plan's nominal final pose: position (m)
    and |orientation| (rad).  This, not the error to the goal, is what an
    analytic bound on the propagated tolerances bounds (a tumble plan's own
    residual to the goal is up to eps and is not a propagated error)."""
    from kernels import wrap_angle_np

    f = nominal_final(plan, kind)
    dp = np.hypot(df["final_x_m"].to_numpy(np.float64) - f[0],
                  df["final_y_m"].to_numpy(np.float64) - f[1])
    dt = np.abs(wrap_angle_np(df["final_theta_rad"].to_numpy(np.float64) - f[2]))
    return dp, dt


def analytic_bound(plan, sampler, kind: str):
    """The first-order bound (:mod:`robustness.bounds`) over the box that holds
    every draw of ``sampler`` (a disc of radius tau_com lies in the box of
    half-width tau_com; Gaussians are truncated to their boxes)."""
    return KINDS[kind].bound(plan, sampler.geometry, sampler.execution)


def empty_summary(task: str, kind: str, model: str, dtype: str, criterion: SuccessCriterion,
                  confidence: float, reason: str = "no_plan") -> dict:
    """The summary row of a task with no samples (no plan): every field of the
    ``summary`` table, as :func:`summary_row` gives it for zero samples (``n = 0``,
    every count 0, ``worst_sample_id`` -1, NaN statistics, null bound findings),
    with ``dominant_failure_mode`` = ``reason``.  The same fields and types as a
    planned task's row: column types never depend on the data."""
    cols = ("sample_id", "err_pos_m", "err_x_m", "err_y_m", "err_theta_rad", "slip_m")
    df = pd.DataFrame({c: np.zeros(0, np.int64 if c == "sample_id" else np.float64) for c in cols})
    df["success"] = df["in_bound_model"] = np.zeros(0, bool)
    df["failure_mode"] = np.zeros(0, object)
    none = np.zeros(0, np.float64)
    s = summary_row(df, kind, model, dtype, criterion, confidence, None, task, (none, none))
    s["paper_bound_position_m"] = s["paper_bound_theta_rad"] = math.nan
    s["paper_bound_violated"] = None
    s["dominant_failure_mode"] = reason
    return s


def paper_bound_check(s: dict, df, plan, sampler, kind: str, bound: bool, task, dev,
                      atol=(0.0, 0.0), stacklevel: int = 3) -> None:
    """Confront the Marigo-Bicchi bounds (eqs. 5 and 6) with the Monte-Carlo
    maximum of a tumble plan's error (``paper_bound_*`` summary fields).

    The paper's bounds cover the vertex tolerance only, so the comparison is
    made when the execution errors are zero (else the fields are NaN/None);
    ``dev`` holds each sample's deviation (position m, |orientation| rad) from
    the plan's nominal final configuration (:func:`deviations`).
    ``atol`` is the rounding allowance (m, rad) of the kernels' dtype, as for
    the first-order bound.  A violation is a finding, warned as
    :class:`BoundViolation`, never clipped:
    eq. (6) raises lengths to high powers, so in metres it can collapse to an
    impossibly small number for parts smaller than a metre.
    """
    s["paper_bound_position_m"] = s["paper_bound_theta_rad"] = math.nan
    s["paper_bound_violated"] = None
    e = sampler.execution
    if not KINDS[kind].paper_bounds or not bound or e.start_xy or e.start_theta or e.tumble_slip_xy \
            or e.tumble_slip_theta:
        return
    from robustness.bounds import tumble_plan_paper_bounds

    pb = tumble_plan_paper_bounds(plan, sampler.geometry.tau_v)
    bp, bt = float(pb["Delta_C_f"]), float(pb["Delta_theta_f"])
    s["paper_bound_position_m"], s["paper_bound_theta_rad"] = bp, bt
    inm = df["in_bound_model"].to_numpy(bool)
    if not inm.any():
        return
    emp_p = float(dev[0][inm].max())
    emp_t = float(dev[1][inm].max())
    msgs = []
    if not emp_p <= bp + atol[0]:
        msgs.append(f"position {emp_p:.6g} m > Delta_C_f {bp:.6g} m (eq. 6)")
    if not emp_t <= bt + atol[1]:
        msgs.append(f"orientation {emp_t:.6g} rad > Delta_theta_f {bt:.6g} rad (eq. 5)")
    s["paper_bound_violated"] = bool(msgs)
    if msgs:
        warnings.warn(f"PAPER BOUND VIOLATED (task {task!r}, tumble plan): the Monte-Carlo "
                      f"maximum over {int(inm.sum())} samples exceeds the Marigo-Bicchi bound: "
                      f"{'; '.join(msgs)}. A finding, not clipped.", BoundViolation,
                      stacklevel=stacklevel)


def summary_row(df, kind, model, dtype_name, criterion: SuccessCriterion, confidence, b, task,
                dev, atol=(0.0, 0.0), stacklevel: int = 4) -> dict:
    """The summary fields of a per-sample frame: success with its Clopper-Pearson
    bounds, error quantiles, the worst sample, failure counts, and the analytic
    bound ``b`` beside the largest deviation ``dev`` (from the plan's nominal
    final pose) of the samples inside the bound's model (``in_bound_model``);
    an excess beyond rounding (``atol``: m, rad) is a finding, warned as
    :class:`BoundViolation` and stored as ``bound_violated``."""
    pe, te = criterion.pos_eps_m, criterion.theta_eps_rad
    n = len(df)
    k = int(df["success"].sum())
    lo, hi = stats.clopper_pearson(k, n, confidence) if n else (math.nan, math.nan)
    s = {"task": task, "kind": kind, "model": model, "dtype": dtype_name, "n": n, "n_success": k,
         "success_rate": k / n if n else math.nan, "confidence": confidence, "ci_low": lo,
         "ci_high": hi,
         # what a probability claim uses: the ONE-sided lower bound at `confidence`
         "ci_low_one_sided": stats.one_sided_lower(k, n, confidence) if n else math.nan,
         "pos_eps_m": pe, "theta_eps_rad": te}
    for stem, vals in (("err_pos_m", df["err_pos_m"]), ("err_x_abs_m", df["err_x_m"].abs()),
                       ("err_y_abs_m", df["err_y_m"].abs()),
                       ("err_theta_abs_rad", df["err_theta_rad"].abs()), ("slip_m", df["slip_m"])):
        for q, v in stats.quantiles(vals).items():
            s[f"{stem}_{q}"] = v
    score = np.maximum(df["err_pos_m"].to_numpy() / pe, np.abs(df["err_theta_rad"].to_numpy()) / te)
    score = np.where(np.isfinite(score), score, np.inf)
    w = int(np.argmax(score)) if n else -1
    s["worst_sample_id"] = int(df["sample_id"].iloc[w]) if n else -1
    s["worst_err_pos_m"] = float(df["err_pos_m"].iloc[w]) if n else math.nan
    s["worst_err_theta_abs_rad"] = float(abs(df["err_theta_rad"].iloc[w])) if n else math.nan
    inm = df["in_bound_model"].to_numpy(bool)
    s["n_in_bound_model"] = int(inm.sum())
    emp_p = float(dev[0][inm].max()) if inm.any() else math.nan
    emp_t = float(dev[1][inm].max()) if inm.any() else math.nan
    s["emp_max_pos_in_model_m"], s["emp_max_theta_in_model_rad"] = emp_p, emp_t
    if b is None:
        s["bound_position_m"] = s["bound_theta_rad"] = math.nan
        s["bound_violated"] = None
    else:
        bp, bt = float(b.position_m), float(b.theta_rad)
        s["bound_position_m"], s["bound_theta_rad"] = bp, bt
        viol = False
        msgs = []
        if inm.any():
            if not emp_p <= bp * (1 + BOUND_RTOL) + atol[0]:
                viol = True
                msgs.append(f"position {emp_p:.6g} m > bound {bp:.6g} m")
            if not emp_t <= bt * (1 + BOUND_RTOL) + atol[1]:
                viol = True
                msgs.append(f"orientation {emp_t:.6g} rad > bound {bt:.6g} rad")
        s["bound_violated"] = viol
        if viol:
            warnings.warn(f"BOUND VIOLATED (task {task!r}, {kind} plan, {model} model): the "
                          f"Monte-Carlo maximum over {int(inm.sum())} samples inside the bound's "
                          f"model exceeds the analytic first-order bound: {'; '.join(msgs)}. "
                          "This is a finding (a second-order effect or a modelling gap), "
                          "not clipped.", BoundViolation, stacklevel=stacklevel)
    counts = df["failure_mode"].value_counts()
    for mname in FAILURE_MODES:
        s[f"n_{mname}"] = int(counts.get(mname, 0))
    fails = {mname: s[f"n_{mname}"] for mname in FAILURE_MODES if mname != "none"}
    worst = max(fails.items(), key=lambda kv: kv[1]) if fails else ("none", 0)
    s["dominant_failure_mode"] = worst[0] if worst[1] > 0 else "none"
    return s
