"""Benchmark: certificates that predict physics (calibration, issue 38).

Run by hand from the repository root (no assertions)::

    python bench/calibration.py --quick     # 20 rollouts per plan, small selection
    python bench/calibration.py             # >= 100 rollouts per certified plan
    python bench/calibration.py --stroke contact --supports rigid

Task: the ``turn`` task of ``examples/certify_triangle.yaml`` (start
``(0, 0, 0)``, goal ``(0.10, 0.05, 60 deg)``, positions scaled by the part's size
against the triangle's, as in ``bench/synthesis.py``) on every bundled polygon
(rectangle, nice-stable, biplus-stable, uni-stable), with that config's
tolerances, robot errors, eps (3 mm, 0.05 rad) and requirement (p >= 0.9 at
95 %).  One cell per fence friction ``mu_f`` in 0.5 / 0.8 / 1.5 (a point
range: the cell's fence is that fence) and support family ``rigid`` / ``any``
(``robustness.FrictionRange.support``).  In each cell two plans:

* ``default``: the configured planner's plan (``plan_pose``, the same in every
  cell);
* ``synth``: robust synthesis as ``nudge certify --synthesize`` runs it
  (``robustness.synthesize`` with the cell's grid, ``sweeps.config.Synthesize``:
  Peshkin's and the support family's distance rules, slip-aware variants at the
  cell's fence friction), scored under ``--syn-model`` (default the faithful
  model) on ``--select`` draws of ``selection_key(key)``, at most
  ``--candidates`` candidates.  When it chose the default plan it is marked
  ``=default`` and shares its certificates and rollouts.

Each plan is certified (``robustness.certify``, ``n_samples="auto"``: the
sequential Bonferroni schedule, at most ``--max-samples``) under the faithful
model (``model="limit_surface"``, the exact limit surface of the drawn support
points) and under the fast one (``model="quasistatic"``), on the cell's key
``fold_in(key(0), cell)``.  Every plan either model certified is rolled out in
MuJoCo (C engine, CPU; ``evaluate(model="mujoco")``, ``PhysicsRun(stroke=
--stroke)``: ``planned`` is the library's default, the cell running the plan
open loop; ``contact`` measures every stroke from where the part is, the
models' semantics) on ``--rollouts`` FRESH draws of another key
(``fold_in(key(1), cell)``), judged by the same eps.  A certified plan whose
MuJoCo success rate falls below 0.9 is a calibration failure (``FAIL``; ``FAIL*``
when even the two-sided 95 % Clopper-Pearson upper bound is below 0.9).  The
limit-surface model is also replayed on the rollouts' own draws (``ls@mj``: its
success there, and ``ls ok/mj fail``: draws it calls a success that physics
fails), and the physics failure modes and slip are listed.

The last line is ``RESULT certified=N calibration_failures=F
calibration_failure_rate=R mujoco_success_certified=S qs_certified=Q
qs_calibration_failures=QF`` (N: plans certified under ``limit_surface``, each
distinct plan of a cell once; R = F / N; S: the pooled MuJoCo success of those
plans; Q, QF: the same under ``quasistatic``) with ``rollouts`` per plan and
``stroke``.

Measured 2026-12-06, CPU (2 cores shared with two other engineers' jobs, no
GPU), the C engine, stroke ``planned``, 16 candidates x 100 selection draws
under ``limit_surface``:

* ``--quick`` (20 rollouts per plan; 1,466 s cold: synthesis 614 s, certificates
  310 s, MuJoCo 365 s)::

    RESULT certified=20 calibration_failures=3 calibration_failure_rate=0.150
    mujoco_success_certified=0.963 qs_certified=29 qs_calibration_failures=9

* full (100 rollouts per limit-surface-certified plan, 40 per plan only the
  quasistatic model certified; 1,459 s: synthesis 522 s, certificates 101 s, MuJoCo 734 s)::

    RESULT certified=20 calibration_failures=3 calibration_failure_rate=0.150
    mujoco_success_certified=0.960 qs_certified=29 qs_calibration_failures=9

What it shows: the faithful model misses the issue's goal (<= 5 %): 3 of 20
certified plans fail, all on rigid support at 82/100 (CP upper 0.890):
nice-stable at mu_f 0.8 (default and synthesized, nearly the same plan) and the
uni-stable synthesized plan at 0.5.  On those draws the limit-surface model
predicts 100/100 with zero fence slip; MuJoCo slips 3-19 mm along the fence on
most draws (not explained by the drawn c or support friction), and the open-loop
cell hides much of it (nice-stable 0.8 rigid, 30 draws: 26/30 planned strokes,
13/30 contact strokes).  The quasistatic model is far worse: 9 of 29 fail, five
of them 0/40 (biplus-stable default at 0.5/0.8 rigid: slip; uni-stable default
at 0.8/1.5 rigid: fence strikes), plans the limit-surface model rightly refused.
The limit-surface model is also pessimistic: the rectangle's default plan at
0.5/0.8 rigid (LS 0/49, MuJoCo 40/40).

With the physics veto (``--veto-samples 24``, the default since December 2026,
as ``nudge certify --synthesize`` runs it: a synthesized choice MuJoCo
contradicts against the default plan on 24 common draws keeps the default
plan), ``--no-qs``, full (1,376 s: synthesis 224 s, certificates 124 s, MuJoCo
972 s with the veto's rollouts)::

    RESULT certified=20 calibration_failures=3 calibration_failure_rate=0.150
    mujoco_success_certified=0.960 rollouts=100 stroke=planned

The veto fired in three cells (the rectangle at 0.5 and 0.8 and the
nice-stable pentagon at 0.5, support ``any``: 1/24, 11/24 and 6/24 against the
default plan's 24/24), each a synthesized plan the model did not certify
either, so the calibration is unchanged: the same three failures, two of them
a default plan (nice-stable at 0.8 rigid, the synthesized plan nearly the
same) and the uni-stable synthesized plan at 0.5 rigid, where the veto saw no
contradiction (the default plan, CP low 0.27 under the model, did not do
better by two standard errors on the veto's 24 draws).

After the pad and rim stood on their feet alone (December 2026,
``kernels.support.FEET_AT_CORNERS``; only the ``any`` cells can change),
``--no-qs``, full (1,527 s beside other work: synthesis 249 s, certificates
149 s, MuJoCo 1,001 s)::

    RESULT certified=20 calibration_failures=3 calibration_failure_rate=0.150
    mujoco_success_certified=0.960 rollouts=100 stroke=planned

As many plans certified and the same three failures (rigid support: the
nice-stable pentagon's two plans at 0.8 and the uni-stable synthesized plan
at 0.5, 82/100 each); in the ``any`` cells MuJoCo gives the certified plans
96/100 (the nice-stable pentagon at 0.8) and 100/100, and the veto fires in
the same three cells (1/24, 12/24 and 6/24 against the default's 24/24).

With a batch's compiled calls spread over a CPU device per core (December 2026;
the script sets ``JAX_NUM_CPU_DEVICES`` as the command lines do), ``--no-qs``, full,
quiet machine (1,010 s: synthesis 174 s, certificates 99 s, MuJoCo 671 s)::

    RESULT certified=20 calibration_failures=3 calibration_failure_rate=0.150
    mujoco_success_certified=0.960 rollouts=100 stroke=planned

The same three failures at 82/100 each (the limit surface 100/100 on the same
draws; slips of 14-16 mm median on the failures), the veto in the same three cells.
"""
from __future__ import annotations

