"""The batched pose planner: many start/goal pairs of one part at once (JAX,
jit + vmap, float64), with the same rules, options and results as the numpy
reference :func:`planning.pushing.planner.plan_pose` (tested plan for plan).

The candidates of every pair are evaluated in closed form
(:mod:`planning.pushing.batch_kernel`); every plan is then replayed by the exact
kinematics.  With a workspace, a pair whose best plan does not fit is planned
again by the numpy reference (the constrained LP runs on the host).

Frames: world frame, metres, radians CCW.  Pose ``(x, y, theta)``:
``p_world = R(theta) (p - com) + (x, y)``.
"""
from __future__ import annotations

import dataclasses
import functools
import math
from typing import Optional

import jax
import jax.numpy as jnp
import numpy as np

from kernels import wrap_angle, float64, replay_pushes
from planning.pushing.options import DEFAULTS, PushOptions, options_of
from planning.pushing import batch_kernel as bk, planner as pp, sequences as sq, workspace as wsp
from planning.pushing.part import ANG_TOL, PlanningError, PushPart, check_pose, prepare_part
from planning.pushing.plan import Push, PushPlan


# --------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True, eq=False)
class PushPlanBatch:
    """Plans for many start/goal pairs of one part (numpy arrays, leading axis B).

    Attributes:
      part: the prepared part; starts, goals: (B, 3) poses.
      settings: the planner's :class:`~planning.PushOptions`.
      ok: (B,) plan found and verified by replay.
      plan_class: (B,) index into ``PLAN_CLASSES``; turns: (B,) extra full turns.
      total_distance: (B,) m; n_pushes: (B,).
      kind: (B, P) 0 none / 1 translate / 2 reorient; angle (B, P) world angle of
      the fence direction (rad; ``direction`` gives unit vectors);
      distance (B, P) m; edge (B, P) hull edge; contact (B, P) hull vertex or -1;
      min_distance (B, P) m; rotation (B, P) planned rotation (rad);
      pose_after (B, P, 3) replayed; final_error (B, 2).
      replanned: plans found by the numpy reference (workspace fallback), by index.
    """

    part: PushPart
    starts: np.ndarray
    goals: np.ndarray
    settings: PushOptions
    ok: np.ndarray
    plan_class: np.ndarray
    turns: np.ndarray
    total_distance: np.ndarray
    n_pushes: np.ndarray
    kind: np.ndarray
    angle: np.ndarray
    distance: np.ndarray
    edge: np.ndarray
    contact: np.ndarray
    min_distance: np.ndarray
    rotation: np.ndarray
    pose_after: np.ndarray
    final_error: np.ndarray
    replanned: dict = dataclasses.field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.ok)

    @property
    def objective(self) -> str:
        return self.settings.objective

    @property
    def margin_deg(self) -> float:
        return self.part.margin_deg

    @property
    def direction(self) -> np.ndarray:
        """(B, P, 2) unit fence directions, world frame (computed from ``angle``)."""
        return np.stack([np.cos(self.angle), np.sin(self.angle)], -1)

    def plan(self, b: int) -> PushPlan:
        """The b-th plan as a :class:`PushPlan` (raises PlanningError if not ok)."""
        if not self.ok[b]:
            raise PlanningError(f"plan {b}: no verified plan (final error {self.final_error[b].tolist()})")
        if b in self.replanned:
            return self.replanned[b]
        poly = self.part.polygon
        hull = poly.hull_index
        pushes = []
        for i in range(self.kind.shape[1]):
            k = int(self.kind[b, i])
            if k == 0:
                continue
            reo = k == 2
            pushes.append(Push(
                kind="reorient" if reo else "translate",
                direction=(math.cos(self.angle[b, i]), math.sin(self.angle[b, i])),
                distance=float(self.distance[b, i]), edge=poly.edge_vertices(int(self.edge[b, i])),
                contact_vertex=hull[int(self.contact[b, i])] if reo else None,
                min_distance=float(self.min_distance[b, i]) if reo else None,
                pose_after=tuple(float(x) for x in self.pose_after[b, i]),
                rotation=float(self.rotation[b, i]) if reo else None))
        return pp.make_plan(self.part, self.settings, self.starts[b], self.goals[b], tuple(pushes),
                            int(self.plan_class[b]), int(self.turns[b]), self.final_error[b])


@functools.lru_cache(maxsize=32)
def _plan_fns(part: PushPart, strategy: str, extra_steps: int, objective: str, R: int, tier: int):
    """``(fast, full)`` jit(vmap) planners over (starts, goals) -> compact plans
    for the candidates of one tier (:func:`planning.pushing.batch_kernel.plan_functions`)."""
    table = sq.candidate_table(part, strategy, extra_steps)
    keep = np.flatnonzero(table["tier"] == tier)
    sub = {k: v[keep] for k, v in table.items()}
    fasts, full = bk.plan_functions(part, sub, objective, R, rows=keep)
    return [jax.jit(jax.vmap(f)) for f in fasts], jax.jit(jax.vmap(full))


