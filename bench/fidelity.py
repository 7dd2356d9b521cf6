"""Benchmark: how well the plans and our models hold up in MuJoCo (C engine).

Run by hand from the repository root (no assertions)::

    python bench/fidelity.py             # default: a few minutes on 2 cores
    python bench/fidelity.py --goals 6   # more goals per part
    python bench/fidelity.py --support centred --no-tumbles   # feet at the sampled points

Pushes: on each bundled polygon (rectangle, nice-stable, biplus-stable,
uni-stable) ``--goals`` seeded goals 3-8 cm from the start with any heading
are planned (``plan_pose``, default settings; plans pushing more than
``--max-push`` metres in all are set aside and counted); each plan runs on
the NOMINAL part with fence friction 0.5, 0.8 and 1.5 (support friction 0.5,
the support distribution a draw of the default sampler, the same draw for
the three).  For every run:

* **push_ok**: the rollout as a cell runs it (open loop: every stroke from
  the planned pose) ends within 1 % of the start-goal distance and 1 degree
  of the goal;
* **agreement**: the rollout with contact strokes (every stroke from where
  the part is, the models' semantics) against the quasi-static and exact
  models' rows of the same sample (``robustness.evaluation``'s kernels):
  success at 3 mm / 1 degree the same in both, and the median / p95 of the
  final pose differences.  Every disagreement is listed with the physics and
  model outcomes (slip, landed edges) so that its class can be named.

Tumbles: on each bundled polyhedron, ``--tumble-goals`` goals reached by a
seeded random walk of 4 tumbles from ``(0, 0, 0, 0)``, planned with
``plan_tumble`` (eps 1 mm), rolled out with pads of friction 1.5; the
fraction of plans that land every planned face, with the final error
against the goal and the pivot slips.

Last line: ``RESULT push_ok=F qs_agreement=A tumble_faces_ok=T``.
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import pathlib
import sys
import time
import warnings

ROOT = pathlib.Path(__file__).resolve().parents[1]
# first, even when ROOT is already on PYTHONPATH: the package ``robustness`` must win
# over bench/robustness.py (this script's folder is sys.path[0])
sys.path.insert(0, str(ROOT))

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from kernels import polygon as pg  # noqa: E402
from kernels.planar import wrap_angle_np  # noqa: E402
from planning import plan_pose, plan_tumble  # noqa: E402
from robustness import FrictionRange, Sampler  # noqa: E402
from robustness.replay import run_push as _run_push  # noqa: E402  (the evaluation's own kernels)
from robustness.physics import PhysicsSettings, rollout_push_plan, rollout_tumble_plan  # noqa: E402
from sweeps.partfile import load_part  # noqa: E402

PUSH_PARTS = ("rectangle", "nice_stable", "biplus_stable", "unistable")
POLYHEDRA = ("cube", "octahedron", "tetrahedron", "truncated_pyramid", "irregular_polyhedron")
MU_F = (0.5, 0.8, 1.5)
EPS_POS, EPS_TH = 3e-3, math.radians(1.0)


def _quiet():
    warnings.simplefilter("ignore")


def _push_goals(k, seed):
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(k):
        r, a = rng.uniform(0.03, 0.08), rng.uniform(-math.pi, math.pi)
        out.append((r * math.cos(a), r * math.sin(a), rng.uniform(-math.pi, math.pi)))
    return out


def _params(plan, seed):
    """Three samples of the nominal part: one support draw, mu_f 0.5/0.8/1.5."""
    body = pg.make_polygon(np.asarray(plan.vertices), np.asarray(plan.com)).body
    sam = Sampler(friction=FrictionRange(mu_f=(0.5, 1.5), mu_s=(0.5, 0.5)))
    p, ax = sam.sample(jax.random.key(seed), 1, n_vertices=len(plan.vertices), dim=2,
                       n_pushes=plan.n_pushes, body=body)
    f = p.friction
    f3 = dataclasses.replace(
        f, mu_f=jnp.asarray(MU_F), c=jnp.repeat(f.c, 3), support_points=jnp.repeat(
            f.support_points, 3, axis=0), support_weights=jnp.repeat(f.support_weights, 3, axis=0))
    return dataclasses.replace(p, friction=f3), ax


def _model_rows(plan, params, axes, model):
    with jax.enable_x64(True):
        _, _, r = _run_push(plan, params, axes, 3, model, jnp.float64, 3)
    return {k: np.asarray(v) for k, v in r.items()}


def _ok(x, y, th, goal, pe, te):
    return (np.hypot(x - goal[0], y - goal[1]) <= pe) & (np.abs(wrap_angle_np(th - goal[2])) <= te)


def run_pushes(args):
    rows, skipped, agree = [], [], []
    for name in PUSH_PARTS:
        part = load_part(ROOT / "examples" / f"{name}.yaml")
        for gi, goal in enumerate(_push_goals(args.goals, args.seed)):
            plan = plan_pose(part.vertices, (0.0, 0.0, 0.0), goal, com=part.com)
            if plan.total_distance > args.max_push:
                skipped.append((name, gi, plan.total_distance))
                continue
            params, axes = _params(plan, args.seed + gi)
            straight = math.hypot(goal[0], goal[1])
            t0 = time.perf_counter()
            cell = rollout_push_plan(plan, params, axes, 3, backend="c", settings=args.settings)
            con = rollout_push_plan(plan, params, axes, 3, backend="c", stroke="contact",
                                    settings=args.settings)
            secs = time.perf_counter() - t0
            qs = _model_rows(plan, params, axes, "quasistatic")
            ex = _model_rows(plan, params, axes, "exact")
            g = np.asarray(plan.goal)
            cell_ok = _ok(cell["x"], cell["y"], cell["theta"], g, 0.01 * straight, EPS_TH)
            ph_s = _ok(con["x"], con["y"], con["theta"], g, EPS_POS, EPS_TH)
            for j, mu in enumerate(MU_F):
                rec = dict(part=name, goal=gi, mu=mu, pushes=plan.n_pushes,
                           dist=plan.total_distance, cell_ok=bool(cell_ok[j]),
                           cell_err=(cell["err_pos"][j], cell["err_theta"][j]),
                           cell_mode=cell["failure_mode"][j], secs=secs / 3)
                for tag, m in (("qs", qs), ("ex", ex)):
                    ok = _ok(m["x"][j], m["y"][j], m["theta"][j], g, EPS_POS, EPS_TH)
                    dpos = math.hypot(con["x"][j] - m["x"][j], con["y"][j] - m["y"][j])
                    dth = abs(wrap_angle_np(con["theta"][j] - m["theta"][j]))
                    rec[tag] = dict(agree=bool(ok) == bool(ph_s[j]), ok=bool(ok), dpos=dpos, dth=dth,
                                    slip=float(np.sum(m["slip"][j])), edges=m["edges"][j].tolist(),
                                    complete=m["complete"][j].tolist())
                rec["phys"] = dict(ok=bool(ph_s[j]), slip=float(con["slip"][j]),
                                   slips=np.round(con["slip_per_push"][j] * 1e3, 2).tolist(),
                                   edges=con["edges"][j].tolist(), mode=con["failure_mode"][j],
                                   c=float(con["c"][j]))
                rows.append(rec)
            agree += [r["qs"]["agree"] for r in rows[-3:]]
            print(f"  {name:<14} goal {gi}: {plan.n_pushes} pushes, {plan.total_distance:.3f} m, "
                  f"{secs:.1f} s; cell ok {cell_ok.astype(int).tolist()}, physics/qs/exact "
                  f"success {ph_s.astype(int).tolist()}/"
                  f"{[int(r['qs']['ok']) for r in rows[-3:]]}/{[int(r['ex']['ok']) for r in rows[-3:]]}",
                  flush=True)
    return rows, skipped


def report_pushes(rows, skipped):
    print(f"\n{'part':<14}{'mu_f':>6}{'plans':>7}{'push_ok':>9}{'qs_agree':>10}{'ex_agree':>10}"
          f"{'dpos_qs med/p95 mm':>21}{'dth_qs med/p95 deg':>21}{'dpos_ex med/p95':>18}")
    for name in PUSH_PARTS:
        for mu in MU_F:
            sel = [r for r in rows if r["part"] == name and r["mu"] == mu]
            if not sel:
                continue
            dq = np.array([r["qs"]["dpos"] for r in sel]) * 1e3
            tq = np.degrees([r["qs"]["dth"] for r in sel])
            de = np.array([r["ex"]["dpos"] for r in sel]) * 1e3
            print(f"{name:<14}{mu:>6.1f}{len(sel):>7}{np.mean([r['cell_ok'] for r in sel]):>9.2f}"
                  f"{np.mean([r['qs']['agree'] for r in sel]):>10.2f}"
                  f"{np.mean([r['ex']['agree'] for r in sel]):>10.2f}"
                  f"{np.median(dq):>11.3f}/{np.percentile(dq, 95):<9.3f}"
                  f"{np.median(tq):>11.3f}/{np.percentile(tq, 95):<9.3f}"
                  f"{np.median(de):>9.3f}/{np.percentile(de, 95):<8.3f}")
    if skipped:
        print("set aside (total push above --max-push): "
              + ", ".join(f"{n} goal {g} ({d:.2f} m)" for n, g, d in skipped))
    print("\ndisagreements (physics with contact strokes vs quasi-static, 3 mm / 1 deg):")
    for r in rows:
        if not r["qs"]["agree"]:
            print(f"  {r['part']} goal {r['goal']} mu_f {r['mu']}: physics "
                  f"{'ok' if r['phys']['ok'] else r['phys']['mode']} (slip {r['phys']['slip'] * 1e3:.2f} mm "
                  f"per push {r['phys']['slips']}, edges {r['phys']['edges']}, c {r['phys']['c'] * 1e3:.1f} mm)"
                  f"; qs {'ok' if r['qs']['ok'] else 'fail'} (slip {r['qs']['slip'] * 1e3:.2f} mm, "
                  f"edges {r['qs']['edges']}); dpos {r['qs']['dpos'] * 1e3:.2f} mm")
    print("\nopen-loop cell failures (1 % / 1 deg):")
    for r in rows:
        if not r["cell_ok"]:
            print(f"  {r['part']} goal {r['goal']} mu_f {r['mu']}: {r['cell_mode']}, err "
                  f"{r['cell_err'][0] * 1e3:.2f} mm / {math.degrees(r['cell_err'][1]):.2f} deg "
                  f"(plan {r['dist']:.3f} m)")


def _tumble_goal(poly, steps, rng):
    from kernels.tumble import make_config, replay

    f, word = 0, []
    for _ in range(steps):
        g = int(rng.choice([h for h in poly.neighbors(f) if h >= 0]))
        word.append(g)
        f = g
    with jax.enable_x64(True):
        fin, _ = replay(poly.geometry(jnp.float64), make_config(0, 0, 0, 0, dtype=jnp.float64),
                        jnp.asarray(word))
    return (float(fin.xy[0]), float(fin.xy[1]), float(fin.theta), int(fin.face))


def run_tumbles(args):
    from kernels.polyhedron import make_polyhedron

    rows = []
    sam = Sampler(friction=FrictionRange(mu_f=(1.5, 1.5), mu_s=(1.5, 1.5)))
    for name in POLYHEDRA:
        part = load_part(ROOT / "examples" / f"{name}.yaml")
        poly = make_polyhedron(part.vertices, part.com)
        rng = np.random.default_rng(args.seed)
        for gi in range(args.tumble_goals):
            goal = _tumble_goal(poly, 4, rng)
            plan = plan_tumble(part.vertices, goal, com=part.com, eps=1e-3)
            if plan.verdict != "solved" or plan.n_tumbles == 0:
                print(f"  {name:<20} goal {gi}: {plan.verdict} ({plan.n_tumbles} tumbles), skipped")
                continue
            params, axes = sam.sample(jax.random.key(gi), 1, n_vertices=len(part.vertices), dim=3,
                                      n_tumbles=plan.n_tumbles)
            t0 = time.perf_counter()
            r = rollout_tumble_plan(plan, params, axes, 1, backend="c")
            rows.append(dict(part=name, goal=gi, n=plan.n_tumbles, ok=bool(r["faces_ok"][0]),
                             wrong=int(r["n_wrong_faces"][0]), err=float(r["err_pos"][0]),
                             eth=float(r["err_theta"][0]), pred=plan.error,
                             slip=float(np.nanmax(r["slip_per_tumble"][0])),
                             mode=r["failure_mode"][0]))
            print(f"  {name:<20} goal {gi}: {plan.n_tumbles} tumbles, faces ok {rows[-1]['ok']}, "
                  f"err {rows[-1]['err'] * 1e3:.2f} mm / {math.degrees(rows[-1]['eth']):.3f} deg, "
                  f"max pivot slip {rows[-1]['slip'] * 1e3:.2f} mm, {r['failure_mode'][0]}, "
                  f"{time.perf_counter() - t0:.1f} s", flush=True)
    return rows


def main():
    _quiet()
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--goals", type=int, default=3, help="push goals per part")
    ap.add_argument("--tumble-goals", type=int, default=2, help="tumble goals per polyhedron")
    ap.add_argument("--max-push", type=float, default=1.0, help="set aside longer push plans (m)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--support", default="tripod", choices=("tripod", "centred", "sampled"),
                    help="how the support friction is realised (PhysicsSettings.support)")
    ap.add_argument("--no-tumbles", action="store_true", help="pushes only")
    args = ap.parse_args()
    args.settings = PhysicsSettings(support=args.support)
    t0 = time.perf_counter()
    print("push plans (3 fence frictions each):")
    rows, skipped = run_pushes(args)
    report_pushes(rows, skipped)
    print("\ntumble plans (pads of friction 1.5):")
    trows = [] if args.no_tumbles else run_tumbles(args)
    push_ok = float(np.mean([r["cell_ok"] for r in rows])) if rows else math.nan
    qs_agree = float(np.mean([r["qs"]["agree"] for r in rows])) if rows else math.nan
    ex_agree = float(np.mean([r["ex"]["agree"] for r in rows])) if rows else math.nan
    t_ok = float(np.mean([r["ok"] for r in trows])) if trows else math.nan
    print(f"\npush runs {len(rows)}, set aside {len(skipped)} plans; agreement with the exact model "
          f"{ex_agree:.3f}; tumble plans {len(trows)}; {time.perf_counter() - t0:.0f} s")
    print(f"RESULT push_ok={push_ok:.3f} qs_agreement={qs_agree:.3f} tumble_faces_ok={t_ok:.3f}")


if __name__ == "__main__":
    main()
