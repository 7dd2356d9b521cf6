"""Benchmark: how well the plans and our models hold up in MuJoCo (C engine).

Run by hand from the repository root (no assertions)::

    python bench/fidelity.py                     # default: supports rigid and any, ~20 min
    python bench/fidelity.py --goals 6           # more goals per part
    python bench/fidelity.py --supports rigid --kinds default --no-tumbles --no-mjx

Pushes: on each bundled polygon (rectangle, nice-stable, biplus-stable,
uni-stable) ``--goals`` seeded goals 3-8 cm from the start with any heading
are planned with each plan kind of ``--kinds``: ``default`` (Peshkin's
distances), ``rigid`` (distances valid for rigid corner support,
``support="rigid"``), ``slip`` (rigid and slip-aware, ``min_fence_mu=0.5``)
and ``c4-8`` (the old README's model-based distances for c in [4, 8] mm, a
support no part resting on its corners has); plans pushing more than
``--max-push`` metres in all are set aside and counted.  Each plan runs on the
NOMINAL part with fence friction 0.5, 0.8 and 1.5 (support friction 0.5) under
each support family of ``--supports`` (``robustness.FrictionRange.support``:
one draw of the family, the same for the three frictions; the MuJoCo scene
realises the family the sampler drew, ``kernels.support``).  For every run:

* **push_ok**: the rollout as a cell runs it (open loop: every stroke from
  the planned pose) ends within 1 % of the start-goal distance and 1 degree
  of the goal;
* **agreement**: the rollout with contact strokes (every stroke from where
  the part is, the models' semantics) against the quasi-static (ellipsoidal
  limit surface of the sample's ``c``: ``qs``), limit-surface (the exact
  limit surface of the sample's support points: ``ls``,
  :mod:`kernels.quasistatic_points`) and exact models' rows of the same sample: success at 3 mm / 1 degree the same in
  both, and the median / p95 of the final pose differences.  Every
  disagreement is listed with the physics and model outcomes (slip, landed
  edges, the support and the c MuJoCo realised) so that its class can be named.

C vs MJX (``--no-mjx`` skips it, ~1-2 min of compilation on a CPU per family;
``--goals 0 --no-tumbles`` runs it alone): one 2 cm translation of the
rectangle on a tripod, rigid corners, a uniform pad and a ring under the soft contact
model (noslip 0, impratio 30) that both engines run: the final position
difference per family (and MJX's soft model against the C engine's default).

Tumbles: on each bundled polyhedron, ``--tumble-goals`` goals reached by a
seeded random walk of 4 tumbles from ``(0, 0, 0, 0)``, planned with
``plan_tumble`` (eps 1 mm), rolled out with pads of friction 1.5; the
fraction of plans that land every planned face.

Measured 2026-12-07 (CPU, ``--no-tumbles --no-mjx``: four plan kinds, supports
rigid and any, 288 runs, 901 s beside other work), after the pad and rim stood on
their feet alone (``kernels.support.FEET_AT_CORNERS``)::

    RESULT push_ok=0.306 qs_agreement=0.795 qs_agreement_rigid=0.660 ls_agreement=0.969
    ls_agreement_rigid=0.951 c_vs_mjx_mm=nan tumble_faces_ok=nan

Under ``any`` (its draws here: rings and tripods) the limit-surface model agrees
on 142 of 144 runs (the two others: the ``c4-8`` plan on a ring, where physics
leaves a reorientation incomplete), the ellipsoid on 0.93.

``--thickness-mm T``: the scenes' parts ``T`` mm thick instead of the
scene's 3 mm, their mass kept (the fence pushes at half the thickness: the
moment of the push about the support, which the planar models do not have).
Measured 2026-12-06 (CPU, ``--supports rigid --kinds default --no-tumbles
--no-mjx``, 36 runs, 99 s): at 3 mm ``ls_agreement_rigid=0.917
qs_agreement_rigid=0.639``; at 0.5 mm 0.833 and 0.500, the thin parts'
own failures (``incomplete_reorientation``: a 0.5 mm plate under a fence 0.2
mm above the table lands no edge flush) replacing the thick ones'.  On the
rectangle, whose centre of mass lies on the diagonal joining two of the three
corners it rests on, the difference with the planar model follows the
thickness: its
physics slip per push at fence friction 0.5 / 0.8 falls from 2.05 / 0.71 mm
to 0.80 / 0.07 mm (the limit-surface model: 0.59 / 0.00); on the rectangle's
7-push turn of ``bench/synthesis.py`` (rigid corners, fence friction 0.65,
6 draws) MuJoCo slips 0.3-0.6 mm on each of its five short turning pushes in
the four draws where the model sticks (0.8-0.9 mm in the two where both
slip), and ends 2.0-4.4 mm from the goal; at 0.5 mm
thickness and the same mass it ends 0.2-0.3 mm from the model on all six
(the biplus-stable and uni-stable parts' slip hardly changes with the
thickness).  The rocking is not what differs, though: the support's contact
forces read through the same rectangle plan (its default plan to
(0.05, 0.02, 1.0), fence friction 0.8, support friction 0.5, one draw, every
10th step) move from the rest diagonal (loads 0, 0.50, 0.01, 0.50) to
0.14-0.16, 0.21, 0.01, 0.63-0.65 on average while the fence touches, alike
at 3 mm and at 0.5 mm (the loads' spread alike too), where the slip per push
is 0.34 and 0.03 mm: a load transfer growing with the push's height would
differ tenfold; the fence touches with 3.1-3.2 contacts on average in
both.  So the thickness acts through the fence's contact, not through the
loads: a part that rocks moves its side face up and down at the fence, the
more the higher the contact, and that vertical sliding takes its share of
the fence's friction cone (``bench/fence_friction.py``'s
``fence_vertical_w``); a planar model has neither the rocking nor the
height (open).

Last line: ``RESULT push_ok=F qs_agreement=A qs_agreement_rigid=R ls_agreement=L
ls_agreement_rigid=LR c_vs_mjx_mm=M tumble_faces_ok=T`` (push_ok over the default
plans, the agreements over every run and over the runs on rigid support).
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
from planning import PushOptions, plan_pose, plan_tumble  # noqa: E402
from robustness import Draws, FrictionRange, Sampler, release_executables  # noqa: E402
from robustness.replay import run_push as _run_push  # noqa: E402  (the evaluation's own kernels)
from robustness.physics import PhysicsSettings, rollout_push_plan, rollout_tumble_plan  # noqa: E402
from robustness.physics.settings import SOFT_IMPRATIO  # noqa: E402
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


def _params(plan, seed, support):
    """Three samples of the nominal part: one support draw, mu_f 0.5/0.8/1.5."""
    body = pg.make_polygon(np.asarray(plan.vertices), np.asarray(plan.com)).body
    fr = (FrictionRange(mu_f=(0.5, 1.5), mu_s=(0.5, 0.5), support="tripod", c=(0.004, 0.004))
          if support == "tripod" else FrictionRange(mu_f=(0.5, 1.5), mu_s=(0.5, 0.5),
                                                    support=support))
    draws = Sampler(friction=fr).sample(jax.random.key(seed), 1, n_vertices=len(plan.vertices),
                                         dim=2, n_pushes=plan.n_pushes, body=body)
    p, ax = draws.params, draws.in_axes
    p3 = jax.tree_util.tree_map(lambda x, a: x if a is None else jnp.repeat(x, 3, axis=0), p, ax,
                                is_leaf=lambda x: x is None)
    f = dataclasses.replace(p3.friction, mu_f=jnp.asarray(MU_F))
    return Draws(dataclasses.replace(p3, friction=f), ax, 3)


KINDS = {"default": PushOptions(), "rigid": PushOptions(support="rigid"),
         "slip": PushOptions(support="rigid", min_fence_mu=0.5),
         "c4-8": PushOptions(support={"c": [0.004, 0.008]})}


def _model_rows(plan, draws, model):
    with jax.enable_x64(True):
        _, _, r = _run_push(plan, draws, model, jnp.float64, 3)
    return {f.name: np.asarray(getattr(r, f.name)) for f in dataclasses.fields(r)}


def _ok(x, y, th, goal, pe, te):
    return (np.hypot(x - goal[0], y - goal[1]) <= pe) & (np.abs(wrap_angle_np(th - goal[2])) <= te)


def run_pushes(args):
    from planning.pushing.planner import PlanningError

    rows, skipped = [], []
    for support in args.supports:
        for kind in args.kinds:
            for name in PUSH_PARTS:
                part = load_part(ROOT / "examples" / f"{name}.yaml")
                for gi, goal in enumerate(_push_goals(args.goals, args.seed)):
                    try:
                        plan = plan_pose(part.vertices, (0.0, 0.0, 0.0), goal, com=part.com,
                                         options=KINDS[kind])
                    except PlanningError as exc:
                        skipped.append((support, kind, name, gi, f"no plan ({str(exc)[:60]})"))
                        continue
                    if plan.total_distance > args.max_push:
                        skipped.append((support, kind, name, gi, f"{plan.total_distance:.2f} m"))
                        continue
                    rows += _run_one(args, support, kind, name, gi, goal, plan)
    return rows, skipped


def _run_one(args, support, kind, name, gi, goal, plan):
    release_executables()   # every plan shape compiles its own kernels
    draws = _params(plan, args.seed + gi, support)
    straight = math.hypot(goal[0], goal[1])
    t0 = time.perf_counter()
    cell = rollout_push_plan(plan, draws, backend="c", settings=args.settings)
    con = rollout_push_plan(plan, draws, backend="c", stroke="contact",
                            settings=args.settings)
    secs = time.perf_counter() - t0
    qs = _model_rows(plan, draws, "quasistatic")
    ls = _model_rows(plan, draws, "limit_surface")
    ex = _model_rows(plan, draws, "exact")
    g = np.asarray(plan.goal)
    cell_ok = _ok(cell.x, cell.y, cell.theta, g, 0.01 * straight, EPS_TH)
    ph_s = _ok(con.x, con.y, con.theta, g, EPS_POS, EPS_TH)
    out = []
    for j, mu in enumerate(MU_F):
        rec = dict(support=support, kind=kind, part=name, goal=gi, mu=mu, pushes=plan.n_pushes,
                   dist=plan.total_distance, cell_ok=bool(cell_ok[j]),
                   cell_err=(cell.err_pos[j], cell.err_theta[j]),
                   cell_mode=cell.failure_mode[j], strike=bool(cell.fence_strike[j]),
                   secs=secs / 3)
        for tag, m in (("qs", qs), ("ls", ls), ("ex", ex)):
            ok = _ok(m["x"][j], m["y"][j], m["theta"][j], g, EPS_POS, EPS_TH)
            dpos = math.hypot(con.x[j] - m["x"][j], con.y[j] - m["y"][j])
            dth = abs(wrap_angle_np(con.theta[j] - m["theta"][j]))
            rec[tag] = dict(agree=bool(ok) == bool(ph_s[j]), ok=bool(ok), dpos=dpos, dth=dth,
                            slip=float(np.sum(m["slip"][j])), edges=m["edges"][j].tolist())
        rec["phys"] = dict(ok=bool(ph_s[j]), slip=float(con.slip[j]),
                           slips=np.round(con.slip_per_push[j] * 1e3, 2).tolist(),
                           edges=con.edges[j].tolist(), mode=con.failure_mode[j],
                           c=float(con.c[j]), c_phys=float(con.c_physical[j]),
                           family=str(con.support[j]))
        out.append(rec)
    print(f"  {support:<6} {kind:<8} {name:<14} goal {gi}: {plan.n_pushes} pushes, "
          f"{plan.total_distance:.3f} m, {secs:.1f} s; {out[0]['phys']['family']} c "
          f"{out[0]['phys']['c'] * 1e3:.1f}/{out[0]['phys']['c_phys'] * 1e3:.1f} mm; cell ok "
          f"{cell_ok.astype(int).tolist()}, physics/qs/exact success {ph_s.astype(int).tolist()}/"
          f"{[int(r['qs']['ok']) for r in out]}/{[int(r['ex']['ok']) for r in out]}, limit surface "
          f"{[int(r['ls']['ok']) for r in out]}", flush=True)
    return out


def report_pushes(rows, skipped):
    print(f"\n{'support':<8}{'kind':<9}{'part':<14}{'mu_f':>5}{'runs':>5}{'push_ok':>8}"
          f"{'qs_agree':>9}{'ls_agree':>9}{'ex_agree':>9}{'dpos_ls med/p95 mm':>20}"
          f"{'dth_ls med/p95 deg':>20}{'slip/push phys/qs/ls mm':>26}{'strikes':>8}")
    for support in dict.fromkeys(r["support"] for r in rows):
        for kind in dict.fromkeys(r["kind"] for r in rows):
            for name in PUSH_PARTS:
                for mu in MU_F:
                    sel = [r for r in rows if (r["support"], r["kind"], r["part"], r["mu"])
                           == (support, kind, name, mu)]
                    if not sel:
                        continue
                    dq = np.array([r["ls"]["dpos"] for r in sel]) * 1e3
                    tq = np.degrees([r["ls"]["dth"] for r in sel])
                    sp = np.array([r["phys"]["slip"] / r["pushes"] for r in sel]) * 1e3
                    sq = np.array([r["qs"]["slip"] / r["pushes"] for r in sel]) * 1e3
                    sl = np.array([r["ls"]["slip"] / r["pushes"] for r in sel]) * 1e3
                    print(f"{support:<8}{kind:<9}{name:<14}{mu:>5.1f}{len(sel):>5}"
                          f"{np.mean([r['cell_ok'] for r in sel]):>8.2f}"
                          f"{np.mean([r['qs']['agree'] for r in sel]):>9.2f}"
                          f"{np.mean([r['ls']['agree'] for r in sel]):>9.2f}"
                          f"{np.mean([r['ex']['agree'] for r in sel]):>9.2f}"
                          f"{np.median(dq):>10.3f}/{np.percentile(dq, 95):<9.3f}"
                          f"{np.median(tq):>10.3f}/{np.percentile(tq, 95):<9.3f}"
                          f"{np.median(sp):>11.2f}/{np.median(sq):.2f}/{np.median(sl):<9.2f}"
                          f"{sum(r['strike'] for r in sel):>8d}")
    print(f"\n{'support':<8}{'kind':<9}{'drawn':<9}{'runs':>5}{'push_ok':>8}{'qs_agree':>9}"
          f"{'ls_agree':>9}   (the goal: agreement >= 0.95 under each family, every plan kind)")
    for support in dict.fromkeys(r["support"] for r in rows):
        for kind in dict.fromkeys(r["kind"] for r in rows):
            sel = [r for r in rows if (r["support"], r["kind"]) == (support, kind)]
            for drawn in [None] + sorted({r["phys"]["family"] for r in sel}):
                sub = [r for r in sel if drawn is None or r["phys"]["family"] == drawn]
                if not sub or (drawn is not None and drawn == support):
                    continue
                print(f"{support:<8}{kind:<9}{drawn or 'all':<9}{len(sub):>5}"
                      f"{np.mean([r['cell_ok'] for r in sub]):>8.2f}"
                      f"{np.mean([r['qs']['agree'] for r in sub]):>9.2f}"
                      f"{np.mean([r['ls']['agree'] for r in sub]):>9.2f}")
    if skipped:
        print("set aside: " + ", ".join(f"{s} {k} {n} goal {g} ({why})"
                                        for s, k, n, g, why in skipped))
    print("\ndisagreements (physics with contact strokes vs the limit-surface model, 3 mm / 1 deg):")
    for r in rows:
        if not r["ls"]["agree"]:
            p = r["phys"]
            print(f"  {r['support']} {r['kind']} {r['part']} goal {r['goal']} mu_f {r['mu']}: "
                  f"physics {'ok' if p['ok'] else p['mode']} ({p['family']} c {p['c'] * 1e3:.1f}"
                  f"/{p['c_phys'] * 1e3:.1f} mm, slip per push {p['slips']} mm, edges "
                  f"{p['edges']}); ls {'ok' if r['ls']['ok'] else 'fail'} (slip "
                  f"{r['ls']['slip'] * 1e3:.2f} mm, edges {r['ls']['edges']}); dpos "
                  f"{r['ls']['dpos'] * 1e3:.2f} mm")
    print("\nopen-loop cell failures (1 % / 1 deg):")
    for r in rows:
        if not r["cell_ok"]:
            print(f"  {r['support']} {r['kind']} {r['part']} goal {r['goal']} mu_f {r['mu']}: "
                  f"{r['cell_mode']}, err {r['cell_err'][0] * 1e3:.2f} mm / "
                  f"{math.degrees(r['cell_err'][1]):.2f} deg (plan {r['dist']:.3f} m)")


def c_vs_mjx():
    """Final position difference (mm) of one 2 cm push of the rectangle,
    soft contact model (noslip 0, impratio 30) on both engines, C engine
    against MJX (float32), per support family; and the C engine's default
    (noslip) model against MJX.  Returns the largest soft-model difference."""
    part = load_part(ROOT / "examples" / "rectangle.yaml")
    plan = plan_pose(part.vertices, (0.0, 0.0, 0.0), (0.02, 0.0, 0.0), com=part.com)
    body = pg.make_polygon(part.vertices, part.com).body
    soft = PhysicsSettings(noslip_iterations=0, impratio=SOFT_IMPRATIO)
    worst = 0.0
    for fam, c in (("tripod", (0.008, 0.008)), ("rigid", None), ("uniform", None), ("ring", None)):
        sam = Sampler(friction=FrictionRange(mu_f=(0.8, 0.8), mu_s=(0.5, 0.5), support=fam, c=c))
        params = sam.sample(jax.random.key(0), 1, n_vertices=4, dim=2, n_pushes=plan.n_pushes,
                            body=body)
        m = rollout_push_plan(plan, params, backend="mjx", settings=soft)
        cs = rollout_push_plan(plan, params, backend="c", settings=soft)
        cn = rollout_push_plan(plan, params, backend="c")
        d = math.hypot(m.x[0] - cs.x[0], m.y[0] - cs.y[0]) * 1e3
        dn = math.hypot(m.x[0] - cn.x[0], m.y[0] - cn.y[0]) * 1e3
        worst = max(worst, d)
        print(f"C vs MJX, 2 cm push, {fam:<8}: soft model {d:.3f} mm ({cs.failure_mode[0]} / "
              f"{m.failure_mode[0]}), C noslip vs MJX soft {dn:.3f} mm")
    return worst


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
            draws = sam.sample(jax.random.key(gi), 1, n_vertices=len(part.vertices), dim=3,
                               n_tumbles=plan.n_tumbles)
            t0 = time.perf_counter()
            r = rollout_tumble_plan(plan, draws, backend="c")
            rows.append(dict(part=name, goal=gi, n=plan.n_tumbles, ok=bool(r.faces_ok[0]),
                             wrong=int(r.n_wrong_faces[0]), err=float(r.err_pos[0]),
                             eth=float(r.err_theta[0]), pred=plan.error,
                             slip=float(np.nanmax(r.slip_per_tumble[0])),
                             mode=r.failure_mode[0]))
            print(f"  {name:<20} goal {gi}: {plan.n_tumbles} tumbles, faces ok {rows[-1]['ok']}, "
                  f"err {rows[-1]['err'] * 1e3:.2f} mm / {math.degrees(rows[-1]['eth']):.3f} deg, "
                  f"max pivot slip {rows[-1]['slip'] * 1e3:.2f} mm, {r.failure_mode[0]}, "
                  f"{time.perf_counter() - t0:.1f} s", flush=True)
    return rows


def main():
    _quiet()
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--goals", type=int, default=3, help="push goals per part")
    ap.add_argument("--tumble-goals", type=int, default=2, help="tumble goals per polyhedron")
    ap.add_argument("--max-push", type=float, default=1.0, help="set aside longer push plans (m)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--supports", nargs="+", default=["rigid", "any"],
                    choices=("rigid", "uniform", "ring", "tripod", "any"),
                    help="support families the scenes and the sampler draw (tripod: c 4 mm)")
    ap.add_argument("--kinds", nargs="+", default=list(KINDS), choices=list(KINDS),
                    help="plan kinds")
    ap.add_argument("--no-tumbles", action="store_true", help="pushes only")
    ap.add_argument("--no-mjx", action="store_true", help="skip the C vs MJX push")
    ap.add_argument("--thickness-mm", type=float,
                    help="the parts' thickness in the scene (the fence pushes at half of it), "
                         "their mass kept (the density scaled); default: the scene's 3 mm")
    args = ap.parse_args()
    args.settings = PhysicsSettings()
    if args.thickness_mm:
        base = args.settings
        t = args.thickness_mm * 1e-3
        args.settings = dataclasses.replace(base, part_thickness=t, part_density=base.part_density
                                            * base.part_thickness / t)
    t0 = time.perf_counter()
    print("push plans (3 fence frictions each):")
    rows, skipped = run_pushes(args)
    report_pushes(rows, skipped)
    print("\ntumble plans (pads of friction 1.5):")
    trows = [] if args.no_tumbles else run_tumbles(args)
    dflt = [r["cell_ok"] for r in rows if r["kind"] == "default"]
    push_ok = float(np.mean(dflt)) if dflt else math.nan
    qs_agree = float(np.mean([r["qs"]["agree"] for r in rows])) if rows else math.nan
    rig = [r["qs"]["agree"] for r in rows if r["support"] == "rigid"]
    qs_rigid = float(np.mean(rig)) if rig else math.nan
    ls_agree = float(np.mean([r["ls"]["agree"] for r in rows])) if rows else math.nan
    lrig = [r["ls"]["agree"] for r in rows if r["support"] == "rigid"]
    ls_rigid = float(np.mean(lrig)) if lrig else math.nan
    mjx_mm = math.nan if args.no_mjx else c_vs_mjx()
    ex_agree = float(np.mean([r["ex"]["agree"] for r in rows])) if rows else math.nan
    t_ok = float(np.mean([r["ok"] for r in trows])) if trows else math.nan
    print(f"\npush runs {len(rows)}, set aside {len(skipped)} plans; agreement with the exact model "
          f"{ex_agree:.3f}; tumble plans {len(trows)}; {time.perf_counter() - t0:.0f} s")
    print(f"RESULT push_ok={push_ok:.3f} qs_agreement={qs_agree:.3f} "
          f"qs_agreement_rigid={qs_rigid:.3f} ls_agreement={ls_agree:.3f} "
          f"ls_agreement_rigid={ls_rigid:.3f} c_vs_mjx_mm={mjx_mm:.3f} tumble_faces_ok={t_ok:.3f}")


if __name__ == "__main__":
    main()