import argparse
import math
import os
import pathlib
import sys
import time
import warnings

ROOT = pathlib.Path(__file__).resolve().parents[1]
# first, even when ROOT is already on PYTHONPATH: the package ``robustness`` must win
# over bench/robustness.py (this script's folder is sys.path[0])
sys.path.insert(0, str(ROOT))
os.environ.setdefault("JAX_PLATFORMS", "cpu")
# a CPU device per core, as the command lines (robustness.replay.replay_devices)
os.environ.setdefault("JAX_NUM_CPU_DEVICES", str(len(os.sched_getaffinity(0))))

PARTS = ("rectangle", "nice_stable", "biplus_stable", "unistable")
MU_F = (0.5, 0.8, 1.5)
SUPPORTS = ("rigid", "any")
GOAL = (0.10, 0.05, math.pi / 3)       # certify_triangle.yaml's "turn", for the triangle
P_REQ, CONF = 0.9, 0.95


def _sampler(mu_f, support):
    """certify_triangle.yaml's tolerances and robot errors; fence friction mu_f."""
    from robustness import ExecutionTolerance, FrictionRange, GeometryTolerance, Sampler

    return Sampler(GeometryTolerance(tau_v=2e-5, tau_com=1e-4),
                   FrictionRange(mu_f=(mu_f, mu_f), mu_s=(0.2, 0.5), support=support),
                   ExecutionTolerance(start_xy=5e-4, start_theta=0.01, fence_angle=0.002,
                                      distance_abs=1e-4, distance_rel=0.005))


