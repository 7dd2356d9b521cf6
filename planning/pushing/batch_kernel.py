"""The batched planner's kernel: every candidate of
:mod:`planning.pushing.sequences` for one start/goal pair, in closed form, and
the chosen plan's pushes (JAX, written for one pair and vmapped by
:mod:`planning.pushing.batch`).

Per candidate the work is O(stable edges), whatever the number of steps:

* a candidate's reorient pushes form *runs* of equal steps (pre-excursion,
  the main run on edge A, then on edge B, post-excursion; the paper's
  angle-eating run is full steps and one last step, rule ``LAST`` equal steps
  and a last step of its own).  A push of angle ``a``
  about pivot ``v`` that ends at orientation ``theta`` moves the centre of mass
  by ``R(theta) Q`` with ``Q = R(-sigma a) v - v + need(a) u(omega)``, so a run's
  displacement is ``Q`` times a geometric sum of rotations (closed form);
* the LP's columns are the stable edges' push directions at every orientation
  of the sequence; the orientations of a run form an arithmetic progression,
  and only its terms around the target's direction can be the nearest column
  on either side (:func:`progression_terms`), so each edge hands a handful of
  columns to the closed-form LP (:func:`planning.pushing.pose_lp.solve_delta`),
  with the numpy reference's column ranks for ties.

Frames: world frame, metres, radians CCW.
"""
from __future__ import annotations

import functools
import math

import jax
import jax.numpy as jnp
import numpy as np

from kernels import (CCW, mod_2pi, peshkin_length, peshkin_length_np, rot2, rot2_np, TWO_PI,
                     wrap_angle, wrap_angle_near)
from planning.pushing import pose_lp, sequences as sq
from planning.pushing.part import SAME_ORIENTATION, PushPart, guarded_start


def progression_terms(a, sigma, count, psi, crossings: int = 3):
    """Nearest terms of an arithmetic progression of column angles.

    The columns ``a + sigma t`` (rad), ``t = 1..count``, ``0 < |sigma| < pi``,
    span less than ``2 pi crossings``.  Relative to direction ``psi`` the terms
    that can be nearest on either side are both ends and the terms on each side
    of every crossing of a multiple of 2 pi; there are at most ``crossings``
    (static) of them.  Returns ``(t, delta)`` for those ``2 + 2 crossings``
    terms (``t`` clipped to ``1..count``; with ``count`` 0 they are invalid),
    ``delta`` the term's angle relative to ``psi`` wrapped to (-pi, pi],
    computed with arithmetic only.
    """
    sg = jnp.sign(sigma)
    st = jnp.abs(sigma)
    y0 = sg * (a + sigma - psi)                               # term t = 1, mirrored to increase
    y0 = y0 - TWO_PI * jnp.floor(y0 / TWO_PI)                 # in [0, 2 pi)
    cs = [jnp.ceil((k * TWO_PI - y0) / st) for k in range(1, crossings + 1)]
    last = jnp.maximum(count - 1, 0).astype(y0.dtype)
    off = jnp.clip(jnp.stack([jnp.zeros_like(y0)] + [x for c in cs for x in (c - 1, c)] + [last]), 0, last)
    z = y0 + st * off - TWO_PI * sum((off >= c).astype(y0.dtype) for c in cs)
    z = jnp.where(z > jnp.pi, z - TWO_PI, z)
    return off.astype(jnp.int32) + 1, sg * z


