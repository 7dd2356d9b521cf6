"""The summary of a plan's Monte-Carlo samples, from the per-sample frame.

:func:`robustness.evaluation.evaluate` summarises the samples it drew; a study
or a certification that draws a task's samples in several chunks (to resume
after a crash, or to grow the sample count) summarises all of them at once
with :func:`summarise`: the same fields, the same bounds.
"""
from __future__ import annotations

import math
from typing import Optional

import jax.numpy as jnp
import numpy as np
import pandas as pd

from kernels.precision import float64
from robustness import evaluation as _ev
from robustness import stats


@float64
def summarise(samples: pd.DataFrame, plan, sampler, *, kind: str, model: str, dtype: str,
              pos_eps_m: float, theta_eps_rad: float, confidence: float = 0.95,
              task: str = "task", bound: bool = True) -> dict:
    """The ``summary`` row of a plan's samples.

    Args:
      samples: per-sample rows (the ``samples`` columns ``sample_id``,
        ``err_pos_m``, ``err_x_m``, ``err_y_m``, ``err_theta_rad``, ``slip_m``,
        ``success``, ``failure_mode``, ``in_bound_model``), any number of chunks
        concatenated.
      plan: the :class:`~planning.PushPlan` or :class:`~planning.TumblePlan`.
      sampler: the :class:`~robustness.Sampler` the samples were drawn from.
      kind, model, dtype: as in the samples; pos_eps_m (m), theta_eps_rad (rad):
        the success tolerances; confidence: of the Clopper-Pearson bounds.
      task: the task's name; bound: compute the analytic bounds.

    Returns:
      dict with the ``summary`` table's fields (``robustness.tables``), including
      ``ci_low_one_sided``: the one-sided Clopper-Pearson lower bound of the
      success probability at ``confidence`` (what a probability claim uses).
    """
    df = samples.sort_values("sample_id", kind="stable").reset_index(drop=True)
    b = None
    if bound and len(df):
        b = _ev._push_bound(plan, sampler) if kind == "push" else \
            _ev._tumble_bound(plan, sampler, _ev._tumble_nominal(plan))
    verts = np.asarray(plan.vertices, np.float64)
    scale = (float(np.max(np.linalg.norm(verts - verts.mean(axis=0), axis=1)))
             + max(float(np.hypot(*plan.start[:2])), float(np.hypot(*plan.goal[:2]))))
    steps = len(plan.pushes) if kind == "push" else plan.n_tumbles
    eps = 1e3 * float(jnp.finfo(jnp.dtype(dtype)).eps) * math.sqrt(steps + 1)
    s = _ev._summarise(df, kind, model, dtype, pos_eps_m, theta_eps_rad, confidence, b, task,
                       atol=(eps * scale, eps))
    _ev._paper_bound(s, df, plan, sampler, kind, bound and len(df) > 0, task,
                     atol=(eps * scale, eps))
    s["ci_low_one_sided"] = (stats.one_sided_lower(int(s["n_success"]), int(s["n"]), confidence)
                             if s["n"] else math.nan)
    return s


def empty_summary(task: str, kind: str, model: str, dtype: str, pos_eps_m: float,
                  theta_eps_rad: float, confidence: float, reason: str = "no_plan") -> dict:
    """The summary row of a task with no samples (no plan): ``n = 0``, NaN
    statistics, ``dominant_failure_mode`` = ``reason``."""
    return {"task": task, "kind": kind, "model": model, "dtype": dtype, "n": 0, "n_success": 0,
            "success_rate": math.nan, "confidence": confidence, "ci_low": math.nan,
            "ci_high": math.nan, "ci_low_one_sided": math.nan, "pos_eps_m": pos_eps_m,
            "theta_eps_rad": theta_eps_rad, "dominant_failure_mode": reason}


def bound_of(summary: dict) -> Optional[tuple[float, float]]:
    """``(position m, orientation rad)`` of the analytic bound in a summary, or None."""
    bp, bt = summary.get("bound_position_m", math.nan), summary.get("bound_theta_rad", math.nan)
    return (bp, bt) if math.isfinite(bp) and math.isfinite(bt) else None