def _size(v):
    import numpy as np

    v = np.asarray(v, float)
    return float(np.max(np.linalg.norm(v[:, None] - v[None], axis=-1)))


def _same(a, b) -> bool:
    """The same pushes (kind, direction, distance, edge)."""
    return a.n_pushes == b.n_pushes and all(
        x.kind == y.kind and tuple(x.edge) == tuple(y.edge)
        and abs(x.distance - y.distance) < 1e-12
        and max(abs(u - v) for u, v in zip(x.direction, y.direction)) < 1e-12
        for x, y in zip(a.pushes, b.pushes))


def main() -> int:
    import jax
    import numpy as np

    from planning import plan_pose
    from robustness import (Model, Requirement, Selection, SuccessCriterion, auto_schedule,
                            certify, clopper_pearson, evaluate, physics_veto, selection_key,
                            synthesize, veto_key)
    from robustness.physics import PhysicsRun
    from sweeps.config import Synthesize
    from sweeps.executors import enable_compilation_cache
    from sweeps.study import load_part_ref

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true",
                    help="20 rollouts per plan, 100 selection draws of 16 candidates")
    ap.add_argument("--rollouts", type=int, default=None, help="MuJoCo rollouts per plan (100)")
    ap.add_argument("--qs-rollouts", type=int, default=None,
                    help="rollouts of a plan only the quasistatic model certified (40; quick 20)")
    ap.add_argument("--select", type=int, default=None, help="selection draws (100)")
    ap.add_argument("--candidates", type=int, default=None, help="most candidates (16)")
    ap.add_argument("--syn-model", default="limit_surface",
                    choices=("limit_surface", "quasistatic"), help="the selection's model")
    ap.add_argument("--max-samples", type=int, default=4000, help="certification cap")
    ap.add_argument("--stroke", default="planned", choices=("planned", "contact"))
    ap.add_argument("--parts", nargs="+", default=list(PARTS), choices=PARTS)
    ap.add_argument("--mu-f", nargs="+", type=float, default=list(MU_F))
    ap.add_argument("--supports", nargs="+", default=list(SUPPORTS), choices=SUPPORTS)
    ap.add_argument("--no-qs", action="store_true", help="skip the quasistatic certificates")
    ap.add_argument("--veto-samples", type=int, default=24,
                    help="MuJoCo confirms a synthesized choice against the default plan on this "
                         "many common draws, as nudge certify --synthesize does "
                         "(robustness.physics_veto); 0: the kinematic choice alone")
    args = ap.parse_args()
    n_mj = args.rollouts or (20 if args.quick else 100)
    n_qs = args.qs_rollouts or (20 if args.quick else 40)
    n_sel = args.select or 100
    n_cand = args.candidates or 16
    warnings.simplefilter("ignore")
    jax.config.update("jax_enable_x64", True)
    enable_compilation_cache()
    crit = SuccessCriterion(pos_eps_m=0.003, theta_eps_rad=0.05)
    req = Requirement(P_REQ, CONF, crit)
    run = PhysicsRun(backend="c", stroke=args.stroke)
    models = ("limit_surface",) if args.no_qs else ("limit_surface", "quasistatic")
    ref = _size(load_part_ref("biplus_stable", ROOT / "examples").vertices)
    t_all = time.perf_counter()
    t_cert = t_syn = t_mj = 0.0
    print(f"calibration: {n_mj} MuJoCo rollouts per certified plan (C engine, stroke "
          f"{args.stroke}){' [--quick: fewer than the issue asks]' if n_mj < 100 else ''}, "
          f"{n_qs} of a plan only the quasistatic model certified; "
          f"synthesis {n_cand} candidates x {n_sel} draws under {args.syn_model}; "
          f"certificates p >= {P_REQ} at {CONF:.0%}, auto (cap {args.max_samples})", flush=True)
    hdr = (f"{'part':14s}{'mu_f':>5s} {'support':7s} {'plan':9s}{'P':>3s}{'dist m':>7s}  "
           f"{'ls cert':13s}{'low':>6s}{'n':>6s}  {'qs cert':13s}{'low':>6s}{'n':>5s}  "
           f"{'mujoco k/n':>10s} {'CP 95 %':>13s}  {'ls@mj':>5s} {'ls ok/mj fail':>13s}  "
           f"{'calib':6s} {'qs calib':8s}  physics failure modes (slip median mm)")
    print(hdr)
    rows = []
    cell = 0
    for name in args.parts:
        part = load_part_ref(name, ROOT / "examples")
        k = _size(part.vertices) / ref
        goal = (GOAL[0] * k, GOAL[1] * k, GOAL[2])
        default = plan_pose(part.vertices, (0.0, 0.0, 0.0), goal, part.com)
        for mu in args.mu_f:
            for sup in args.supports:
                cell += 1
                sampler = _sampler(mu, sup)
                key = jax.random.fold_in(jax.random.key(0), cell)
                mj_key = jax.random.fold_in(jax.random.key(1), cell)
                t0 = time.perf_counter()
                grid = Synthesize(max_candidates=n_cand).grid(sampler.friction)
                syn = synthesize(part.vertices, (0.0, 0.0, 0.0), goal, part.com,
                                 selection=Selection(sampler, n_sel, selection_key(key)),
                                 requirement=req, model=args.syn_model, **grid)
                t_syn += time.perf_counter() - t0
                if args.veto_samples:
                    t0 = time.perf_counter()
                    syn = physics_veto(syn, sampler, args.veto_samples, veto_key(key), crit,
                                       physics=run)
                    t_mj += time.perf_counter() - t0
                    if syn.vetoed_from is not None:
                        k0, kc, nv, _ = syn.veto
                        print(f"  {name} mu_f {mu} {sup}: MuJoCo vetoed the synthesized choice "
                              f"({kc}/{nv} against the default's {k0}/{nv})", flush=True)
                plans = [("default", default, False)]
                plans.append(("synth", syn.plan, _same(syn.plan, default)))
                done = {}
                for label, plan, dup in plans:
                    if dup:
                        r = dict(done["default"], plan="synth", dup=True)
                        rows.append(r)
                        _print(r)
                        continue
                    r = dict(part=name, mu=mu, support=sup, plan=label, dup=False,
                             pushes=plan.n_pushes, dist=plan.total_distance)
                    for m in models:
                        t0 = time.perf_counter()
                        cert, _, _ = certify(plan, sampler, key, req,
                                             samples=auto_schedule(P_REQ, CONF, args.max_samples),
                                             model=m, bound=False)
                        t_cert += time.perf_counter() - t0
                        r[m] = dict(ok=cert.verdict == "certified", low=cert.ci_low_one_sided,
                                    n=cert.n_samples, k=cert.n_success, reason=cert.reason,
                                    mode=cert.dominant_failure_mode)
                    r["mj"] = None
                    if any(r[m]["ok"] for m in models):
                        n = n_mj if r["limit_surface"]["ok"] else n_qs
                        t0 = time.perf_counter()
                        ev = evaluate(plan, sampler, n, mj_key, crit, Model("mujoco", physics=run))
                        t_mj += time.perf_counter() - t0
                        c = ev.columns
                        ok = np.asarray(c["success"], bool)
                        ls = evaluate(plan, sampler, n, mj_key, crit, "limit_surface")
                        lok = np.asarray(ls.columns["success"], bool)
                        modes = {}
                        for mo in np.asarray(c["failure_mode"])[~ok]:
                            modes[str(mo)] = modes.get(str(mo), 0) + 1
                        slip = np.asarray(c["slip_m"], float)
                        r["mj"] = dict(k=int(ok.sum()), n=n, cp=clopper_pearson(int(ok.sum()), n,
                                                                                  CONF),
                                       ls_k=int(lok.sum()), ls_ok_mj_fail=int((lok & ~ok).sum()),
                                       modes=modes,
                                       slip_fail=float(np.median(slip[~ok])) if (~ok).any()
                                       else math.nan,
                                       slip_ok=float(np.median(slip[ok])) if ok.any()
                                       else math.nan,
                                       qs_k=int(np.asarray(c["success_quasistatic"], bool).sum()))
                    done[label] = r
                    rows.append(r)
                    _print(r)
    distinct = [r for r in rows if not r["dup"]]

    def tally(m):
        cert = [r for r in distinct if r.get(m, {}).get("ok")]
        fails = [r for r in cert if r["mj"]["k"] < P_REQ * r["mj"]["n"]]
        k = sum(r["mj"]["k"] for r in cert)
        n = sum(r["mj"]["n"] for r in cert)
        return cert, fails, (k / n if n else math.nan), k, n

    ls_c, ls_f, ls_s, ls_k, ls_n = tally("limit_surface")
    print(f"\n{len(distinct)} distinct plans in {cell} cells ({len(rows) - len(distinct)} "
          f"synthesized plans were the default plan); wall {time.perf_counter() - t_all:.0f} s "
          f"(synthesis {t_syn:.0f} s, certificates {t_cert:.0f} s, MuJoCo {t_mj:.0f} s)")
    print(f"limit_surface: {len(ls_c)} certified, {len(ls_f)} calibration failures "
          f"(MuJoCo success < {P_REQ}); pooled MuJoCo success of the certified {ls_k}/{ls_n}")
    for r in ls_f:
        print(f"  FAIL {r['part']} mu_f {r['mu']} {r['support']} {r['plan']}: MuJoCo "
              f"{r['mj']['k']}/{r['mj']['n']}, limit surface on the same draws "
              f"{r['mj']['ls_k']}/{r['mj']['n']}, failure modes {r['mj']['modes']}, slip "
              f"median {r['mj']['slip_fail'] * 1e3:.2f} mm on failures, "
              f"{r['mj']['slip_ok'] * 1e3:.2f} mm on successes")
    qs_keys = ""
    if not args.no_qs:
        qs_c, qs_f, qs_s, qs_k, qs_n = tally("quasistatic")
        print(f"quasistatic: {len(qs_c)} certified, {len(qs_f)} calibration failures; pooled "
              f"MuJoCo success of the certified {qs_k}/{qs_n}")
        qs_keys = f" qs_certified={len(qs_c)} qs_calibration_failures={len(qs_f)}"
    rate = len(ls_f) / len(ls_c) if ls_c else math.nan
    print(f"\nRESULT certified={len(ls_c)} calibration_failures={len(ls_f)} "
          f"calibration_failure_rate={rate:.3f} mujoco_success_certified={ls_s:.3f}{qs_keys} "
          f"rollouts={n_mj} stroke={args.stroke}")
    return 0


