"""Benchmark: the pose planner's options on the bundled parts (issue 10).

Run by hand from the repository root (no assertions)::

    python bench/push_options.py                  # ~5 minutes on 2 cores
    python bench/push_options.py --goals 100 --mc 512 --physics 0

On every bundled polygon (``examples/*.yaml``), ``--goals`` seeded goals
within 15 cm of a start at the origin (uniform in the disc, any orientation;
margin 7 deg, safety factor 1.15: the setting of ``bench/push_planning.py``):

* **workspace**: ``plan_pose_batch(..., options=PushOptions(workspace=(-0.15, 0.15, -0.15, 0.15)))``
  (30 x 30 cm around the start).  Goals whose goal pose itself does not hold the
  part inside are set aside and counted.  Every plan's poses are checked inside
  here independently (part extent at each replayed pose); ``ws_ok`` is the
  fraction of the remaining goals that got a plan.  For the goals without one,
  the scale of the smallest workspace found (the planner's ``WorkspaceError``:
  the workspace scaled about its centre) says how much larger a table they need.
* **slip-aware**: the support range ``c`` of each part is the 5-95 % range of
  the default sampler's limit-surface ratio (16 support points, Dirichlet 1,
  centred under the centre of mass); plans with ``support`` only and with
  ``support`` + ``min_fence_mu=0.5`` are compared with the default (Peshkin)
  plans: which goals become more expensive with ``min_fence_mu`` and by how much.
* **quasi-static Monte Carlo**: each slip-aware plan (and, for comparison, each
  support-only plan) is evaluated (``robustness.evaluate``, model
  ``quasistatic``) on ``--mc`` samples of the NOMINAL part and execution, fence
  friction uniform in 0.5-0.8 and ``c`` uniform in the plan's support range;
  ``no_slip`` is the fraction of plans with no sample failing by slip.
* **MuJoCo** (C engine, open loop as a cell runs a plan): ``--physics`` slip-
  aware plans per part, each on the nominal part with fence friction 0.5 and
  0.8 and a support drawn by the default sampler with ``c`` inside the plan's
  range; ``mj_ok`` is the fraction of runs ending within 1 % of the start-goal
  distance and 1 degree of the goal.

Last line: ``RESULT ws_ok=F ws_fail_scale_median=S no_slip=F no_slip_support_only=F mj_ok=F
slip_aware_cost_median=R slip_aware_cost_max=R``.
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import os
import sys
import time
import warnings

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))   # the repository first: over bench/robustness.py
sys.path.append(os.path.dirname(__file__))

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402

from planning import (PushOptions, WorkspaceError, plan_pose, plan_pose_batch,  # noqa: E402
                      prepare_part)
from planning.pushing.workspace import part_extent  # noqa: E402
from push_planning import bundled_polygons, near_goals  # noqa: E402
from robustness import Draws, FrictionRange, Sampler, evaluate  # noqa: E402

WORKSPACE = (-0.15, 0.15, -0.15, 0.15)
MU_LO = 0.5
MU_F = (0.5, 0.8)


def support_range(verts, com, q=(0.05, 0.95), n=4096):
    """The ``q`` quantiles (m) of the default sampler's limit-surface ratio."""
    part = prepare_part(verts, com)
    s = Sampler(friction=FrictionRange(mu_f=MU_F))
    draws = s.sample(jax.random.key(1), n, n_vertices=len(verts), dim=2, n_pushes=1,
                     body=part.body, keep_support=False)
    par = draws.params
    lo, hi = np.quantile(np.asarray(par.friction.c), q)
    return float(lo), float(hi)


def inside(batch, ws, b) -> bool:
    """Every replayed pose of plan ``b`` holds the part inside ``ws`` (the start too)."""
    body = batch.part.body
    poses = [batch.starts[b]] + [p for p, k in zip(batch.pose_after[b], batch.kind[b]) if k > 0]
    if b in batch.replanned:
        poses = [batch.starts[b]] + [p.pose_after for p in batch.replanned[b].pushes]
    for p in poses:
        e = part_extent(body, float(p[2])) + np.repeat(np.asarray(p[:2], float), 2)
        if e[0] < ws[0] - 1e-9 or e[1] > ws[1] + 1e-9 or e[2] < ws[2] - 1e-9 or e[3] > ws[3] + 1e-9:
            return False
    return True


def workspace_rows(parts, starts, goals):
    rows = []
    straight = np.hypot(goals[:, 0], goals[:, 1])
    for name, (verts, com, cls) in parts.items():
        body = prepare_part(verts, com).body
        fits = np.array([inside_pose(body, g, WORKSPACE) for g in goals])
        t0 = time.perf_counter()
        b = plan_pose_batch(verts, starts[fits], goals[fits], com=com,
                            options=PushOptions(workspace=WORKSPACE))
        secs = time.perf_counter() - t0
        free = plan_pose_batch(verts, starts[fits], goals[fits], com=com)
        ok_in = np.array([bool(b.ok[i]) and inside(b, WORKSPACE, i) for i in range(len(b))])
        ratio = b.total_distance[b.ok] / straight[fits][b.ok]
        scales = []   # the failed goals: the least scale of the workspace the planner's error names
        for i in np.flatnonzero(~b.ok):
            try:
                plan_pose(verts, starts[fits][i], goals[fits][i], com=com,
                          options=PushOptions(workspace=WORKSPACE))
                scales.append(1.0)
            except WorkspaceError as err:
                scales.append(err.scale)
        rows.append(dict(part=name, cls=cls, goals=int(fits.sum()), set_aside=int((~fits).sum()),
                         ok=float(ok_in.mean()), replanned=len(b.replanned), secs=secs, scales=np.array(scales),
                         median=float(np.median(ratio)),
                         median_free=float(np.median(free.total_distance / straight[fits]))))
    return rows