def _host_table(part: PushPart, table: dict) -> dict:
    """Per-candidate constants computed on the host (numpy): the gains,
    alignment angles, pivots and push-direction offsets of each run, and the
    static runs' (excursions, angle-eating full steps) distances and ``Q``."""
    C = len(table["trans"])
    sidx = {e: i for i, e in enumerate(part.stable)}
    om = part.omega
    out = {k: np.asarray(v) for k, v in table.items()}

    def run_consts(edge, sense):
        e = np.maximum(edge, 0)
        return (part.gain[e, sense], part.beta2[e, sense], part.body[part.pivot[e, sense]],
                om[[sidx.get(int(x), 0) for x in e]])

    sense = out["sense"]
    opp = 1 - sense
    for name, edge, sn in (("A", out["a"], sense), ("B", out["b"], sense),
                           ("P", out["pre_e"], opp), ("O", out["post_e"], opp)):
        g, b2, v, w = run_consts(edge, sn)
        out[f"g{name}"], out[f"b2{name}"], out[f"v{name}"], out[f"om{name}"] = g, b2, v, w
    out["pivA"] = part.pivot[out["a"], sense]
    out["pivB"] = part.pivot[out["b"], sense]
    out["pivP"] = part.pivot[np.maximum(out["pre_e"], 0), opp]
    out["pivO"] = part.pivot[np.maximum(out["post_e"], 0), opp]
    sgn = np.where(sense == CCW, 1.0, -1.0)
    for name, ang_key, cnt_key, sg in (("P", "pre_ang", "pre_cnt", -sgn), ("O", "post_ang", "post_cnt", -sgn),
                                       ("F", "step", None, sgn)):
        src = "A" if name == "F" else name
        a = out[ang_key] / (np.maximum(out[cnt_key], 1) if cnt_key else 1.0)
        a = np.where(np.isfinite(a) & (a > 0), a, 0.0)
        need, least = _need_np(out[f"g{src}"], out[f"b2{src}"], a)
        out[f"need{name}"], out[f"least{name}"], out[f"ang{name}"] = need, least, a
        out[f"Q{name}"] = _q_np(out[f"v{src}"], sg * a, need, out[f"om{src}"])
    assert np.all(out["pre_cnt"] <= 1) and np.all(out["post_cnt"] <= 1) and len(out["trans"]) == C
    return out


def _need_np(g, b2, a):
    """The distance given (guarded) and the rule's least distance (m) of reorient
    steps of ``a`` rad (0: no step) with gains ``g`` and alignment angles ``b2``."""
    with np.errstate(divide="ignore", invalid="ignore"):
        need = peshkin_length_np(g, guarded_start(b2, a), b2)
        least = peshkin_length_np(g, b2 - a, b2)
    return np.where(a > 0, need, 0.0), np.where(a > 0, least, 0.0)


def _q_np(v, sa, need, om):
    """Row-wise ``R(-sa) v - v + need u(om)`` (host twin of :func:`_q`)."""
    rv = np.stack([rot2_np(-s) @ vi for s, vi in zip(sa, v)]) if len(v) else np.zeros((0, 2))
    return rv - v + need[:, None] * np.stack([np.cos(om), np.sin(om)], -1)


def _need(g, b2, a):
    """JAX twin of :func:`_need_np`'s guarded distance (m)."""
    return peshkin_length(g, guarded_start(b2, a, jnp), b2)


def _least(g, b2, a):
    """The distance rule's least distance (m) of a reorient step of ``a`` rad."""
    return peshkin_length(g, b2 - a, b2)


def _q(v, sa, need, om):
    """Centre-of-mass displacement, in the landed orientation's frame, of a
    reorient step turning ``sa`` rad about pivot ``v`` and pushed ``need`` m
    along ``u(om)`` (the module docstring's ``Q``)."""
    return rot2(-sa) @ v - v + need * jnp.stack([jnp.cos(om), jnp.sin(om)])


def _geo(theta_first, step, count):
    """``sum_{i=0}^{count-1} u(theta_first + i step)`` as a unit direction times
    a length: ``(sin(count step / 2) / sin(step / 2)) u(theta_first + (count-1) step / 2)``."""
    cnt = count.astype(step.dtype)
    half = 0.5 * step
    safe = jnp.where(jnp.abs(jnp.sin(half)) > 1e-300, jnp.sin(half), 1.0)
    mag = jnp.where(count > 0, jnp.sin(cnt * half) / safe, 0.0)
    return mag, theta_first + (cnt - 1.0) * half


def _rotq(theta, q):
    """``q`` turned by ``theta`` rad (CCW)."""
    return rot2(theta) @ q


