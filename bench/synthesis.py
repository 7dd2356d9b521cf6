"""Benchmark of robust plan synthesis and tolerance design (``robustness.synthesis``,
``robustness.tolerance_design``): the default plan against the synthesized one.

Run by hand from the repository root (no assertions)::

    python bench/synthesis.py                       # ~20 min on 2 cores
    python bench/synthesis.py --mujoco-samples 0    # the kinematic model only
    python bench/synthesis.py --model quasistatic   # the fast approximation chooses

Tasks: the two tasks of ``examples/certify_triangle.yaml`` (a translation and
a 60-degree turn, their positions scaled by the part's size against the
triangle's) on every bundled polygon (rectangle, nice-stable, biplus-stable,
uni-stable), with that config's tolerances and robot errors and fence friction
uniform in [0.5, 0.8] (support ``any``).  For each task:

* the default plan (the configured planner, ``plan_pose``) and the synthesized
  one (``synthesize``: the default grid, at most 64 candidates, 1,000 selection
  draws of ``selection_key``);
* synthesized and evaluated under ``--model`` (default: the default model,
  ``robustness.DEFAULT_MODEL``, the exact limit surface);
* both evaluated on the same ``--fresh`` FRESH draws of that model (not the
  selection's): the one-sided Clopper-Pearson lower bound of success at 95 %;
* both rolled out in MuJoCo (C engine, ``--mujoco-samples`` fresh draws, 48 by
  default): the success rate and its standard error (a check that the choice
  holds in physics, not a certificate);
* the push distance ratio (synthesized / default) and the synthesis time
  (candidates + scoring, warm; with ``--physics-samples N`` the selection's
  tie is broken in MuJoCo on N draws, ``robustness.physics_tiebreak``, and its
  rollouts are counted);
* as ``nudge certify --synthesize`` does by default, a choice other than the
  default plan is confirmed in MuJoCo against it on ``--veto-samples`` (24)
  common draws of another key (``robustness.physics_veto``): where the chosen
  plan does worse by more than two standard errors of the paired difference,
  the default plan is kept (those rollouts are timed apart; 0: the
  kinematic model's choice alone, as before the veto).

``--only rectangle,nice_stable`` runs some parts; ``--no-design`` skips the
one-task timing and the design.

Then one task timed alone: 64 candidates x 1,000 samples (candidate generation
and the one compiled scoring call, warm), and the tolerance design of its
synthesized plan, 6 axes (warm).

The last line is ``RESULT model=... gain_model=G gain_mujoco=M length_ratio=L
seconds_per_task=S`` (``gain_model``: the median over tasks of the synthesized
minus the default plan's lower bound on the fresh draws of the model;
``gain_mujoco``: the mean over tasks of the difference of the MuJoCo success
rates; ``length_ratio``: the median distance ratio; ``seconds_per_task``: the
median synthesis time) with ``tasks_not_worse_model``, ``tasks_not_worse_mujoco``,
``tasks_worse_2se_mujoco`` (tasks whose synthesized plan does worse in MuJoCo
than the default by more than two standard errors of the difference),
``one_task_s`` and ``design_s``.

Measured 2026-12-06 under the default model (``limit_surface``, 8 quadrature
panels), 48 MuJoCo rollouts a plan, CPU (2 cores, quiet), the eight task rows
(the one-task timing and the design were not reached: stopped at 31 min)::

    rectangle      translate   CP low 0.9985 -> 0.9985   MuJoCo 1.000 -> 1.000   14.8 s
    rectangle      turn        CP low 0.2131 -> 0.9985   MuJoCo 1.000 -> 0.438    7.7 s
    nice_stable    translate   CP low 0.9985 -> 0.9985   MuJoCo 1.000 -> 1.000   16.5 s
    nice_stable    turn        CP low 0.7745 -> 0.9985   MuJoCo 0.979 -> 0.583    7.6 s
    biplus_stable  translate   CP low 0.9985 -> 0.9985   MuJoCo 0.000 -> 0.000   69.8 s
    biplus_stable  turn        CP low 0.0000 -> 0.9724   MuJoCo 0.000 -> 0.854   17.2 s
    unistable      translate   CP low 0.0000 -> 0.9985   MuJoCo 0.000 -> 0.000  137.9 s
    unistable      turn        CP low 0.3610 -> 0.3893   MuJoCo 0.000 -> 0.000  155.2 s

that is ``gain_model=0.126 gain_mujoco=-0.013 length_ratio=1.10
seconds_per_task=16.9 tasks_not_worse_model=8 tasks_not_worse_mujoco=6
tasks_worse_2se_mujoco=2``.  The faithful model did not remove the
disagreement the ellipsoid had: the turns of the rectangle and the
nice-stable pentagon are the two tasks worse in physics, as under
``quasistatic`` (there 12/12 -> 8/12 and 11/12 -> 9/12); the model calls the
rectangle's default turn poor (0.21) where MuJoCo succeeds 48/48.  It wins
one in physics the ellipsoid could not judge (biplus-stable's turn, 0 ->
0.85), and on the long plans (9-18 pushes, 0.5-0.7 m) MuJoCo fails both
plans where the model gives 0.9985.

Again with a batch's compiled calls on both cores (``robustness.replay``),
``--mujoco-samples 0``, quiet machine: the same choices (CP lows as above),
seconds per task 10.5, 4.5, 8.6, 4.0, 29.5, 10.3, 78.1, 77.9 (were 14.8, 7.7,
16.5, 7.6, 69.8, 17.2, 137.9, 155.2)::

    RESULT model=limit_surface gain_model=0.1261 gain_mujoco=nan length_ratio=1.099
    seconds_per_task=10.42 tasks_not_worse_model=8/8 tasks_not_worse_mujoco=0/0
    tasks_worse_2se_mujoco=0 one_task_s=10.07 design_s=71.37

(the one task: biplus-stable's turn, 8 candidates x 1,000 samples; the design:
6 axes, 65 evaluations of 1,000 samples).  With the limit surface's solves
stopping once settled and its sliding steps gathered (December 2026; ``--no-design
--mujoco-samples 0 --veto-samples 0``, quiet machine): the same choices and CP
lows, seconds per task 5.19, 2.36, 4.84, 1.85, 19.99, 6.11, 53.17, 59.65::

    RESULT model=limit_surface gain_model=0.1261 gain_mujoco=nan length_ratio=1.099
    seconds_per_task=5.65 tasks_not_worse_model=8/8 tasks_not_worse_mujoco=0/0
    tasks_worse_2se_mujoco=0 one_task_s=nan design_s=nan

With a batch's compiled calls spread over a CPU device per core (December 2026,
``robustness.replay``; the script now sets ``JAX_NUM_CPU_DEVICES`` to the cores as
the command lines do; ``--no-design --mujoco-samples 0 --veto-samples 0``, quiet
machine), the same session on one device and on two: seconds per task 5.78 /
3.12, 2.70 / 1.54, 5.38 / 2.99, 2.24 / 1.33, 12.39 / 6.99, 4.80 / 2.97, 31.51 /
18.05, 37.66 / 21.31, the same choices and CP lows::

    RESULT model=limit_surface gain_model=0.1419 gain_mujoco=nan length_ratio=1.099
    seconds_per_task=3.05 tasks_not_worse_model=8/8 tasks_not_worse_mujoco=0/0
    tasks_worse_2se_mujoco=0 one_task_s=nan design_s=nan

(one device: ``seconds_per_task=5.58``).  The CP lows
moved since the runs above (rectangle turn 0.2131 -> 0.1931, nice-stable turn
0.7745 -> 0.7330, its synthesized plan now 8 pushes, 0.249 m): the previous commit
(e159560) gives the same lows and choices on the same draws, so the move predates
the spread (the pad's and rim's feet, ``kernels.support.FEET_AT_CORNERS``, came
between).

The runs above are without the physics veto (``--veto-samples 0``).  With it
(24 common draws, the default), 48 MuJoCo rollouts a plan, 2 cores shared with
a test run, in two runs (``--only rectangle,nice_stable,biplus_stable
--no-design``, then ``--only unistable --no-design``)::

    rectangle      translate   CP low 0.9985 -> 0.9985   MuJoCo 1.000 -> 1.000   19.3 s
    rectangle      turn        CP low 0.2131 -> 0.2131   MuJoCo 1.000 -> 1.000    7.2 s  veto: 10/24 vs 23/24, default kept
    nice_stable    translate   CP low 0.9985 -> 0.9985   MuJoCo 1.000 -> 1.000   14.5 s
    nice_stable    turn        CP low 0.7745 -> 0.7745   MuJoCo 0.979 -> 0.979    5.5 s  veto: 9/24 vs 23/24, default kept
    biplus_stable  translate   CP low 0.9985 -> 0.9985   MuJoCo 0.000 -> 0.000   37.3 s  veto: 0/24 vs 0/24, confirmed
    biplus_stable  turn        CP low 0.0000 -> 0.9724   MuJoCo 0.000 -> 0.854   10.1 s  veto: 21/24 vs 0/24, confirmed
    unistable      translate   CP low 0.0000 -> 0.9985   MuJoCo 0.000 -> 0.000   86.3 s  veto: 0/24 vs 0/24, confirmed
    unistable      turn        CP low 0.3610 -> 0.3893   MuJoCo 0.000 -> 0.000  102.4 s  veto: 0/24 vs 0/24, confirmed

the eight tasks (combined by hand from the two RESULT lines): ``gain_model=0.000
gain_mujoco=0.107 length_ratio=1.000 seconds_per_task=16.9 tasks_not_worse_model=8/8
tasks_not_worse_mujoco=8/8 tasks_worse_2se_mujoco=0`` (the seconds under load, not
comparable with the quiet 10.4 above; the selection did not change).
The two choices physics made worse (the rectangle's and the nice-stable
pentagon's turns: the synthesized plans 21/48 and 28/48 in MuJoCo against
48/48 and 47/48) are now caught by the veto's own 24 draws (10/24 and 9/24
against 23/24) and the default plans kept; the choice physics confirms
(biplus-stable's turn, 0 -> 0.854) stays.  The price: the kinematic model's
gain on those two tasks is given up (``gain_model`` 0.126 -> 0.000: their
default plans' CP lows 0.21 and 0.77 are what the certificate then says,
beside the MuJoCo confirmation, which flags the disagreement where the two
intervals part), 48 MuJoCo rollouts per task whose choice is not the
default, and nothing where the model chose the default.
"""
from __future__ import annotations