def inside_pose(body, pose, ws) -> bool:
    e = part_extent(body, float(pose[2])) + np.repeat(np.asarray(pose[:2], float), 2)
    return bool(e[0] >= ws[0] and e[1] <= ws[1] and e[2] >= ws[2] and e[3] <= ws[3])


def slip_rows(parts, starts, goals, n_mc, seed):
    """Plans with support only and slip-aware, their costs, and the Monte Carlo."""
    rows = []
    for name, (verts, com, cls) in parts.items():
        c = support_range(verts, com)
        base = plan_pose_batch(verts, starts, goals, com=com)
        sup = plan_pose_batch(verts, starts, goals, com,
                              options=PushOptions(support={"c": list(c)}))
        slip = plan_pose_batch(verts, starts, goals, com,
                               options=PushOptions(support={"c": list(c)}, min_fence_mu=MU_LO))
        both = sup.ok & slip.ok
        rel = slip.total_distance[both] / sup.total_distance[both]
        sampler = Sampler(friction=FrictionRange(mu_f=MU_F, c=c))
        mc = {}
        t0 = time.perf_counter()
        for tag, batch in (("slip", slip), ("sup", sup)):
            fails, maxslip = [], []
            for i in np.flatnonzero(batch.ok):
                ev = evaluate(batch.plan(int(i)), sampler, n_mc, jax.random.key(seed + int(i)),
                              model="quasistatic", bound=False)
                df = ev.samples
                fails.append(int((df["failure_mode"] == "slip").sum()))
                maxslip.append(float(df["slip_m"].max()))
            mc[tag] = (np.array(fails), np.array(maxslip))
        rows.append(dict(part=name, cls=cls, c=c, ok_sup=float(sup.ok.mean()), ok_slip=float(slip.ok.mean()),
                         rel=rel, dearer=float(np.mean(rel > 1 + 1e-6)) if len(rel) else math.nan,
                         vs_default=_median(slip.total_distance[slip.ok & base.ok]
                                            / base.total_distance[slip.ok & base.ok]),
                         sup_vs_default=_median(sup.total_distance[sup.ok & base.ok]
                                                / base.total_distance[sup.ok & base.ok]),
                         mc=mc, mc_secs=time.perf_counter() - t0, batch=slip, verts=verts, com=com))
    return rows


def _median(x) -> float:
    return float(np.median(x)) if len(x) else math.nan


