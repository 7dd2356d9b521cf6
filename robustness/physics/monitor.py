"""Reading outcomes off simulated trajectories (host side, numpy).

The engines return, chunk by chunk, every step's state (``[time, qpos, qvel,
act]``) and sensor data for every sample; the monitors here reduce them to
per-sample outcomes as the chunks arrive, so no trajectory is kept.

Frames: world z up; the part's free joint gives its body frame's origin and
orientation (quaternion ``w, x, y, z``).  Planar quantities are taken in the
support plane (yaw about world z; the tilt is the angle between the body's z
axis and world z).
"""
from __future__ import annotations

import numpy as np

from kernels import wrap_angle_np


def quat_to_mat(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of unit quaternions (..., 4) ``w, x, y, z``."""
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], -2)


def mat_to_quat(R: np.ndarray) -> np.ndarray:
    """Unit quaternions (n, 4) ``w, x, y, z`` of rotation matrices (n, 3, 3)."""
    import mujoco

    out = np.empty(R.shape[:-2] + (4,))
    flat_R = R.reshape(-1, 9)
    flat_q = out.reshape(-1, 4)
    for i in range(len(flat_R)):
        mujoco.mju_mat2Quat(flat_q[i], np.ascontiguousarray(flat_R[i]))
    return out


def yaw_tilt(q: np.ndarray):
    """Yaw (rad, CCW about world z, of the body x axis) and tilt (rad, body z
    from world z) of quaternions (..., 4)."""
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = np.moveaxis(q, -1, 0)
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    tilt = np.arccos(np.clip(1 - 2 * (x * x + y * y), -1.0, 1.0))
    return yaw, tilt


def yaw_quat(theta: np.ndarray) -> np.ndarray:
    """Quaternions (n, 4) of rotations by ``theta`` about world z."""
    th = np.asarray(theta, np.float64)
    return np.stack([np.cos(th / 2), np.zeros_like(th), np.zeros_like(th), np.sin(th / 2)], -1)


SUPPORT_TOUCH = 1e-3   # m: a point this low touches the support


def outside(xy: np.ndarray, z: np.ndarray, workspace) -> np.ndarray:
    """Whether points are outside the workspace rectangle ``(xmin, xmax,
    ymin, ymax)`` or have fallen below the support (z < -1 cm)."""
    x0, x1, y0, y1 = workspace
    return ((xy[..., 0] < x0) | (xy[..., 0] > x1) | (xy[..., 1] < y0) | (xy[..., 1] > y1)
            | (z < -0.01))


class Recorder:
    """What every monitor needs: the schedule's phase of each step, the
    states at chosen phase ends, the running maxima.

    Args:
      schedule: the :class:`~robustness.physics.schedule.Schedule`.
      layout: the scene's :class:`~robustness.physics.scene.Layout`.
      n: samples; workspace: ``(xmin, xmax, ymin, ymax)``, m.
      keep: phase indices whose last state (and sensors) are kept.
      support: optional ``(points (n, m, 3), rectangle)``: body-frame points
        of each sample (m) that must not touch the support (world z below
        ``SUPPORT_TOUCH``) outside ``rectangle`` ``(xmin, xmax, ymin, ymax)``
        (a finite plate whose collision is a plane); touching there counts as
        leaving the workspace.
    """

    def __init__(self, schedule, layout, n: int, workspace, keep, support=None):
        self.schedule, self.layout, self.n = schedule, layout, n
        self.workspace = workspace
        self.support = support
        self.keep = set(int(k) for k in keep)
        self.ends = {}
        self.sensors = {}
        self.max_tilt = np.zeros(n)
        self.left = np.zeros(n, bool)
        self.last_state = None

    def update(self, i0: int, states: np.ndarray, sens: np.ndarray) -> None:
        """Consume the states and sensors of global steps ``i0 ..``."""
        L = self.layout
        K = states.shape[1]
        pq = L.part_qpos
        _, tilt = yaw_tilt(states[:, :, pq + 3:pq + 7])
        self.max_tilt = np.maximum(self.max_tilt, np.nan_to_num(tilt, nan=np.pi).max(axis=1))
        self.left |= outside(states[:, :, pq:pq + 2], states[:, :, pq + 2], self.workspace).any(axis=1)
        if self.support is not None:
            pts, rect = self.support
            R = quat_to_mat(states[:, :, pq + 3:pq + 7])                       # (n, K, 3, 3)
            w = np.einsum("nkij,nmj->nkmi", R, pts) + states[:, :, None, pq:pq + 3]
            low = w[..., 2] < SUPPORT_TOUCH
            off = outside(w[..., :2], np.zeros_like(w[..., 2]), rect)
            self.left |= (low & off).any(axis=(1, 2))
        for p in self.keep:
            last = self.schedule.span(p)[1] - 1
            if i0 <= last < i0 + K:
                self.ends[p] = states[:, last - i0].copy()
                self.sensors[p] = sens[:, last - i0].copy()
        self.last_state = states[:, -1].copy()

    def kinds(self, i0: int, K: int):
        """Phase index and kind of each step ``i0 .. i0 + K - 1``."""
        ph = self.schedule.phase_at(np.arange(i0, i0 + K))
        kinds = np.array([self.schedule.phases[p].kind for p in ph])
        return ph, kinds


def planar_pose(state: np.ndarray, layout, dcom: np.ndarray):
    """Planar pose ``(x, y, theta)`` (n, 3) of the part's NOMINAL reference
    point: the body origin is the (perturbed) centre of mass; the reported
    point is it minus ``R(theta) dcom`` (the nominal centre of mass), as in
    :mod:`robustness.evaluation`."""
    pq = layout.part_qpos
    yaw, tilt = yaw_tilt(state[:, pq + 3:pq + 7])
    c, s = np.cos(yaw), np.sin(yaw)
    x = state[:, pq] - (c * dcom[:, 0] - s * dcom[:, 1])
    y = state[:, pq + 1] - (s * dcom[:, 0] + c * dcom[:, 1])
    return np.stack([x, y, wrap_angle_np(yaw)], -1), tilt


def fence_frame(state: np.ndarray, layout, thickness: float):
    """The fence's pushing face: a point on it (n, 2), the push direction d
    and the tangent t (n, 2 each), world frame."""
    tq = layout.tool_qpos
    psi = state[..., tq + 3]
    d = np.stack([np.cos(psi), np.sin(psi)], -1)
    t = np.stack([-d[..., 1], d[..., 0]], -1)
    face = state[..., tq:tq + 2] + 0.5 * thickness * d
    return face, d, t


def vertices_world(state: np.ndarray, layout, body: np.ndarray) -> np.ndarray:
    """World xy (n, ..., m, 2) of body-frame polygon vertices ``body`` (n, m, 2)
    (yaw only)."""
    pq = layout.part_qpos
    yaw, _ = yaw_tilt(state[..., pq + 3:pq + 7])
    c, s = np.cos(yaw)[..., None], np.sin(yaw)[..., None]
    bx, by = body[..., 0], body[..., 1]
    if state.ndim == 3:
        bx, by = bx[:, None], by[:, None]
    x = state[..., pq, None] + c * bx - s * by
    y = state[..., pq + 1, None] + s * bx + c * by
    return np.stack([x, y], -1)


def flush_edge(state: np.ndarray, layout, body: np.ndarray, thickness: float, flush_tol: float,
               contact_tol: float) -> np.ndarray:
    """Hull edge (n,) lying flush on the fence (both ends within
    ``contact_tol`` of its face and its outward normal within ``flush_tol``
    of the fence side), -1 if none."""
    face, d, _ = fence_frame(state, layout, thickness)
    v = vertices_world(state, layout, body)                             # (n, m, 2)
    dist = np.einsum("nmi,ni->nm", v - face[:, None, :], d)
    e = np.roll(v, -1, axis=1) - v
    normal = np.stack([e[..., 1], -e[..., 0]], -1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    cosang = -np.einsum("nmi,ni->nm", normal, d)
    ok = (cosang >= np.cos(flush_tol)) & (np.abs(dist) <= contact_tol) \
        & (np.abs(np.roll(dist, -1, axis=1)) <= contact_tol)
    return np.where(ok.any(axis=1), np.argmax(np.where(ok, cosang, -2.0), axis=1), -1)