import argparse
import os
import pathlib
import statistics
import sys
import time
import warnings

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
os.environ.setdefault("JAX_PLATFORMS", "cpu")
# a CPU device per core, as the command lines (robustness.replay.replay_devices)
os.environ.setdefault("JAX_NUM_CPU_DEVICES", str(len(os.sched_getaffinity(0))))

PARTS = ("rectangle", "nice_stable", "biplus_stable", "unistable")


def _sampler():
    from robustness import ExecutionTolerance, FrictionRange, GeometryTolerance, Sampler

    return Sampler(GeometryTolerance(tau_v=2e-5, tau_com=1e-4),
                   FrictionRange(mu_f=(0.5, 0.8), mu_s=(0.2, 0.5), support="any"),
                   ExecutionTolerance(start_xy=5e-4, start_theta=0.01, fence_angle=0.002,
                                      distance_abs=1e-4, distance_rel=0.005))


def _size(v):
    import numpy as np

    v = np.asarray(v, float)
    return float(np.max(np.linalg.norm(v[:, None] - v[None], axis=-1)))


def main() -> int:
    import jax
    import numpy as np

    from planning import plan_pose
    from robustness import (DEFAULT_MODEL, Requirement, Selection, SuccessCriterion, evaluate,
                            one_sided_lower, physics_tiebreak, physics_veto, selection_key,
                            synthesize, tiebreak_key, veto_key)
    from sweeps.executors import enable_compilation_cache
    from sweeps.study import load_part_ref

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", default=DEFAULT_MODEL, choices=("limit_surface", "quasistatic"),
                    help="the kinematic model that synthesizes and evaluates")
    ap.add_argument("--fresh", type=int, default=2000, help="fresh draws of the model per plan")
    ap.add_argument("--mujoco-samples", type=int, default=48, help="MuJoCo rollouts per plan")
    ap.add_argument("--veto-samples", type=int, default=24,
                    help="confirm a choice other than the default plan in MuJoCo against it on "
                         "this many common draws (robustness.physics_veto; the product's "
                         "default, synthesize.veto_samples); 0: the kinematics alone")
    ap.add_argument("--only", help="comma-separated parts (default: all four)")
    ap.add_argument("--no-design", action="store_true",
                    help="skip the one-task timing and the tolerance design")
    ap.add_argument("--physics-samples", type=int, default=0,
                    help="break the selection's tie in MuJoCo on this many draws "
                         "(robustness.physics_tiebreak, 4 candidates); 0: the kinematics alone")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    enable_compilation_cache()
    sampler = _sampler()
    eps = dict(criterion=SuccessCriterion(pos_eps_m=0.003, theta_eps_rad=0.05))
    req = Requirement(0.9, 0.95, **eps)
    model = args.model
    tri = load_part_ref("biplus_stable", ROOT / "examples")
    ref = _size(tri.vertices)
    tasks = (("translate", (0.08, 0.03, 0.0)), ("turn", (0.10, 0.05, np.pi / 3)))
    rows = []
    print(f"{'part':14s} {'task':10s} {'K':>3s} {'default':>24s} {'synthesized':>24s} "
          f"{'CP low def':>10s} {'CP low syn':>10s} {'mj def':>7s} {'mj syn':>7s} "
          f"{'length':>7s} {'s':>6s}")
    for name in (args.only.split(",") if args.only else PARTS):
        part = load_part_ref(name, ROOT / "examples")
        k = _size(part.vertices) / ref
        for ti, (task, goal) in enumerate(tasks):
            goal = (goal[0] * k, goal[1] * k, goal[2])
            key = jax.random.fold_in(jax.random.key(0), 10 * PARTS.index(name) + ti)
            default = plan_pose(part.vertices, (0.0, 0.0, 0.0), goal, part.com)
            sel = Selection(sampler, 1000, selection_key(key))
            synthesize(part.vertices, (0, 0, 0), goal, part.com, selection=sel, requirement=req,
                       model=model)         # warm-up
            t0 = time.perf_counter()
            syn = synthesize(part.vertices, (0, 0, 0), goal, part.com, selection=sel,
                             requirement=req, model=model)
            if args.physics_samples:
                syn = physics_tiebreak(syn, sampler, args.physics_samples,
                                       tiebreak_key(key), **eps)
            dt = time.perf_counter() - t0
            veto = ""
            if args.veto_samples:             # rollouts: timed apart
                syn = physics_veto(syn, sampler, args.veto_samples, veto_key(key), **eps)
                if syn.veto is not None:
                    k0, kc, nv, vetoed = syn.veto
                    veto = f"  veto check {kc}/{nv} vs default {k0}/{nv}: " + \
                        ("default kept" if vetoed else "choice confirmed")
            fresh = jax.random.fold_in(key, 1)
            lows = []
            for plan in (default, syn.plan):
                ev = evaluate(plan, sampler, args.fresh, fresh, model=model, **eps)
                lows.append(one_sided_lower(int(np.sum(ev.columns["success"])), args.fresh, 0.95))
            mj = [float("nan"), float("nan")]
            if args.mujoco_samples:
                for j, plan in enumerate((default, syn.plan)):
                    ev = evaluate(plan, sampler, args.mujoco_samples, jax.random.fold_in(key, 2),
                                  model="mujoco", **eps)
                    mj[j] = float(np.mean(ev.columns["success"]))
            ratio = syn.plan.total_distance / default.total_distance
            rows.append(dict(part=name, task=task, K=len(syn.candidates), low=lows, mj=mj,
                             ratio=ratio, s=dt))
            d = f"{default.n_pushes} pushes {default.total_distance:.3f} m"
            s = f"{syn.plan.n_pushes} pushes {syn.plan.total_distance:.3f} m"
            print(f"{name:14s} {task:10s} {len(syn.candidates):3d} {d:>24s} {s:>24s} "
                  f"{lows[0]:10.4f} {lows[1]:10.4f} {mj[0]:7.3f} {mj[1]:7.3f} {ratio:7.3f} "
                  f"{dt:6.2f}{veto}", flush=True)
    one = design_s = float("nan")
    if not args.no_design:
        one, design_s = _one_task(args, sampler, req, model, tasks)
    _result(args, rows, model, one, design_s)
    return 0