def plan_functions(part: PushPart, table: dict, objective: str, R: int, top_k=(4, 16), rows=None):
    """``(fasts, full)``: functions ``(start, goal) -> dict`` of the chosen plan
    (arrays of length ``R + 2``: the reorient pushes and at most two
    translations, in execution order, plus ``certified``); unjitted, unbatched.

    ``full`` solves every candidate's LP.  Each of ``fasts`` (objective
    ``distance`` only) bounds every candidate from below by its reorient
    distances plus ``|T''|`` (each LP column is a unit vector, so the LP costs at
    least ``|T''|``), solves the LPs of the ``k`` lowest bounds only (``k`` from
    ``top_k``), and is ``certified`` when the next bound exceeds the best cost
    found by more than the tie tolerance: then no other candidate can win or
    tie, and its plan is ``full``'s.  The caller tries them in order and
    ``full`` for the pairs none certified.  ``rows``: the
    table rows' indices in the whole candidate table (ties go to the lowest).
    The tiers of :mod:`planning.pushing.sequences` are the caller's business.

    The candidates are reordered (``rows`` keeps each one's row for ties) so
    that the *simple* ones (one run of equal steps on one edge) come first: their
    sequences take the short closed form, the others (two-edge splits, the
    paper's angle-eating runs, rule ``LAST``) the general one.

    Long (its nested functions are each short): they close over the host
    tables and the static flags (``simple``, ``has_pre``, ``has_post``,
    ``crossings``) that decide what jit traces, so they live in one scope.
    """
    rows = np.arange(len(table["trans"])) if rows is None else np.asarray(rows)
    is_simple = (np.asarray(table["split"]) == 0.0) & (np.asarray(table["rule"]) == sq.EQUAL)
    order = np.concatenate([np.flatnonzero(is_simple), np.flatnonzero(~is_simple)])
    n_simple = int(is_simple.sum())
    table = {k: np.asarray(v)[order] for k, v in table.items()}
    host = _host_table(part, table)
    ns = len(part.stable)
    sidx = {e: i for i, e in enumerate(part.stable)}
    host["spre"] = np.array([sidx.get(int(e), 0) for e in host["pre_e"]])
    host["spost"] = np.array([sidx.get(int(e), 0) for e in host["post_e"]])
    host["row"] = rows[order]
    has_pre, has_post = bool(np.any(host["pre_cnt"] > 0)), bool(np.any(host["post_cnt"] > 0))
    span = np.max(TWO_PI * (1 + host["turns"]) + host["pre_ang"] + host["post_ang"])
    crossings = max(1, int(math.ceil(span / TWO_PI - 1e-9)))
    cand = {k: jnp.asarray(v) for k, v in host.items()}
    C = len(host["trans"])
    omega = jnp.asarray(part.omega)
    stable = jnp.asarray(np.array(part.stable))
    js = jnp.arange(ns)
    scale = part.size
    longest = part.longest_plan
    big = jnp.iinfo(jnp.int32).max

    def shift_of(theta0, thetag, T, c, simple: bool):
        """Sequence, reorient distances and ``T''`` of one candidate (``simple``:
        static, the candidate is one run of equal steps on one edge)."""
        trans = c["trans"] == 1
        sgn = jnp.where(c["sense"] == CCW, 1.0, -1.0)
        delta = mod_2pi(sgn * (thetag - theta0))
        delta = jnp.where(delta == 0.0, TWO_PI, delta)
        base = delta + TWO_PI * c["turns"]
        total = base + c["pre_ang"] + c["post_ang"]
        step = jnp.where(c["step"] > 0, c["step"], 1.0)
        lastr = c["rule"] == sq.LAST              # n - 1 equal steps share ``rest``, then ``last``
        rest = total - c["last"]
        n = jnp.where(lastr, jnp.ceil(rest / step * (1.0 - sq.STEP_ROUND)).astype(jnp.int32) + c["extra"] + 1,
                      jnp.ceil(total / step * (1.0 - sq.STEP_ROUND)).astype(jnp.int32) + c["extra"])
        p, q = c["pre_cnt"], c["post_cnt"]
        r = jnp.where(trans, 0, n + p + q)
        split = c["split"] != 0.0
        valid = jnp.where(trans, jnp.abs(wrap_angle(thetag - theta0)) <= SAME_ORIENTATION,
                          (c["step"] > 0) & (r <= R) & (~split | (n >= 2)) & (~lastr | (rest > 0.0))
                          & ((c["twin"] == 0) | (n != 1)))
        eat = c["rule"] == sq.EAT
        nf = n.astype(total.dtype)
        j = jnp.where(split, jnp.clip(jnp.round(c["split"] * nf).astype(jnp.int32), 1, n - 1), n)
        alpha = jnp.where(lastr, rest / jnp.where(nf > 1.0, nf - 1.0, 1.0), total / nf)
        a_main = jnp.where(eat, step, alpha)
        s_main = sgn * a_main
        theta_m0 = theta0 - sgn * c["pre_ang"]
        theta_fin = theta0 + sgn * base
        needA = _need(c["gA"], c["b2A"], a_main)
        QA = _q(c["vA"], s_main, needA, c["omA"])
        if simple:   # one run of n equal steps on one edge (no split, no angle-eating, no LAST)
            theta_me = jnp.where(q > 0, theta_m0 + sgn * total, theta_fin) if has_post else theta_fin
            jA, nB, last_on_b = n - 1, jnp.zeros_like(n), jnp.zeros_like(trans)
            needB, needL, a_last = needA, needA, a_main
            mag, cen = _geo(theta_m0 + s_main, s_main, n)
            shift = mag * _rotq(cen, QA)
            sum_need = nf * needA
        else:
            a_last = jnp.where(eat, total - (nf - 1.0) * step, jnp.where(lastr, c["last"], alpha))
            last_on_b = (j < n) & ~eat
            needB = _need(c["gB"], c["b2B"], alpha)
            needL = _need(jnp.where(last_on_b, c["gB"], c["gA"]), jnp.where(last_on_b, c["b2B"], c["b2A"]),
                          a_last)
            vL = jnp.where(last_on_b, c["vB"], c["vA"])
            omL = jnp.where(last_on_b, c["omB"], c["omA"])
            theta_me = jnp.where(q > 0, theta_m0 + sgn * total, theta_fin)
            jA = jnp.minimum(j, n - 1)
            nB = n - 1 - jA
            magA, cenA = _geo(theta_m0 + s_main, s_main, jA)
            magB, cenB = _geo(theta_m0 + s_main * (jA + 1).astype(total.dtype), s_main, nB)
            shift = (magA * _rotq(cenA, QA) + magB * _rotq(cenB, _q(c["vB"], s_main, needB, c["omB"]))
                     + _rotq(theta_me, _q(vL, sgn * a_last, needL, omL)))
            sum_need = jA * needA + nB * needB + needL
        if has_pre:
            shift = shift + p * _rotq(theta_m0, c["QP"])
            sum_need = sum_need + p * c["needP"]
        if has_post:
            shift = shift + q * _rotq(theta_fin, c["QO"])
            sum_need = sum_need + q * c["needO"]
        target = jnp.where(trans, T, T - shift)
        sum_need = jnp.where(trans, 0.0, sum_need)
        bound = jnp.where(valid, sum_need + jnp.hypot(target[0], target[1]), jnp.inf)
        return dict(valid=valid, trans=trans, sum_need=sum_need, target=target, bound=bound, r=r, n=n,
                    j=j, jA=jA, a_main=a_main, s_main=s_main, theta_m0=theta_m0, theta_me=theta_me,
                    theta_fin=theta_fin, needA=needA, needB=needB, needL=needL, a_last=a_last,
                    last_on_b=last_on_b)

    def shifts(theta0, thetag, T):
        """:func:`shift_of` of every candidate: the simple ones, then the others."""
        parts = []
        for lo, hi, simple in ((0, n_simple, True), (n_simple, C, False)):
            if hi > lo:
                sub = jax.tree_util.tree_map(lambda x: x[lo:hi], cand)
                parts.append(jax.vmap(functools.partial(shift_of, simple=simple),
                                      in_axes=(None, None, None, 0))(theta0, thetag, T, sub))
        return parts[0] if len(parts) == 1 else jax.tree_util.tree_map(
            lambda *x: jnp.concatenate(x), *parts)

    def solve(theta0, g, c):
        """The candidate's LP (closed form, reduced columns)."""
        target, trans, n, p, q = g["target"], g["trans"], g["n"], c["pre_cnt"], c["post_cnt"]
        psi = jnp.arctan2(target[1], target[0])
        t_prog, d_prog = jax.vmap(lambda w: progression_terms(g["theta_m0"] + w, g["s_main"], n - 1, psi,
                                                              crossings))(omega)
        sL = jnp.where(g["last_on_b"], c["sb"], c["sa"])
        gens = [(jnp.zeros((ns, 1), jnp.int32), wrap_rel(theta0, psi)[:, None], jnp.ones((ns, 1), bool),
                 jnp.full((ns, 1), -1))]
        if has_pre:
            gens.append((jnp.ones((ns, 1), jnp.int32), wrap_rel(g["theta_m0"], psi)[:, None],
                         jnp.broadcast_to(p > 0, (ns, 1)) & ~trans, jnp.full((ns, 1), c["spre"])))
        gens.append((p + t_prog, d_prog, jnp.broadcast_to((n >= 2) & ~trans, t_prog.shape),
                     jnp.where(t_prog <= g["jA"], c["sa"], c["sb"])))
        gens.append((jnp.broadcast_to(p + n, (ns, 1)).astype(jnp.int32), wrap_rel(g["theta_me"], psi)[:, None],
                     jnp.broadcast_to(~trans, (ns, 1)), jnp.full((ns, 1), sL)))
        if has_post:
            gens.append((jnp.broadcast_to(p + n + 1, (ns, 1)).astype(jnp.int32),
                         wrap_rel(g["theta_fin"], psi)[:, None], jnp.broadcast_to(q > 0, (ns, 1)) & ~trans,
                         jnp.full((ns, 1), c["spost"])))
        rows, dlt, ok, land = (jnp.concatenate(x, 1) for x in zip(*gens))
        ok = ok & g["valid"]
        merged = (land == js[:, None]) & (rows >= 1) & ok
        edges = jnp.broadcast_to(js[:, None], rows.shape)
        feas, cost, npush, ia, xa, ib, xb = pose_lp.solve_delta(
            dlt.ravel(), ok.ravel(), merged.ravel(), jnp.hypot(target[0], target[1]), objective,
            (rows * ns + edges).ravel(), scale=scale)
        feas = feas & g["valid"] & (g["sum_need"] + cost <= longest)
        fl = lambda x: x.ravel()  # noqa: E731
        return dict(feas=feas, total=jnp.where(feas, g["sum_need"] + cost, jnp.inf), npush=g["r"] + npush,
                    row_a=fl(rows)[ia], col_a=fl(edges)[ia], ang_a=psi + fl(dlt)[ia], mrg_a=fl(merged)[ia],
                    xa=xa, row_b=fl(rows)[ib], col_b=fl(edges)[ib], ang_b=psi + fl(dlt)[ib],
                    mrg_b=fl(merged)[ib], xb=jnp.where(ia == ib, 0.0, xb))

    def wrap_rel(th, psi):
        return wrap_angle_near(th + omega - psi)

    def pick(res, rows):
        """Best of the evaluated candidates: the objective, ties to the lowest row."""
        ok = res["feas"]
        if objective == "pushes":
            bn = jnp.min(jnp.where(ok, res["npush"], big))
            ok = ok & (res["npush"] == bn)
        low = jnp.min(jnp.where(ok, res["total"], jnp.inf))
        win = ok & (res["total"] <= low * (1.0 + sq.COST_TIE))
        return jnp.argmin(jnp.where(win, rows, big)), low

    def angles(start, goal):
        theta0 = wrap_angle(start[2])
        return theta0, theta0 + wrap_angle(goal[2] - theta0), goal[:2] - start[:2]

    def finish(theta0, info, lp, c, i, certified):
        g = {**jax.tree_util.tree_map(lambda x: x[i], info), **jax.tree_util.tree_map(lambda x: x[i], lp)}
        ci = jax.tree_util.tree_map(lambda x: x[i], c)
        out = _assemble(g, ci, theta0, ns, R, stable, pose_lp.DROP * scale, g["feas"])
        out["certified"] = certified
        return out

    def full(start, goal):
        theta0, thetag, T = angles(start, goal)
        info = shifts(theta0, thetag, T)
        lp = jax.vmap(solve, in_axes=(None, 0, 0))(theta0, info, cand)
        i, _ = pick(lp, cand["row"])
        return finish(theta0, info, lp, cand, i, jnp.asarray(True))

    def fast(start, goal, K):
        theta0, thetag, T = angles(start, goal)
        info = shifts(theta0, thetag, T)
        idx = _smallest(info["bound"], min(K + 1, C))
        neg = -info["bound"][idx]
        sub_info = jax.tree_util.tree_map(lambda x: x[idx[:K]], info)
        sub_c = jax.tree_util.tree_map(lambda x: x[idx[:K]], cand)
        lp = jax.vmap(solve, in_axes=(None, 0, 0))(theta0, sub_info, sub_c)
        i, low = pick(lp, sub_c["row"])
        nxt = -neg[K] if K < C else jnp.inf
        certified = (K >= C) | (jnp.isfinite(low) & (nxt > low * (1.0 + sq.COST_TIE)))
        return finish(theta0, sub_info, lp, sub_c, i, certified)

    if objective != "distance":
        return [], full
    return [functools.partial(fast, K=min(k, C)) for k in top_k if k < C], full