def _print(r):
    def cert(m, w):
        c = r.get(m)
        if c is None:
            return f"{'-':13s}{'':>6s}{'':>{w}s}"
        v = "yes" if c["ok"] else f"no:{c['mode']}"[:12]
        return f"{v:13s}{c['low']:6.3f}{c['n']:{w}d}"

    mj = r["mj"]
    ls_ok = r.get("limit_surface", {}).get("ok", False)
    qs_ok = r.get("quasistatic", {}).get("ok", False)
    if mj is None:
        m = f"{'-':>10s} {'':>13s}  {'':>5s} {'':>13s}  {'-':6s} {'-':8s}  "
    else:
        low = mj["k"] < P_REQ * mj["n"]
        sig = mj["cp"][1] < P_REQ

        def verdict(ok):
            return "-" if not ok else ("FAIL*" if sig else "FAIL") if low else "ok"

        modes = ", ".join(f"{k} {v}" for k, v in sorted(mj["modes"].items(), key=lambda x: -x[1]))
        slip = "" if mj["slip_fail"] != mj["slip_fail"] else f" ({mj['slip_fail'] * 1e3:.1f})"
        m = (f"{mj['k']:>4d}/{mj['n']:<5d} [{mj['cp'][0]:.3f},{mj['cp'][1]:.3f}]  "
             f"{mj['ls_k'] / mj['n']:5.2f} {mj['ls_ok_mj_fail']:>13d}  {verdict(ls_ok):6s} "
             f"{verdict(qs_ok):8s}  {modes}{slip}")
    plan = r["plan"] + ("=d" if r["dup"] else "")
    print(f"{r['part']:14s}{r['mu']:5.1f} {r['support']:7s} {plan:9s}{r['pushes']:3d}"
          f"{r['dist']:7.3f}  {cert('limit_surface', 6)}  {cert('quasistatic', 5)}  {m}",
          flush=True)


if __name__ == "__main__":
    sys.exit(main())