def _one_task(args, sampler, req, model, tasks):
    """One task alone: 64 candidates x 1000 samples, warm; then its tolerance
    design (warm).  Returns their seconds."""
    import jax

    from robustness import Selection, selection_key, synthesize
    from robustness import tolerance_design as td
    from sweeps.study import load_part_ref

    part = load_part_ref("biplus_stable", ROOT / "examples")
    goal = tasks[1][1]
    key = jax.random.key(7)
    t0 = time.perf_counter()
    syn = synthesize(part.vertices, (0, 0, 0), goal, part.com,
                     selection=Selection(sampler, 1000, selection_key(key)), requirement=req,
                     limit=64, model=model)
    one = time.perf_counter() - t0

    def design():
        judge = td.Judge(syn.plan, 1000, td.design_key(key), req, model)
        ds = [td.loosest(judge, sampler, a) for a in td.PUSH_AXES]
        td.sensitivity(judge, sampler, td.PUSH_AXES)
        td.joint_design(judge, sampler, ds, jax.random.fold_in(td.design_key(key), 1))
        return judge.calls

    design()                                       # warm-up (its compilations)
    t0 = time.perf_counter()
    calls = design()
    design_s = time.perf_counter() - t0
    print(f"\none task (biplus_stable turn): {len(syn.candidates)} candidates x 1000 samples "
          f"in {one:.2f} s (warm); tolerance design, 6 axes, {calls} evaluations of 1000 "
          f"samples: {design_s:.2f} s (warm)")
    return one, design_s


