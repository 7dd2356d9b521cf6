"""The records of a plan rolled out in MuJoCo: :class:`PushRollout` (what
:func:`robustness.physics.rollout_push_plan` returns) and :class:`TumbleRollout`
(:func:`robustness.physics.rollout_tumble_plan`), each a :class:`RolloutVerdict`
(the samples judged against the goal) with its kind's own fields.

Frozen dataclasses of numpy arrays, one row per sample (``n``) unless a field
says otherwise; ``P`` is the plan's number of pushes, ``L`` its number of
tumbles.  Frames: world, z up; planar poses in the support plane (``theta``
CCW about world z).  A changed copy: ``dataclasses.replace``; the fields'
names: ``dataclasses.fields``.
"""
from __future__ import annotations

import dataclasses

import numpy as np


@dataclasses.dataclass(frozen=True)
class RolloutVerdict:
    """How a rollout's samples end against the goal, as the plan's
    :class:`~robustness.SuccessCriterion` judges them, and what ran; the first
    fields of :class:`PushRollout` and :class:`TumbleRollout`.

    Attributes:
      err_x, err_y, err_pos: (n,) float64: the final position minus the goal's,
        and its norm (m; world).
      err_theta: (n,) float64: the final heading minus the goal's, wrapped (rad).
      success: (n,) bool: within the criterion's tolerances of the goal (a
        tumble: on the goal face).
      failure_mode: (n,) str: one of ``PUSH_FAILURE_MODES`` /
        ``TUMBLE_FAILURE_MODES`` (``"none"`` for a success).
      backend: ``"c"`` or ``"mjx"``: the engine that ran.
      steps: physics steps per sample.
      seconds: the rollout's wall time (s).
    """

    err_x: np.ndarray
    err_y: np.ndarray
    err_pos: np.ndarray
    err_theta: np.ndarray
    success: np.ndarray
    failure_mode: np.ndarray
    backend: str
    steps: int
    seconds: float


@dataclasses.dataclass(frozen=True)
class PushRollout(RolloutVerdict):
    """A push plan rolled out in MuJoCo on ``n`` sampled parts and executions.

    Samples not simulated (hull changed) hold NaN / -1 / False.

    Attributes (after :class:`RolloutVerdict`'s):
      x, y, theta: (n,) float64: the final pose of the nominal reference point
        (the simulated centre of mass minus ``R(theta) dcom``) (m, m, rad; world).
      pose_after: (n, P, 3) float64: that pose after each push's dwell (m, m,
        rad; world).
      edges: (n, P) int64: the hull edge flush on the fence at the end of each
        push (-1: none; hull order of :func:`kernels.polygon.make_polygon`).
      complete: (n, P) bool: push ``k`` ended with an edge flush (``edges >= 0``).
      planned_edges: (P,) int64: the edge each push of the plan ends flush on
        (same hull order).
      slip: (n,) float64: the slip along the fence summed over the pushes (m).
      slip_per_push: (n, P) float64: the slip along the fence during each push
        (m; :class:`robustness.physics.pushing.PushTracker`).
      contact: (n, P) bool: the fence touched the part during push ``k``.
      max_tilt: (n,) float64: the largest tilt over the run, the angle between
        the body's z axis and world z (rad).
      final_tilt: (n,) float64: that tilt at the end (rad).
      tipped: (n,) bool: ``max_tilt`` above the settings' ``tip_angle``.
      toppled: (n,) bool: ``final_tilt`` above the settings' ``topple_angle``.
      fence_strike: (n,) bool: the fence touched the part while coming down or
        moving lifted.
      left_workspace: (n,) bool: the part left the workspace
        (``(xmin, xmax, ymin, ymax)``, m, world).
      hull_changed: (n,) bool: the perturbed hull lost or gained a vertex (not
        simulated).
      simulated: (n,) bool: the sample was rolled out (``~hull_changed``).
      support_ok: (n,) bool: the centre of mass stands inside the loaded
        support contacts after settling.
      support: (n,) object (str): the support family's name
        (:data:`kernels.FAMILIES`).
      c: (n,) float64: the sampled limit-surface ratio (m).
      c_support: (n,) float64: the one the family's loads give on the
        perturbed part (m).
      c_physical: (n,) float64: the one MuJoCo's support loads realise after
        settling (m).
    """

    x: np.ndarray
    y: np.ndarray
    theta: np.ndarray
    pose_after: np.ndarray
    edges: np.ndarray
    complete: np.ndarray
    planned_edges: np.ndarray
    slip: np.ndarray
    slip_per_push: np.ndarray
    contact: np.ndarray
    max_tilt: np.ndarray
    final_tilt: np.ndarray
    tipped: np.ndarray
    toppled: np.ndarray
    fence_strike: np.ndarray
    left_workspace: np.ndarray
    hull_changed: np.ndarray
    simulated: np.ndarray
    support_ok: np.ndarray
    support: np.ndarray
    c: np.ndarray
    c_support: np.ndarray
    c_physical: np.ndarray


@dataclasses.dataclass(frozen=True)
class TumbleRollout(RolloutVerdict):
    """A tumble plan rolled out in MuJoCo on ``n`` sampled parts and executions.

    Samples not simulated (combinatorics changed) hold NaN / -1 / False.

    Attributes (after :class:`RolloutVerdict`'s):
      x, y, theta: (n,) float64: the final configuration of the nominal frame
        of the face on the support (m, m, rad; world).
      face: (n,) int64: that face (-1: none flat).
      faces: (n, L) int64: the face on the support after each tumble (-1: none).
      planned_faces: (L,) int64: the faces the plan lands.
      faces_ok: (n,) bool: every tumble landed its planned face.
      n_wrong_faces: (n,) int64: the tumbles that landed another face (-1: not
        simulated).
      slip: (n,) float64: ``slip_per_tumble`` summed (m).
      slip_per_tumble: (n, L) float64: the horizontal displacement of the
        tumble edge's midpoint during each roll (m; the paper's tumble keeps it
        fixed).
      left_workspace: (n,) bool: the part left the workspace or slipped off
        the jaw.
      combinatorics_changed: (n,) bool: the perturbed hull's faces are not
        the nominal part's (not simulated).
      simulated: (n,) bool: the sample was rolled out.
      grip_n: the grasp force (N; NaN when no sample was simulated).
    """

    x: np.ndarray
    y: np.ndarray
    theta: np.ndarray
    face: np.ndarray
    faces: np.ndarray
    planned_faces: np.ndarray
    faces_ok: np.ndarray
    n_wrong_faces: np.ndarray
    slip: np.ndarray
    slip_per_tumble: np.ndarray
    left_workspace: np.ndarray
    combinatorics_changed: np.ndarray
    simulated: np.ndarray
    grip_n: float


__all__ = ["PushRollout", "TumbleRollout"]
