"""The batched Akella-Mason pose planner: many start/goal pairs of one part at
once (JAX, jit + vmap, float64), with the same rules and results as the numpy
reference :func:`planning.pushing.planner.plan_pose` (tested plan for plan).

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

from kernels import polygon as pg
from kernels.planar import rot2, wrap_angle, wrap_angle_near
from kernels.precision import float64
from kernels.push import replay_pushes
from planning.pushing import pose_lp
from planning.pushing.part import (ANG_TOL, OBJECTIVES, POS_TOL, SAME_ORIENTATION, PlanningError,
                                   PushPart, check_pose, prepare_part)
from planning.pushing.plan import PLAN_CLASSES, Push, PushPlan


# --------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True, eq=False)
class PushPlanBatch:
    """Plans for many start/goal pairs of one part (numpy arrays, leading axis B).

    Attributes:
      part: the prepared part; starts, goals: (B, 3) poses.
      objective, margin_deg: settings.
      ok: (B,) plan found and verified by replay.
      plan_class: (B,) index into ``PLAN_CLASSES``; reorient_edge: (B,) hull edge (-1 none).
      total_distance: (B,) m; n_pushes: (B,).
      kind: (B, P) 0 none / 1 translate / 2 reorient; angle (B, P) world angle of
      the fence direction (rad; ``direction`` gives unit vectors);
      distance (B, P) m; edge (B, P) hull edge; contact (B, P) hull vertex or -1;
      min_distance (B, P) m; pose_after (B, P, 3) replayed; final_error (B, 2).
    """

    part: PushPart
    starts: np.ndarray
    goals: np.ndarray
    objective: str
    margin_deg: float
    ok: np.ndarray
    plan_class: np.ndarray
    reorient_edge: np.ndarray
    total_distance: np.ndarray
    n_pushes: np.ndarray
    kind: np.ndarray
    angle: np.ndarray
    distance: np.ndarray
    edge: np.ndarray
    contact: np.ndarray
    min_distance: np.ndarray
    pose_after: np.ndarray
    final_error: np.ndarray

    def __len__(self) -> int:
        return len(self.ok)

    @property
    def direction(self) -> np.ndarray:
        """(B, P, 2) unit fence directions, world frame (computed from ``angle``)."""
        return np.stack([np.cos(self.angle), np.sin(self.angle)], -1)

    def plan(self, b: int) -> PushPlan:
        """The b-th plan as a :class:`PushPlan` (raises PlanningError if not ok)."""
        if not self.ok[b]:
            raise PlanningError(f"plan {b}: no verified plan (final error {self.final_error[b].tolist()})")
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
                pose_after=tuple(float(x) for x in self.pose_after[b, i])))
        total = float(sum(p.distance for p in pushes))
        re = int(self.reorient_edge[b])
        return PushPlan(
            vertices=tuple((float(a), float(c)) for a, c in poly.vertices),
            com=(float(poly.com[0]), float(poly.com[1])),
            start=tuple(float(x) for x in self.starts[b]), goal=tuple(float(x) for x in self.goals[b]),
            pushes=tuple(pushes), plan_class=PLAN_CLASSES[int(self.plan_class[b])],
            reorient_edge=None if re < 0 else poly.edge_vertices(re),
            object_class=self.part.class_name, objective=self.objective,
            objective_value=float(len(pushes)) if self.objective == "pushes" else total,
            total_distance=total, margin_deg=self.margin_deg,
            safety_factor=self.part.safety_factor,
            final_error=(float(self.final_error[b, 0]), float(self.final_error[b, 1])))

    def to_plans(self) -> list[PushPlan]:
        """All plans (raises on the first that is not ok)."""
        return [self.plan(b) for b in range(len(self))]


def _candidate_table(part: PushPart) -> tuple[dict, int]:
    """Static candidate list in the numpy reference's order (translation, then
    (edge, CW/CCW) regular, then (edge, CW/CCW) singular) with everything that
    does not depend on the start and goal precomputed: step angles, the
    singular pre-step, pivots, and the Peshkin distances of full steps."""
    rows = [dict(cls=0, s=0, sidx=0, sense=0, sing=0, trans=1, step=1.0, pre=0.0, piv=0, piv_pre=0,
                 m_step=0.0, m_pre=0.0, k_main=1.0, b2_main=1.0)]
    for sing in (0, 1):
        for sidx, s in enumerate(part.stable):
            for sense in (pg.CW, pg.CCW):
                step = float(part.step[s, sense])
                pre = float(min(part.step[s, 0], part.step[s, 1])) if sing else 0.0
                piv = s if sense == pg.CW else (s + 1) % part.n
                piv_pre = (s + 1) % part.n if sense == pg.CW else s
                k, b2 = pg.pivot_constants_np(part.body, float(part.nu[s]), piv)
                rows.append(dict(cls=(3 if sing else 1) + sense, s=s, sidx=sidx, sense=sense,
                                 sing=sing, trans=0, step=step, pre=pre, piv=piv, piv_pre=piv_pre,
                                 m_step=part.peshkin(s, piv, step),
                                 m_pre=part.peshkin(s, piv_pre, pre) if sing else 0.0,
                                 k_main=part.safety_factor * k, b2_main=b2))
    table = {k: np.array([r[k] for r in rows]) for k in rows[0]}
    r_max = max(int(math.ceil((2 * math.pi + r["pre"]) / r["step"])) + r["sing"]
                for r in rows if not r["trans"])
    return table, r_max


def _progression_deltas(a, sigma, count, psi):
    """Nearest terms of an arithmetic progression of column angles.

    The columns ``a + sigma t`` (rad), ``t = 1..count``, ``0 < |sigma| < pi``,
    span less than 5 pi.  Relative to direction ``psi`` the terms that can be
    nearest on either side are both ends and the terms on each side of every
    crossing of a multiple of 2 pi; there are at most two crossings.  Returns
    ``(t, delta)`` for those six terms, ``delta`` the term's angle relative to
    ``psi`` wrapped to (-pi, pi], computed with arithmetic only.
    """
    sg = jnp.sign(sigma)
    st = jnp.abs(sigma)
    y0 = sg * (a + sigma - psi)                               # term t = 1, mirrored to increase
    y0 = y0 - 2 * jnp.pi * jnp.floor(y0 / (2 * jnp.pi))       # in [0, 2 pi) (cheaper than remainder)
    c1 = jnp.ceil((2 * jnp.pi - y0) / st)
    c2 = jnp.ceil((4 * jnp.pi - y0) / st)
    last = jnp.maximum(count - 1, 0).astype(y0.dtype)
    off = jnp.clip(jnp.stack([jnp.zeros_like(c1), c1 - 1, c1, c2 - 1, c2, last]), 0, last)
    z = y0 + st * off - 2 * jnp.pi * ((off >= c1).astype(y0.dtype) + (off >= c2).astype(y0.dtype))
    z = jnp.where(z > jnp.pi, z - 2 * jnp.pi, z)
    return off.astype(jnp.int32) + 1, sg * z


@functools.lru_cache(maxsize=32)
def _plan_fn(part: PushPart, objective: str, singular: bool):
    """jit(vmap) of the batched planner over (starts, goals) -> compact plans.

    ``singular=False`` evaluates the translation and regular CW/CCW
    candidates; ``True`` the singularity handlers (run only for the pairs
    that the regular candidates cannot serve).
    """
    table, R = _candidate_table(part)
    keep = (table["sing"] == 1) if singular else (table["sing"] == 0)
    ns = len(part.stable)
    body = jnp.asarray(part.body)
    stable = jnp.asarray(np.array(part.stable))
    omega = jnp.asarray(part.omega)
    cand = {k: jnp.asarray(v[keep]) for k, v in table.items()}
    rows_r = jnp.arange(1, R + 1)
    js = jnp.arange(ns)

    def rotv(th, v):
        return rot2(th) @ v

    def unit(a):
        return jnp.stack([jnp.cos(a), jnp.sin(a)], -1)

    def eval_cand(theta0, thetag, T, c):
        trans = c["trans"] == 1
        sing = c["sing"]
        sgn = jnp.where(c["sense"] == pg.CCW, 1.0, -1.0)
        delta = jnp.remainder(sgn * (thetag - theta0), 2 * jnp.pi)
        delta = jnp.where(delta == 0.0, 2 * jnp.pi, delta)
        dp = delta + c["pre"]
        n = jnp.ceil(dp / c["step"] * (1 - 1e-12)).astype(jnp.int32)
        a_last = dp - (n - 1) * c["step"]
        r = jnp.where(trans, 0, n + sing)
        th1 = theta0 - sgn * c["pre"]
        base = jnp.where(sing == 1, th1, theta0)
        thf = theta0 + sgn * delta
        m_last = pg.peshkin_length(c["k_main"], c["b2_main"] - a_last, c["b2_main"])
        sum_m = (n - 1) * c["m_step"] + m_last + sing * c["m_pre"]
        # centre-of-mass shifts telescope: sum_i R(th_{i-1}) v - R(th_i) v
        v, vp = body[c["piv"]], body[c["piv_pre"]]
        shift = rotv(base, v) - rotv(thf, v) + sing * (rotv(theta0, vp) - rotv(th1, vp))
        # Peshkin parts along the reorient directions: a geometric sum over the full steps
        sig = sgn * c["step"]
        k = (n - 1).astype(sig.dtype)
        geo = jnp.sin(0.5 * k * sig) / jnp.sin(0.5 * sig)
        ws = omega[c["sidx"]]
        shift = (shift + c["m_step"] * geo * unit(base + ws + 0.5 * (k + 1) * sig)
                 + m_last * unit(thf + ws) + sing * c["m_pre"] * unit(th1 + ws))
        target = jnp.where(trans, T, T - shift)
        sum_m = jnp.where(trans, 0.0, sum_m)
        psi = jnp.arctan2(target[1], target[0])
        # reduced column set, as angles relative to the target: per stable edge, the start,
        # pre-step and final orientations and the progression terms nearest the target
        t_prog, d_prog = jax.vmap(lambda w: _progression_deltas(base + w, sig, n - 1, psi))(omega)
        rows = jnp.concatenate([jnp.zeros((ns, 1), jnp.int32), jnp.ones((ns, 1), jnp.int32),
                                jnp.broadcast_to(r, (ns, 1)).astype(jnp.int32), sing + t_prog], 1)
        dlt = jnp.concatenate([wrap_angle_near(theta0 + omega - psi)[:, None],
                               wrap_angle_near(th1 + omega - psi)[:, None],
                               wrap_angle_near(thf + omega - psi)[:, None], d_prog], 1)
        valid = jnp.concatenate([jnp.ones((ns, 1), bool), jnp.broadcast_to(sing == 1, (ns, 1)),
                                 jnp.broadcast_to(~trans, (ns, 1)),
                                 jnp.broadcast_to((n >= 2) & ~trans, (ns, 6))], 1)
        merged = (js[:, None] == c["sidx"]) & (rows >= 1) & valid
        edges = jnp.broadcast_to(js[:, None], rows.shape)
        ok_c = jnp.where(trans, jnp.abs(wrap_angle(thetag - theta0)) <= SAME_ORIENTATION, True)
        rank = (rows * ns + edges).ravel()   # ties go to the earliest (orientation, edge), as in plan_pose
        feas, cost, npush, ia, xa, ib, xb = pose_lp.solve_delta(
            dlt.ravel(), valid.ravel(), merged.ravel(), jnp.hypot(target[0], target[1]), objective, rank)
        feas = feas & ok_c
        fl = lambda x: x.ravel()
        return dict(feas=feas, total=jnp.where(feas, sum_m + cost, jnp.inf), npush=r + npush, r=r,
                    a_last=a_last, m_last=m_last, th1=th1, base=base, thf=thf, sig=sig,
                    row_a=fl(rows)[ia], col_a=fl(edges)[ia], ang_a=psi + fl(dlt)[ia],
                    mrg_a=fl(merged)[ia], xa=xa,
                    row_b=fl(rows)[ib], col_b=fl(edges)[ib], ang_b=psi + fl(dlt)[ib],
                    mrg_b=fl(merged)[ib], xb=jnp.where(ia == ib, 0.0, xb))

    def plan_one(start, goal):
        theta0, thetag = start[2], goal[2]
        res = jax.vmap(eval_cand, in_axes=(None, None, None, 0))(theta0, thetag, goal[:2] - start[:2], cand)
        if objective == "pushes":
            bn = jnp.min(jnp.where(res["feas"], res["npush"], jnp.iinfo(jnp.int32).max))
            ci = jnp.argmin(jnp.where(res["feas"] & (res["npush"] == bn), res["total"], jnp.inf))
        else:
            ci = jnp.argmin(jnp.where(res["feas"], res["total"], jnp.inf))
        g = jax.tree_util.tree_map(lambda x: x[ci], res)
        c = jax.tree_util.tree_map(lambda x: x[ci], cand)
        r, sing = g["r"], c["sing"]
        # reorient pushes at rows 1..R (live up to r)
        is_pre = (sing == 1) & (rows_r == 1)
        is_last = rows_r == r
        th = jnp.where(is_pre, g["th1"], jnp.where(is_last, g["thf"], g["base"] + g["sig"] * (rows_r - sing)))
        m = jnp.where(is_pre, c["m_pre"], jnp.where(is_last, g["m_last"], c["m_step"]))
        ext = (jnp.where(g["mrg_a"] & (g["row_a"] == rows_r), g["xa"], 0.0)
               + jnp.where(g["mrg_b"] & (g["row_b"] == rows_r), g["xb"], 0.0))
        live = rows_r <= r
        # at most two translation pushes: the LP's basic columns that do not extend a reorient
        tr_live = jnp.stack([~g["mrg_a"] & (g["xa"] > pose_lp.DROP), ~g["mrg_b"] & (g["xb"] > pose_lp.DROP)])
        # execution order: reorient i, then the translations at orientation i by stable edge;
        # positions are counted, not sorted: a reorient follows the translations at earlier
        # orientations, a translation follows the reorients up to its orientation
        tr_row = jnp.stack([g["row_a"], g["row_b"]])
        tr_key = tr_row * (ns + 1) + jnp.stack([g["col_a"], g["col_b"]])
        n_before_reo = jnp.sum(tr_live[None, :] & (tr_row[None, :] < rows_r[:, None]), axis=1)
        pos_reo = jnp.where(live, rows_r - 1 + n_before_reo, R + 2)
        other_first = tr_live[::-1] & ((tr_key[::-1] < tr_key) | ((tr_key[::-1] == tr_key) & (jnp.arange(2) == 1)))
        pos_tr = jnp.where(tr_live, jnp.minimum(tr_row, r) + other_first, R + 2)
        pos = jnp.concatenate([pos_reo, pos_tr])
        used_in = jnp.concatenate([live, tr_live]) & g["feas"]
        pos = jnp.where(used_in, pos, R + 2)

        def place(vals, fill):
            return jnp.full(R + 2, fill, vals.dtype).at[pos].set(vals, mode="drop")

        piv = jnp.where(is_pre, c["piv_pre"], c["piv"])
        used = place(used_in, False)
        kind = place(jnp.concatenate([jnp.full(R, 2), jnp.ones(2, jnp.int32)]), 0)
        ang = place(wrap_angle(jnp.concatenate([th + omega[c["sidx"]], jnp.stack([g["ang_a"], g["ang_b"]])])), 0.0)
        dist = place(jnp.concatenate([m + ext, jnp.stack([g["xa"], g["xb"]])]), 0.0)
        edge = place(jnp.concatenate([jnp.full(R, c["s"]), stable[jnp.stack([g["col_a"], g["col_b"]])]]), -1)
        contact = place(jnp.concatenate([piv, jnp.full(2, -1)]), -1)
        mind = place(jnp.concatenate([m, jnp.zeros(2)]), 0.0)
        return dict(feasible=g["feas"], plan_class=c["cls"],
                    reorient_edge=jnp.where(c["trans"] == 1, -1, c["s"]), n_pushes=jnp.sum(used),
                    kind=kind, angle=ang, distance=dist, edge=edge, contact=contact, min_distance=mind)

    return jax.jit(jax.vmap(plan_one)), R + 2


@functools.lru_cache(maxsize=64)
def _replay_fn(part: PushPart, length: int):
    """jit(vmap) of the exact replay of ``length`` pushes, with per-plan checks."""
    geom = part.geom

    def one(start, goal, angles, dists, edges, kinds):
        dirs = jnp.stack([jnp.cos(angles), jnp.sin(angles)], -1)
        final, outs = replay_pushes(geom, start, dirs, dists)
        landed = jnp.all(jnp.where(kinds > 0, outs.edge == edges, True))
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
def plan_pose_batch(vertices, starts, goals, com=None, margin_deg: float = 7.0,
                    safety_factor: float = 1.15, objective: str = "distance",
                    chunk: Optional[int] = 1024) -> PushPlanBatch:
    """Plan many start/goal pairs of one part at once (JAX, float64).

    Same rules and results as :func:`plan_pose` (closed-form LP).  Per
    candidate the work is O(stable edges), independent of the number of
    reorient steps: the centre-of-mass shifts telescope, the Peshkin parts of
    the full steps are a geometric sum, and only the few columns of each
    arithmetic progression of push directions that can bracket the target are
    handed to the LP.  Every plan is then replayed by the exact kinematics
    (plans sorted by length so that each block replays only as many pushes
    as its longest plan).

    Args:
      vertices, com, margin_deg, safety_factor, objective: as :func:`plan_pose`.
      starts, goals: (B, 3) poses ``(x, y, theta)`` (m, m, rad), world frame.
      chunk: pairs per compiled call (bounds memory; the last block is padded
        so one compilation serves every block).

    Returns:
      A :class:`PushPlanBatch`; ``ok[b]`` says whether plan ``b`` was found
      and verified (``plan(b)`` raises for one that was not).
    """
    if objective not in OBJECTIVES:
        raise ValueError(f"objective: expected one of {OBJECTIVES}, got {objective!r}")
    starts = np.atleast_2d(check_pose(starts, "starts"))
    goals = np.atleast_2d(check_pose(goals, "goals"))
    if starts.shape != goals.shape or starts.ndim != 2:
        raise ValueError(f"starts/goals: expected two (B, 3) arrays, got {starts.shape} and {goals.shape}")
    B = len(starts)
    if B == 0:
        raise ValueError("starts: need at least one start/goal pair")
    part = prepare_part(vertices, com, margin_deg, safety_factor)
    size = min(B, int(chunk)) if chunk else B

    def run_plan(singular, sel):
        fn, P = _plan_fn(part, objective, singular)
        spans = list(_blocks(len(sel), size))
        # dispatch every block before reading any back: JAX runs them asynchronously
        pending = [fn(jnp.asarray(_padded(starts[sel[lo:hi]], size)),
                      jnp.asarray(_padded(goals[sel[lo:hi]], size))) for lo, hi in spans]
        blocks = [{k: np.asarray(v)[:hi - lo] for k, v in o.items()}
                  for o, (lo, hi) in zip(pending, spans)]
        return {k: np.concatenate([blk[k] for blk in blocks]) for k in blocks[0]}, P

    out, P = run_plan(False, np.arange(B))
    hard = np.flatnonzero(~out["feasible"])
    if len(hard):  # the singularity handlers, only where the regular candidates fail
        sub, _ = run_plan(True, hard)
        for k in out:
            out[k][hard] = sub[k]
    # replay, shortest plans first, each block only as long as its longest plan
    # (even lengths bound the number of compilations)
    used_len = max(1, int(out["n_pushes"].max()))
    out = {k: (v[:, :used_len] if v.ndim == 2 else v) for k, v in out.items()}
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
    pose_after[out["kind"] == 0] = 0.0
    ok = out.pop("feasible") & landed & (final_error[:, 0] < POS_TOL) & (final_error[:, 1] < ANG_TOL)
    total = out["distance"].sum(axis=1)
    return PushPlanBatch(part=part, starts=starts, goals=goals, objective=objective,
                         margin_deg=float(margin_deg), ok=ok, total_distance=total,
                         pose_after=pose_after, final_error=final_error, **out)
