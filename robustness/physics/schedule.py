"""Open-loop tool trajectories: a plan turned into timed servo targets.

A :class:`Schedule` is a list of :class:`Phase` s that every sample of a plan
runs in lock step (the same number of steps, so that one ``mujoco.rollout``
call or one MJX scan advances all of them); only the targets differ between
samples (execution errors).  A phase moves the tool's target linearly from
``start`` to ``end`` over ``nmove`` steps (or along a per-step ``path``) and
then holds it for the rest of its ``nstep`` steps.  Controls are the target
``[x, y, z, yaw]`` at the end of each step and its velocity
(:data:`robustness.physics.scene.TOOL_JOINTS`; m, rad, world frame).

Phases after which the host changes something (``hook``: the feet's
friction after settling, a contact stroke, a tumble's sampled slip) end an
engine call (:func:`robustness.physics.runner.run_schedule` cuts its chunks
there; MJX runs its compiled chunk length and keeps the steps asked for).
"""
from __future__ import annotations

import dataclasses
import math
from typing import Optional

import numpy as np

PUSH_PHASES = ("settle", "transit", "descend", "approach", "push", "dwell", "retract", "lift",
               "final")
TUMBLE_PHASES = ("settle", "transit", "press", "dwell", "roll", "hold", "lift", "final")


@dataclasses.dataclass
class Phase:
    """One phase of a schedule.

    Attributes:
      kind: what the tool does (``PUSH_PHASES`` / ``TUMBLE_PHASES``).
      step: the push or tumble it belongs to (-1: none).
      nmove: steps of motion; nstep: total steps (the rest hold ``end``).
      start, end: (n or 1, 4) targets at the start and end of the motion.
      path: optional (nmove, 4) targets, one per step, common to all samples
        (replaces the straight line; ``start``/``end`` are its ends).
      hook: the host acts after this phase.
    """

    kind: str
    step: int
    nmove: int
    start: np.ndarray
    end: np.ndarray
    path: Optional[np.ndarray] = None
    hook: bool = False
    nstep: int = 0

    def __post_init__(self):
        self.nmove = max(int(self.nmove), 1)
        self.nstep = max(int(self.nstep), self.nmove)
        self.start = np.atleast_2d(np.asarray(self.start, np.float64))
        self.end = np.atleast_2d(np.asarray(self.end, np.float64))


def steps_for(duration: float, dt: float) -> int:
    """Steps of ``dt`` covering ``duration`` seconds (at least 1)."""
    return max(1, int(math.ceil(duration / dt - 1e-9)))


class Schedule:
    """Phases in order, with their global step ranges.

    Args:
      phases: the :class:`Phase` list.
      dt: the timestep, s.
    """

    def __init__(self, phases: list, dt: float):
        self.dt = float(dt)
        self.phases = phases
        first = 0
        self.first = []
        for ph in phases:
            self.first.append(first)
            first += ph.nstep
        self.first = np.asarray(self.first, np.int64)
        self.total = int(first)

    def hook_ends(self) -> dict:
        """Global step index -> phase index, for the phases with a hook."""
        return {int(self.first[i] + ph.nstep): i for i, ph in enumerate(self.phases) if ph.hook}

    def phase_at(self, steps: np.ndarray) -> np.ndarray:
        """Phase index of each global step index."""
        return np.searchsorted(self.first, np.asarray(steps), side="right") - 1

    def span(self, i: int) -> tuple:
        """Global ``[first, last + 1)`` steps of phase ``i``."""
        return int(self.first[i]), int(self.first[i] + self.phases[i].nstep)

    def controls(self, i0: int, i1: int, n: int) -> np.ndarray:
        """Controls ``(n, i1 - i0, 8)`` for global steps ``i0 .. i1 - 1``."""
        out = np.empty((n, i1 - i0, 8))
        p = int(self.phase_at(i0))
        i = i0
        while i < i1:
            ph = self.phases[p]
            lo, hi = self.span(p)
            j0, j1 = i - lo, min(i1, hi) - lo
            out[:, i - i0:i - i0 + j1 - j0] = self._phase_controls(ph, j0, j1, n)
            i = lo + j1
            p += 1
        return out

    def _phase_controls(self, ph: Phase, j0: int, j1: int, n: int) -> np.ndarray:
        j = np.arange(j0, j1)
        moving = j < ph.nmove
        res = np.empty((n, j1 - j0, 8))
        if ph.path is not None:
            path = np.asarray(ph.path)
            idx = np.minimum(j, ph.nmove - 1)
            pos = path[idx]
            prev = np.where((idx == 0)[:, None], ph.start[0][None, :], path[np.maximum(idx - 1, 0)])
            vel = np.where(moving[:, None], (pos - prev) / self.dt, 0.0)
            res[:, :, :4] = pos[None]
            res[:, :, 4:] = vel[None]
            return res
        frac = np.minimum((j + 1) / ph.nmove, 1.0)
        delta = ph.end - ph.start                                      # (n or 1, 4)
        res[:, :, :4] = ph.start[:, None, :] + frac[None, :, None] * delta[:, None, :]
        res[:, :, 4:] = np.where(moving[None, :, None], delta[:, None, :] / (ph.nmove * self.dt),
                                 0.0)
        return res


def unwrap_near(angle: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """``angle`` plus the whole turns that bring it within pi of ``ref`` (rad)."""
    return ref + np.remainder(angle - ref + np.pi, 2.0 * np.pi) - np.pi


def transit_steps(a: np.ndarray, b: np.ndarray, speed: float, yaw_rate: float, dt: float) -> int:
    """Steps of a move from targets ``a`` to ``b`` ((n, 4)) at ``speed`` m/s
    and ``yaw_rate`` rad/s, the slowest sample setting the pace."""
    lin = np.max(np.linalg.norm(np.atleast_2d(b)[:, :3] - np.atleast_2d(a)[:, :3], axis=1))
    ang = np.max(np.abs(np.atleast_2d(b)[:, 3] - np.atleast_2d(a)[:, 3]))
    return steps_for(max(lin / speed, ang / yaw_rate, dt), dt)