def _smallest(values, k: int):
    """Indices of the ``k`` smallest ``values`` (ties: the lowest index first);
    ``k`` passes of argmin, cheaper than a sort for a few of many."""
    out = []
    ids = jnp.arange(values.shape[0])
    for _ in range(k):
        i = jnp.argmin(values)
        out.append(i)
        values = jnp.where(ids == i, jnp.inf, values)
    return jnp.stack(out)


def _assemble(g, c, theta0, ns, R, stable, drop, feasible):
    """The chosen candidate's pushes in execution order (arrays of ``R + 2``
    slots, no scatter: slot ``m`` holds a translation if one is placed there,
    else reorient push ``k(m)``, whose fields follow from ``k`` in closed form)."""
    p, q, n, r = c["pre_cnt"], c["post_cnt"], g["n"], g["r"]
    # at most two translation pushes: the LP's basic columns that do not extend a reorient;
    # execution order: reorient k, then the translations at orientation k by stable edge
    tr_live = jnp.stack([~g["mrg_a"] & (g["xa"] > drop), ~g["mrg_b"] & (g["xb"] > drop)]) & feasible
    tr_row = jnp.stack([g["row_a"], g["row_b"]])
    tr_key = tr_row * (ns + 1) + jnp.stack([g["col_a"], g["col_b"]])
    other_first = tr_live[::-1] & ((tr_key[::-1] < tr_key) | ((tr_key[::-1] == tr_key) & (jnp.arange(2) == 1)))
    pos_tr = jnp.where(tr_live, jnp.minimum(tr_row, r) + other_first, R + 2)
    m = jnp.arange(R + 2)
    is_tr = (m[:, None] == pos_tr[None, :]) & tr_live[None, :]          # (R + 2, 2)
    any_tr = jnp.any(is_tr, axis=1)
    k = m + 1 - jnp.sum(tr_live[None, :] & (pos_tr[None, :] < m[:, None]), axis=1)
    reo = ~any_tr & (k <= r) & feasible

    def theta_at(kk):
        km = kk - p
        kmf = km.astype(g["a_main"].dtype)
        return jnp.where(kk == 0, theta0, jnp.where((p > 0) & (kk == 1), g["theta_m0"], jnp.where(
            (q > 0) & (kk == p + n + 1), g["theta_fin"],
            jnp.where(km == n, g["theta_me"], g["theta_m0"] + g["s_main"] * kmf))))

    th, th_prev = theta_at(k), theta_at(k - 1)
    km = k - p
    is_pre = (p > 0) & (k == 1)
    is_post = (q > 0) & (k == p + n + 1)
    last = km == n
    on_a = km <= g["j"]
    lb = g["last_on_b"]

    def sel(pre, a, b, lst, post):
        return jnp.where(is_pre, pre, jnp.where(is_post, post, jnp.where(last, lst, jnp.where(on_a, a, b))))

    edge = sel(c["pre_e"], c["a"], c["b"], jnp.where(lb, c["b"], c["a"]), c["post_e"])
    piv = sel(c["pivP"], c["pivA"], c["pivB"], jnp.where(lb, c["pivB"], c["pivA"]), c["pivO"])
    need = sel(c["needP"], g["needA"], g["needB"], g["needL"], c["needO"])
    a_last = g["a_last"]
    least = sel(c["leastP"], _least(c["gA"], c["b2A"], g["a_main"]), _least(c["gB"], c["b2B"], g["a_main"]),
                jnp.where(lb, _least(c["gB"], c["b2B"], a_last), _least(c["gA"], c["b2A"], a_last)),
                c["leastO"])
    om = sel(c["omP"], c["omA"], c["omB"], jnp.where(lb, c["omB"], c["omA"]), c["omO"])
    ext = (jnp.where(g["mrg_a"] & (g["row_a"] == k), g["xa"], 0.0)
           + jnp.where(g["mrg_b"] & (g["row_b"] == k), g["xb"], 0.0))
    t1 = is_tr[:, 1]
    tr_ang = jnp.where(t1, g["ang_b"], g["ang_a"])
    tr_dist = jnp.where(t1, g["xb"], g["xa"])
    tr_edge = stable[jnp.where(t1, g["col_b"], g["col_a"])]
    used = reo | any_tr
    kind = jnp.where(any_tr, 1, jnp.where(reo, 2, 0))
    return dict(feasible=feasible, plan_class=c["cls"], turns=c["turns"], n_pushes=jnp.sum(used),
                kind=kind,
                angle=jnp.where(used, wrap_angle(jnp.where(any_tr, tr_ang, th + om)), 0.0),
                distance=jnp.where(any_tr, tr_dist, jnp.where(reo, need + ext, 0.0)),
                edge=jnp.where(any_tr, tr_edge, jnp.where(reo, edge, -1)),
                contact=jnp.where(reo, piv, -1),
                min_distance=jnp.where(reo, least, 0.0),
                rotation=jnp.where(reo, th - th_prev, 0.0))