def _run(fn, starts, goals, sel, size):
    """Apply a compiled planner to the pairs ``sel`` in padded blocks (a small
    selection in smaller blocks: sizes ``size / 4^k``, a few compilations)."""
    while size > 64 and len(sel) <= size // 4:
        size //= 4
    spans = list(_blocks(len(sel), size))
    # dispatch every block before reading any back: JAX runs them asynchronously
    pending = [fn(jnp.asarray(_padded(starts[sel[lo:hi]], size)), jnp.asarray(_padded(goals[sel[lo:hi]], size)))
               for lo, hi in spans]
    blocks = [{k: np.asarray(v)[:hi - lo] for k, v in o.items()} for o, (lo, hi) in zip(pending, spans)]
    return {k: np.concatenate([blk[k] for blk in blocks]) for k in blocks[0]}


def _plan_all(part, settings, starts, goals, size):
    """Plans of every pair: tier by tier (a tier only for the pairs that the
    lower tiers cannot serve), the fast path first, the full one for the pairs
    it could not certify."""
    table = sq.candidate_table(part, settings.strategy, settings.extra_steps)
    B = len(starts)
    out = None
    todo = np.arange(B)
    for tier in sorted(set(table["tier"].tolist())):
        if len(todo) == 0:
            break
        fasts, full = _plan_fns(part, settings.strategy, settings.extra_steps, settings.objective,
                                settings.max_reorients, tier)
        res = None
        for fn in fasts + [full]:
            if res is None:
                res = _run(fn, starts, goals, todo, size)
                continue
            where = np.flatnonzero(~res["certified"])
            if len(where) == 0:
                break
            again = _run(fn, starts, goals, todo[where], size)
            for k in res:
                res[k][where] = again[k]
        if out is None:
            out = {k: np.zeros((B,) + v.shape[1:], v.dtype) for k, v in res.items()}
        for k in out:
            out[k][todo] = res[k]
        todo = todo[~res["feasible"]]
    return out


@functools.lru_cache(maxsize=64)
def _replay_fn(part: PushPart, length: int):
    """jit(vmap) of the exact replay of ``length`` pushes, with per-plan checks."""
    geom = part.geom
    rate = pp.replay_rate(part)

    def one(start, goal, angles, dists, edges, kinds):
        dirs = jnp.stack([jnp.cos(angles), jnp.sin(angles)], -1)
        final, outs = replay_pushes(geom, start, dirs, dists, rate)
        landed = jnp.all(jnp.where(kinds > 0, outs.finished & (outs.edge == edges), True))
        pos_err = jnp.hypot(final[0] - goal[0], final[1] - goal[1])
        ang_err = jnp.abs(wrap_angle(final[2] - goal[2]))
        return outs.pose, landed, jnp.stack([pos_err, ang_err])

    return jax.jit(jax.vmap(one))


def _blocks(n_items: int, size: int):
    for lo in range(0, n_items, size):
        yield lo, min(lo + size, n_items)


def _padded(arr: np.ndarray, size: int) -> np.ndarray:
    k = len(arr)
    if k == size:
        return arr
    return np.concatenate([arr, np.repeat(arr[-1:], size - k, 0)])