def _result(args, rows, model, one, design_s):
    gq = [r["low"][1] - r["low"][0] for r in rows]
    gm = [r["mj"][1] - r["mj"][0] for r in rows]
    n_mj = max(args.mujoco_samples, 1)
    se = [((r["mj"][0] * (1 - r["mj"][0]) + r["mj"][1] * (1 - r["mj"][1])) / n_mj) ** 0.5
          for r in rows]
    worse_q = sum(g >= -1e-12 for g in gq)
    worse_m = sum(g >= -1e-12 for g in gm if g == g)
    worse_2se = sum(g < -2 * s for g, s in zip(gm, se) if g == g)
    med = lambda xs: statistics.median(xs) if xs else float("nan")  # noqa: E731
    mean = lambda xs: statistics.fmean(xs) if xs else float("nan")  # noqa: E731
    print(f"\nRESULT model={model} gain_model={med(gq):.4f} "
          f"gain_mujoco={mean([g for g in gm if g == g]):.4f} "
          f"length_ratio={med([r['ratio'] for r in rows]):.3f} "
          f"seconds_per_task={med([r['s'] for r in rows]):.2f} "
          f"tasks_not_worse_model={worse_q}/{len(rows)} "
          f"tasks_not_worse_mujoco={worse_m}/{sum(g == g for g in gm)} "
          f"tasks_worse_2se_mujoco={worse_2se} one_task_s={one:.2f} design_s={design_s:.2f}")


if __name__ == "__main__":
    sys.exit(main())