def physics_rows(srows, goals_per_part, seed):
    """Open-loop MuJoCo rollouts of a few slip-aware plans per part."""
    from kernels import polygon as pg
    from robustness.physics import rollout_push_plan

    out = []
    for r in srows:
        batch, (lo, hi) = r["batch"], r["c"]
        for i in np.flatnonzero(batch.ok)[:goals_per_part]:
            plan = batch.plan(int(i))
            body = pg.make_polygon(np.asarray(plan.vertices), np.asarray(plan.com)).body
            sam = Sampler(friction=FrictionRange(mu_f=MU_F))
            draws = sam.sample(jax.random.key(seed + int(i)), 64, n_vertices=len(plan.vertices), dim=2,
                               n_pushes=plan.n_pushes, body=body)
            p, ax = draws.params, draws.in_axes
            cs = np.asarray(p.friction.c)
            j = int(np.flatnonzero((cs >= lo) & (cs <= hi))[0])   # a support whose c is in the range
            f = p.friction
            f2 = jax.tree_util.tree_map(   # sample j's support (every batched field), twice
                lambda x, a: x if a is None else jnp.repeat(x[j:j + 1], 2, axis=0), f, ax.friction,
                is_leaf=lambda x: x is None)
            f2 = dataclasses.replace(f2, mu_f=jnp.asarray(MU_F))
            params = dataclasses.replace(p, friction=f2)   # nominal part: only friction is batched
            t0 = time.perf_counter()
            res = rollout_push_plan(plan, Draws(params, ax, 2), backend="c")
            straight = math.hypot(plan.goal[0] - plan.start[0], plan.goal[1] - plan.start[1])
            ok = (res.err_pos <= 0.01 * straight) & (np.abs(res.err_theta) <= math.radians(1.0))
            out.append(dict(part=r["part"], goal=int(i), ok=ok.tolist(), err_mm=(res.err_pos * 1e3).tolist(),
                            err_deg=np.degrees(np.abs(res.err_theta)).tolist(),
                            slip_mm=(np.asarray(res.slip) * 1e3).tolist(), straight=straight,
                            mode=list(res.failure_mode), secs=time.perf_counter() - t0))
            print(f"  mujoco {r['part']:<14} goal {i}: ok {ok.astype(int).tolist()}, err "
                  f"{np.round(res.err_pos * 1e3, 2).tolist()} mm of {straight * 1e3:.0f} mm, "
                  f"{np.round(np.degrees(np.abs(res.err_theta)), 3).tolist()} deg, slip "
                  f"{np.round(np.asarray(res.slip) * 1e3, 3).tolist()} mm, {out[-1]['secs']:.0f} s",
                  flush=True)
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--goals", type=int, default=40, help="goals per bundled part")
    ap.add_argument("--mc", type=int, default=256, help="quasi-static samples per plan")
    ap.add_argument("--physics", type=int, default=5, help="slip-aware plans per part rolled out in MuJoCo")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    parts = bundled_polygons()
    starts, goals = near_goals(args.goals, seed=args.seed)

    wrows = workspace_rows(parts, starts, goals)
    print(f"workspace 30 x 30 cm around the start, {args.goals} goals within 15 cm")
    print(f"{'part':<16}{'class':<15}{'goals':>6}{'aside':>6}{'ok':>8}{'numpy':>7}{'median':>8}"
          f"{'free':>7}{'s':>7}   failed: scale of the smallest workspace found (min / median / max)")
    for r in wrows:
        sc = np.quantile(r["scales"], [0.0, 0.5, 1.0]) if len(r["scales"]) else None
        print(f"{r['part']:<16}{r['cls']:<15}{r['goals']:>6}{r['set_aside']:>6}{r['ok']:>8.1%}"
              f"{r['replanned']:>7}{r['median']:>8.2f}{r['median_free']:>7.2f}{r['secs']:>7.1f}   "
              + ("-" if sc is None else f"{sc[0]:.3f} / {sc[1]:.3f} / {sc[2]:.3f}"))
    n_ws = sum(r["goals"] for r in wrows)
    ws_ok = sum(r["ok"] * r["goals"] for r in wrows) / n_ws

    srows = slip_rows(parts, starts, goals, args.mc, args.seed)
    print(f"\nslip-aware plans: min_fence_mu {MU_LO}, support c = 5-95 % of the default sampler; "
          f"quasi-static MC {args.mc} samples/plan, mu_f {MU_F}, c uniform in the range, nominal part")
    print(f"{'part':<16}{'c range mm':>14}{'ok':>7}{'dearer':>8}{'x med':>7}{'x p90':>7}{'x max':>8}"
          f"{'vs peshkin':>11}{'no-slip':>9}{'(sup only)':>11}{'max slip mm':>12}{'s':>6}")
    allrel, ns, nsup, tot, totsup = [], 0, 0, 0, 0
    for r in srows:
        rel = r["rel"]
        allrel += rel.tolist()
        f, ms = r["mc"]["slip"]
        fs, _ = r["mc"]["sup"]
        ns += int(np.sum(f == 0)); tot += len(f)
        nsup += int(np.sum(fs == 0)); totsup += len(fs)
        q = np.quantile(rel, [0.5, 0.9, 1.0]) if len(rel) else np.full(3, math.nan)
        print(f"{r['part']:<16}{r['c'][0] * 1e3:>6.2f}-{r['c'][1] * 1e3:<7.2f}{r['ok_slip']:>7.1%}"
              f"{r['dearer']:>8.1%}{q[0]:>7.2f}{q[1]:>7.2f}{q[2]:>8.2f}"
              f"{r['vs_default']:>11.2f}{np.mean(f == 0):>9.1%}{np.mean(fs == 0):>11.1%}"
              f"{(ms.max() if len(ms) else math.nan) * 1e3:>12.4f}{r['mc_secs']:>6.0f}")
    print("  (dearer: fraction of goals whose slip-aware plan is longer than the support-only one; "
          "x: slip-aware / support-only length; vs peshkin: median slip-aware / default length)")
    for r in srows:
        print(f"  {r['part']}: support-only plans are {r['sup_vs_default']:.2f}x the default (median); "
              f"{r['ok_sup']:.0%} planned with support only, {r['ok_slip']:.0%} slip-aware")

    prow = physics_rows(srows, args.physics, args.seed) if args.physics > 0 else []
    runs = [o for p in prow for o in p["ok"]]
    mj_ok = float(np.mean(runs)) if runs else math.nan
    allrel = np.array(allrel)
    fail_scales = np.concatenate([r["scales"] for r in wrows])
    print(f"RESULT ws_ok={ws_ok:.4f} ws_fail_scale_median={_median(fail_scales):.3f} no_slip={ns / max(tot, 1):.4f} "
          f"no_slip_support_only={nsup / max(totsup, 1):.4f} mj_ok={mj_ok:.3f} "
          f"slip_aware_cost_median={_median(allrel):.3f} "
          f"slip_aware_cost_max={allrel.max() if len(allrel) else math.nan:.3f}")


if __name__ == "__main__":
    main()