@float64
def plan_pose_batch(vertices, starts, goals, com=None, options: Optional[PushOptions] = None,
                    chunk: Optional[int] = 1024) -> PushPlanBatch:
    """Plan many start/goal pairs of one part at once (JAX, float64).

    Same rules, options and results as :func:`plan_pose` (closed-form LP).
    Per candidate the work is O(stable edges), independent of the number of
    reorient steps (:mod:`planning.pushing.batch_kernel`).  Every plan is then
    replayed by the exact kinematics (plans sorted by length so that each
    block replays only as many pushes as its longest plan).

    Args:
      vertices, com, options: as :func:`plan_pose` (``options.solver`` must be
        the closed form).
      starts, goals: (B, 3) poses ``(x, y, theta)`` (m, m, rad), world frame.
      chunk: pairs per compiled call (bounds memory; the last block is padded
        so one compilation serves every block).

    Returns:
      A :class:`PushPlanBatch`; ``ok[b]`` says whether plan ``b`` was found
      and verified (``plan(b)`` raises for one that was not).
    """
    o = options_of(options)
    if o.solver != DEFAULTS.solver:
        raise ValueError(f"options.solver: the batched planner solves every LP in closed form, "
                         f"got {o.solver!r}")
    settings = o
    starts = np.atleast_2d(check_pose(starts, "starts"))
    goals = np.atleast_2d(check_pose(goals, "goals"))
    if starts.shape != goals.shape or starts.ndim != 2:
        raise ValueError(f"starts/goals: expected two (B, 3) arrays, got {starts.shape} and {goals.shape}")
    B = len(starts)
    if B == 0:
        raise ValueError("starts: need at least one start/goal pair")
    part = prepare_part(vertices, com, o.margin_deg, o.safety_factor, support=o.support,
                        min_fence_mu=o.min_fence_mu)
    if settings.workspace is not None:
        _check_all_inside(part, settings.workspace, starts, goals)
    size = min(B, int(chunk)) if chunk else B
    out = _plan_all(part, settings, starts, goals, size)
    out.pop("certified")
    pose_after, landed, final_error = _replay_all(part, starts, goals, out, size)
    used_len = pose_after.shape[1]
    out = {k: (v[:, :used_len] if v.ndim == 2 else v) for k, v in out.items()}
    pose_after[out["kind"] == 0] = 0.0
    tol = part.pos_tol(np.hypot(starts[:, 0], starts[:, 1]) + np.hypot(goals[:, 0], goals[:, 1])
                       + out["distance"].sum(axis=1))
    ok = out.pop("feasible") & landed & (final_error[:, 0] < tol) & (final_error[:, 1] < ANG_TOL)
    batch = PushPlanBatch(part=part, starts=starts, goals=goals, settings=settings, ok=ok,
                          total_distance=out["distance"].sum(axis=1), pose_after=pose_after,
                          final_error=final_error, **out)
    if settings.workspace is not None:
        _workspace_fallback(batch)
    return batch


def _check_all_inside(part, ws, starts, goals) -> None:
    """Every start and goal pose holds the part inside the workspace (else one
    ValueError naming the pairs)."""
    for field, poses in (("starts", starts), ("goals", goals)):
        bad = []
        for b, pose in enumerate(poses):
            if wsp.outside(wsp.pose_box(part, pose), ws, part.pos_tol(*pose[:2])):
                bad.append(b)
        if bad:
            raise ValueError(f"workspace: the part at {field} {bad[:10]}{' ...' if len(bad) > 10 else ''} "
                             f"({len(bad)} of {len(poses)}) is not inside the workspace {list(ws)}; give a "
                             f"workspace that holds every start and goal pose")


def _replay_all(part, starts, goals, out, size):
    """Replay every plan, shortest first, each block only as long as its longest
    plan (even lengths bound the number of compilations)."""
    B = len(starts)
    used_len = max(1, int(out["n_pushes"].max()))
    order = np.argsort(out["n_pushes"], kind="stable")
    pose_after = np.zeros((B, used_len, 3))
    landed = np.zeros(B, bool)
    final_error = np.zeros((B, 2))
    pending = []
    for lo, hi in _blocks(B, size):
        idx = order[lo:hi]
        need = int(out["n_pushes"][idx].max())
        length = min(used_len, max(2, need + (need % 2)))
        rf = _replay_fn(part, length)
        args = [starts[idx], goals[idx], out["angle"][idx, :length], out["distance"][idx, :length],
                out["edge"][idx, :length], out["kind"][idx, :length]]
        pending.append((idx, length, rf(*[jnp.asarray(_padded(a, size)) for a in args])))
    for idx, length, (poses, lnd, err) in pending:
        k = len(idx)
        pose_after[idx, :length] = np.asarray(poses)[:k]
        landed[idx] = np.asarray(lnd)[:k]
        final_error[idx] = np.asarray(err)[:k]
    return pose_after, landed, final_error


def _workspace_fallback(batch: PushPlanBatch) -> None:
    """Pairs whose best plan leaves the workspace are planned by the numpy
    reference (its constrained LP); their plans are kept in ``replanned``."""
    part, ws = batch.part, batch.settings.workspace
    for b in range(len(batch)):
        fits = False
        if batch.ok[b]:
            live = batch.kind[b] > 0
            piv = np.where(batch.kind[b] == 2, batch.contact[b], -1)[live]
            boxes = wsp.swept_boxes(part.body, batch.starts[b], batch.direction[b][live],
                                    batch.pose_after[b][live], piv, batch.rotation[b][live],
                                    batch.min_distance[b][live] * (1.0 + wsp.SWEEP_GUARD))
            tol = wsp.plan_tol(part, batch.starts[b], batch.goals[b], float(batch.total_distance[b]))
            fits = not any(wsp.outside(box, ws, tol) for box in boxes)
        if fits:
            continue
        try:
            plan = pp.plan_one(part, batch.settings, batch.starts[b], batch.goals[b])
        except PlanningError:
            batch.ok[b] = False
            continue
        batch.replanned[b] = plan
        batch.ok[b] = True
        batch.total_distance[b] = plan.total_distance
        batch.n_pushes[b] = plan.n_pushes
