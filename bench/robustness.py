"""Benchmark: Monte-Carlo evaluation of plans on perturbed parts.

Run by hand from the repository root (no assertions on time)::

    python bench/robustness.py            # full sizes
    python bench/robustness.py --quick    # small sizes, the limit surface in float64 only, about a minute

Every rate is printed with its ratio to a plain-numpy per-sample loop (the
independent oracles of ``oracles/``) measured in the same run; the device is
the CPU (no accelerator is lent to this benchmark's task: the GPU figures
asked for in issue 11 were not taken).

1. **Push plan, quasi-static model**: a 6-push plan of the biplus-stable
   triangle (``examples/biplus_stable.yaml``, start ``(0, 0, 0)``, the first
   goal of ``PUSH_GOALS`` the planner answers with 6 pushes); every sample
   perturbs the vertices (+-0.02 mm), the centre of mass (0.1 mm disc), fence
   friction (0.3..0.8), the support pressure (16 points -> c), the start pose,
   every fence angle and push distance.  JAX: :func:`kernels.quasistatic.simulate_pushes`
   (event-driven, every contact phase in closed form) vmapped over the
   samples, float64 and float32; "kernel" times the compiled batch on
   pre-drawn parameters, "evaluate()" the whole :func:`robustness.evaluation.evaluate`
   call (sampling, kernel, table and summary; the analytic bound excluded).
   numpy: the quasi-static oracle (``oracles/quasistatic_numpy.py``: world-frame
   mechanics integrated by ``scipy.integrate.solve_ivp`` DOP853, rtol 1e-8 as
   timed, with landing events) per sample in a Python loop on a subset.
   Accuracy: the float64 kernel's final poses against the oracle run at rtol
   1e-12 (the same samples); for reference, the former fixed-step kernel (64
   RK4 steps per push, evaluate()'s default) was 8.9e-7 m off on this plan.
2. **Tumble plan**: a 200-tumble face sequence (seeded random walk) on
   ``examples/irregular_polyhedron.yaml``, vertices perturbed by +-0.1 mm and a
   planar slip after every tumble.  "bare kernel": ``jax.vmap(kernels.tumble.replay)``
   over prebuilt geometries (no slip, no frames); "replay in evaluate": the
   evaluation's compiled replay (geometry per sample, slips, nominal-frame
   conversions; edge motions composed as 2x2 rotations; on the draws as
   evaluate() takes them, the 208 slip columns the sampler computes walked as
   they are), without and with the combinatorics check of every perturbed
   hull; "evaluate()": the whole call
   with the vertex tolerance, in samples/s.  numpy: the oracle
   ``oracles/tumble_numpy.py`` (3-D rotations, no slip) per sample.
3. **Hull check** of the 200-tumble part's perturbed hulls: the JAX check
   (:func:`kernels.hulls.polyhedron_hull_verdict_batch`) against the host
   reference (:func:`kernels.polyhedron.combinatorics_changed`, Qhull per
   sample), with their agreement on the benchmark's samples.

4. **Push plan on a point support** (``model: limit_surface``, the exact limit
   surface of :mod:`kernels.limit_surface`, against ``model: quasistatic`` on
   the same draws, measured in the same run): the nice-stable pentagon's
   7-push default plan (start ``(0, 0, 0)``, goal ``PS_GOAL``), tolerances as
   in ``bench/throughput.py``'s study, support ``rigid`` (3-4 loaded corners)
   and ``any`` (every family, the pads of 25 and 24 feet included); the
   replay kernel (``robustness.replay.run_push``, its calls of at most
   ``LIMIT_SURFACE_CALL`` samples on every core, as evaluate() runs it) in
   float64, and float32's final poses against float64's.

The last line is
``RESULT push_samples_per_s=N tumble_steps_per_s=M tumble_eval_samples_per_s=K
ls_samples_per_s=L ls_any_samples_per_s=A ls_over_quasistatic=R``
(float64: the push kernel; the tumble replay in evaluate, steps = samples x
200; the whole evaluate() of the tumble plan; the limit-surface kernel on
rigid corners and on ``any``; R: how many times slower than the quasi-static
kernel on the same rigid draws).
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
# a CPU device per core, as nudge's command lines have (sweeps.terminal.run_main): a
# batch's compiled replays spread over them (robustness.replay.replay_devices)
os.environ.setdefault("JAX_NUM_CPU_DEVICES", str(len(os.sched_getaffinity(0))))

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from kernels import polygon as pg  # noqa: E402
from kernels.planar import rot2_np, wrap_angle_np  # noqa: E402
from planning import plan_pose  # noqa: E402
from robustness import ExecutionTolerance, FrictionRange, GeometryTolerance, Model, Sampler  # noqa: E402
from robustness import evaluation as ev_mod  # noqa: E402
from robustness import replay  # noqa: E402
from robustness.samplers import drawn_steps  # noqa: E402
from sweeps.partfile import load_part  # noqa: E402
from timing import best_of  # noqa: E402

TUMBLE_LEN = 200
PUSH_START = (0.0, 0.0, 0.0)
PUSH_GOALS = ((0.08, 0.03, 0.0), (0.08, 0.03, -2.0), (0.05, 0.05, 2.0), (0.08, 0.03, 1.0))

PS_GOAL = (0.05, 0.02, 1.0)       # the nice-stable pentagon's 7-push default plan


def point_support_sampler(support: str) -> Sampler:
    """The tolerances of ``bench/throughput.py``'s study on the given support family."""
    return Sampler(GeometryTolerance(tau_v=2e-5, tau_com=1e-4),
                   FrictionRange(mu_f=(0.5, 0.8), mu_s=(0.3, 0.5), support=support),
                   ExecutionTolerance(start_xy=5e-4, start_theta=0.01, fence_angle=0.002,
                                      distance_abs=1e-4, distance_rel=0.005))


PUSH_SAMPLER = Sampler(
    GeometryTolerance(tau_v=2e-5, tau_com=1e-4),
    FrictionRange(mu_f=(0.3, 0.8), mu_s=(0.2, 0.5), support_points=16),
    ExecutionTolerance(start_xy=5e-4, start_theta=0.01, fence_angle=0.002, distance_abs=1e-4,
                       distance_rel=0.005))
TUMBLE_SAMPLER = Sampler(GeometryTolerance(tau_v=1e-4),
                         execution=ExecutionTolerance(tumble_slip_xy=1e-5, tumble_slip_theta=1e-5))


# --------------------------------------------------------------------------
# numpy reference: the quasi-static oracle, per sample
# --------------------------------------------------------------------------
def numpy_push_plan(oracle, V0, com0, hull, start, angles, dists, dv, dc, dstart, dfence, drel,
                    dabs, c, mu, rtol):
    """A whole perturbed push plan with the numpy oracle (same conventions as
    :mod:`robustness.evaluation`): returns the reference pose (3,)."""
    V = V0 + dv
    com = com0 + dc
    body = V[hull] - com
    th0 = start[2] + dstart[2]
    pose = np.array([*(start[:2] + dstart[:2] + rot2_np(th0) @ dc), th0])
    for ang, dist, fa, rel, ab in zip(angles, dists, dfence, drel, dabs):
        a = ang + fa
        r = oracle.simulate_push(body, pose, (math.cos(a), math.sin(a)),
                                 max(dist * (1 + rel) + ab, 0.0), c, mu, rtol=rtol,
                                 atol=rtol * 1e-3)
        pose = np.asarray(r.pose, float)
    ref = pose[:2] - rot2_np(pose[2]) @ dc
    return np.array([ref[0], ref[1], pose[2]])


def six_push_plan():
    """The first plan of ``PUSH_GOALS`` with 6 pushes (the planner decides the count)."""
    part = load_part(ROOT / "examples" / "biplus_stable.yaml")
    plans = []
    for goal in PUSH_GOALS:
        plan = plan_pose(part.vertices, PUSH_START, goal, com=part.com)
        if plan.n_pushes == 6:
            return plan, goal
        plans.append((plan, goal))
    return plans[0]   # none has 6: the first (its push count is printed)


# --------------------------------------------------------------------------
# 1. push plan
# --------------------------------------------------------------------------
def push_bench(n: int, n_np: int, repeat: int) -> dict:
    plan, goal = six_push_plan()
    P = plan.n_pushes
    poly = pg.make_polygon(np.asarray(plan.vertices), np.asarray(plan.com))
    rows, finals = [], {}
    draws = PUSH_SAMPLER.sample(jax.random.key(0), n, n_vertices=len(plan.vertices),
                                dim=2, n_pushes=P, body=poly.body)
    jax.block_until_ready(draws.params)
    for dtype in (jnp.float64, jnp.float32):
        name = jnp.dtype(dtype).name

        def kernel():
            return replay.run_push(plan, draws, "quasistatic", dtype, 4096)

        t0 = time.perf_counter()
        _, _, res = kernel()
        first = time.perf_counter() - t0
        t = best_of(kernel, repeat)
        finals[name] = np.stack([res.x, res.y, res.theta], 1).astype(np.float64)
        rows.append(dict(method=f"jax vmap kernel {name}", n=n, seconds=t, rate=n / t, first=first))

        def full():
            return ev_mod.evaluate(plan, PUSH_SAMPLER, n, jax.random.key(1),
                                   model=Model("quasistatic", dtype=dtype), bound=False)

        t0 = time.perf_counter()
        full()
        first = time.perf_counter() - t0
        t = best_of(full, max(1, repeat - 1))
        rows.append(dict(method=f"jax evaluate() {name}", n=n, seconds=t, rate=n / t, first=first))
    from oracles import quasistatic_numpy as oracle

    p = draws.broadcast()
    angles = [math.atan2(q.direction[1], q.direction[0]) for q in plan.pushes]
    dists = [q.distance for q in plan.pushes]
    k = min(n_np, n)

    def loop(rtol):
        out = []
        for i in range(k):
            q = jax.tree_util.tree_map(lambda x: np.asarray(x[i]), p)
            out.append(numpy_push_plan(
                oracle, np.asarray(plan.vertices), np.asarray(plan.com), list(poly.hull_index),
                np.asarray(plan.start), angles, dists, q.geometry.vertex_offset,
                q.geometry.com_offset, q.execution.start_offset, q.execution.fence_angle,
                q.execution.distance_rel, q.execution.distance_abs, float(q.friction.c),
                float(q.friction.mu_f), rtol))
        return np.array(out)

    t0 = time.perf_counter()
    loop(1e-8)
    t_np = time.perf_counter() - t0
    rows.append(dict(method="numpy oracle loop (rtol 1e-8)", n=k, seconds=t_np, rate=k / t_np,
                     first=math.nan))
    tight = loop(1e-12)
    f64 = finals["float64"]
    scale = float(np.max(np.linalg.norm(poly.body, axis=1)))
    return dict(rows=rows, goal=goal, n_pushes=P, scale=scale,
                err_np_xy=float(np.max(np.abs(tight[:, :2] - f64[:k, :2]))),
                err_np_th=float(np.max(np.abs(wrap_angle_np(tight[:, 2] - f64[:k, 2])))),
                err32_xy=float(np.max(np.abs(finals["float32"][:, :2] - f64[:, :2]))))


# --------------------------------------------------------------------------
# 4. push plan on a point support
# --------------------------------------------------------------------------
def point_support_bench(n: int, repeat: int, float32: bool = True) -> dict:
    """Samples/s of the limit-surface and quasi-static kernels on the same draws
    (``float32``: the limit surface in float32 too, checked against float64)."""
    part = load_part(ROOT / "examples" / "nice_stable.yaml")
    plan = plan_pose(part.vertices, PUSH_START, PS_GOAL, com=part.com)
    poly = pg.make_polygon(np.asarray(plan.vertices), np.asarray(plan.com))
    rows, out = [], dict(n_pushes=plan.n_pushes)
    for support in ("rigid", "any"):
        draws = point_support_sampler(support).sample(
            jax.random.key(2), n, n_vertices=len(plan.vertices), dim=2, n_pushes=plan.n_pushes,
            body=poly.body)
        jax.block_until_ready(draws.params)
        finals = {}
        for model, dtype in (("quasistatic", jnp.float64), ("limit_surface", jnp.float64),
                             ("limit_surface", jnp.float32))[:3 if float32 else 2]:
            name = jnp.dtype(dtype).name

            def kernel():
                return replay.run_push(plan, draws, model, dtype, 4096)

            t0 = time.perf_counter()
            _, _, res = kernel()
            first = time.perf_counter() - t0
            t = best_of(kernel, repeat)
            finals[(model, name)] = np.stack([res.x, res.y, res.theta], 1).astype(np.float64)
            rows.append(dict(method=f"{model} {name}, support {support}", n=n, seconds=t,
                             rate=n / t, first=first, support=support, model=model, dtype=name))
        ls64, ls32 = finals[("limit_surface", "float64")], finals.get(("limit_surface", "float32"))
        qs = finals[("quasistatic", "float64")]
        out[f"err32_{support}"] = (float(np.max(np.abs(ls32[:, :2] - ls64[:, :2])))
                                   if ls32 is not None else float("nan"))
        out[f"models_apart_{support}"] = float(np.median(np.linalg.norm(ls64[:, :2] - qs[:, :2],
                                                                        axis=1)))
    out["rows"] = rows
    return out


# --------------------------------------------------------------------------
# 2. tumble plan, 3. hull check
# --------------------------------------------------------------------------
def tumble_plan_200():
    import yaml

    from kernels.polyhedron import PartWarning, make_polyhedron
    from kernels.tumble import make_config, replay as tumble_replay
    from planning.tumbling.plan import Tumble, TumblePlan

    doc = yaml.safe_load((ROOT / "examples" / "irregular_polyhedron.yaml").read_text())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PartWarning)
        P = make_polyhedron(doc["vertices"], doc.get("com"))
    rng = np.random.default_rng(0)
    seq, f = [], 0
    for _ in range(TUMBLE_LEN):
        g = int(rng.choice(P.neighbors(f)))
        seq.append(g)
        f = g
    fin, ok = tumble_replay(P.geometry(jnp.float64), make_config(0.0, 0.0, 0.0, 0), jnp.asarray(seq))
    pf = (float(fin.xy[0]), float(fin.xy[1]), float(fin.theta), int(fin.face))
    faces = [0] + seq
    plan = TumblePlan(vertices=tuple(map(tuple, P.vertices.tolist())), com=tuple(P.com.tolist()),
                      start=(0.0, 0.0, 0.0, 0), goal=pf, eps=1e-3, tau_v=0.0, tau_g=None,
                      tumbles=tuple(Tumble(edge=P.shared_edge(a, b), face=b)
                                    for a, b in zip(faces[:-1], faces[1:])),
                      predicted_final=pf, error=0.0, bounds={}, verdict="solved",
                      reason="benchmark random walk", reachable_class="dense",
                      n_tumbles_paper=TUMBLE_LEN)
    return P, plan


def tumble_bench(n: int, n_np: int, n_hull: int, repeat: int) -> dict:
    from kernels.tumble_geometry import tumble_geometry
    from kernels.tumble import make_config, replay as tumble_replay
    from oracles import tumble_numpy as oracle
    from robustness.hulls import face_merge_tol, polyhedra_changed, polyhedron_combinatorics_changed

    P, plan = tumble_plan_200()
    rows = []
    steps = n * TUMBLE_LEN
    # as evaluate() draws them: every slip column the sampler computes (208), no cut copy
    draws = TUMBLE_SAMPLER.sample(jax.random.key(0), n, n_vertices=len(plan.vertices),
                                  dim=3, n_tumbles=TUMBLE_LEN, exact_steps=False)
    jax.block_until_ready(draws.params)
    V = np.asarray(P.vertices)[None] + np.asarray(draws.params.geometry.vertex_offset)
    diam = float(np.max(np.linalg.norm(P.vertices[:, None] - P.vertices[None], axis=-1)))
    tol = face_merge_tol(TUMBLE_SAMPLER.geometry.tau_v, diam)
    seq = jnp.asarray(np.asarray(plan.faces, np.int32).reshape(-1))
    finals = {}
    for dtype in (jnp.float64, jnp.float32):
        name = jnp.dtype(dtype).name
        Vd, comd = jnp.asarray(V, dtype), jnp.asarray(P.com, dtype)
        build = jax.jit(jax.vmap(lambda v: tumble_geometry(v, comd, P.topology)))
        run = jax.jit(jax.vmap(tumble_replay, in_axes=(0, None, None)))
        geoms = jax.block_until_ready(build(Vd))
        cfg = make_config(0.0, 0.0, 0.0, 0, dtype=dtype)
        t0 = time.perf_counter()
        jax.block_until_ready(run(geoms, cfg, seq))
        first = time.perf_counter() - t0
        t = best_of(lambda: jax.block_until_ready(run(geoms, cfg, seq)), repeat)
        rows.append(dict(method=f"bare kernel vmap(replay) {name}", n=n, seconds=t,
                         rate=steps / t, first=first))
        for check in (False, True):
            def inside():
                return replay.run_tumble(plan, draws, dtype, 4096,
                                          merge_tol=tol if check else None,
                                          slip_theta=TUMBLE_SAMPLER.execution.tumble_slip_theta)

            t0 = time.perf_counter()
            _, res = inside()
            first = time.perf_counter() - t0
            t = best_of(inside, repeat)
            label = "+ hull check" if check else ""
            rows.append(dict(method=f"replay in evaluate {name} {label}".rstrip(), n=n, seconds=t,
                             rate=steps / t, first=first))
            finals[name] = np.stack([res.x, res.y], 1)
            if check and dtype == jnp.float64:
                changed_eval = res.changed
    full = dict(method="evaluate() float64 (samples/s)", n=n)

    def whole():
        return ev_mod.evaluate(plan, TUMBLE_SAMPLER, n, jax.random.key(1), bound=False)

    t0 = time.perf_counter()
    whole()
    full["first"] = time.perf_counter() - t0
    full["seconds"] = best_of(whole, max(1, repeat - 1))
    full["rate"] = n / full["seconds"]
    # the draws alone (the sampler's compiled call: vertex offsets and 3 x 208 slip
    # uniforms per sample, threefry): a floor under evaluate() as long as the
    # random stream (and so every table) stays what it is
    def draw_only():
        return jax.block_until_ready(TUMBLE_SAMPLER.sample(
            jax.random.key(1), n, n_vertices=len(plan.vertices), dim=3, n_tumbles=TUMBLE_LEN,
            exact_steps=False).params)

    draw_only()
    full["draws_rate"] = n / best_of(draw_only, repeat)
    # numpy oracle (no slip) on a subset
    k = min(n_np, n)
    t0 = time.perf_counter()
    for i in range(k):
        oracle.replay(V[i], P.com, P.topology.face_cycles, plan.start, list(plan.faces),
                      check_landing=False)
    t_np = time.perf_counter() - t0
    rows.append(dict(method="numpy oracle loop", n=k, seconds=t_np, rate=k * TUMBLE_LEN / t_np,
                     first=math.nan))
    # 3. the hull check: JAX against the host reference
    kh = min(n_hull, n)
    t0 = time.perf_counter()
    ref = polyhedron_combinatorics_changed(V[:kh], P, tol)
    t_ref = time.perf_counter() - t0
    polyhedra_changed(V, P, tol)
    t_jax = best_of(lambda: polyhedra_changed(V, P, tol), repeat)
    jx = polyhedra_changed(V[:kh], P, tol)
    # a harder set for the agreement: 13x the tolerance, where about half the samples change
    V2 = np.asarray(P.vertices)[None] + 13.0 * np.asarray(draws.params.geometry.vertex_offset[:kh])
    tol2 = face_merge_tol(13 * TUMBLE_SAMPLER.geometry.tau_v, diam)
    ref2, jx2 = polyhedron_combinatorics_changed(V2, P, tol2), polyhedra_changed(V2, P, tol2)
    return dict(rows=rows, full=full,
                hull=dict(ref_rate=kh / t_ref, jax_rate=n / t_jax, k=kh,
                          agree=int(np.sum(ref == jx)), changed=int(ref.sum()),
                          agree2=int(np.sum(ref2 == jx2)), changed2=int(ref2.sum()),
                          eval_agrees=bool(np.all(changed_eval[:kh] == ref))),
                err32_xy=float(np.max(np.abs(finals["float32"] - finals["float64"]))))


def print_table(title: str, rows: list, unit: str, ref_rate: float, ref: str = "x numpy") -> None:
    print(f"\n## {title}")
    hdr = f"{'method':38s} {'n':>7s} {'seconds':>9s} {unit:>14s} {ref:>8s} {'1st call s':>10s}"
    print(hdr)
    print("-" * len(hdr))
    for r in rows:
        print(f"{r['method']:38s} {r['n']:7d} {r['seconds']:9.4f} {r['rate']:14.4g} "
              f"{r['rate'] / ref_rate:8.4g} {r['first']:10.3f}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="small sizes (about a minute)")
    ap.add_argument("--samples", type=int, help="push samples (default 16384; quick 4096)")
    ap.add_argument("--tumble-samples", type=int, help="tumble samples (default 16384; quick 4096)")
    ap.add_argument("--numpy", type=int, help="samples in the numpy loops (default 64; quick 8)")
    ap.add_argument("--ls-samples", type=int,
                    help="samples of the point-support section (default 512; quick 128)")
    args = ap.parse_args(argv)
    q = args.quick
    n_push = args.samples or (4096 if q else 16384)
    n_tumble = args.tumble_samples or (4096 if q else 16384)
    n_np = args.numpy or (8 if q else 64)
    repeat = 2 if q else 3
    print(f"# bench/robustness.py {'--quick' if q else '(full)'}: jax {jax.__version__}, backend "
          f"{jax.default_backend()}, {os.cpu_count()} CPUs, {len(jax.devices())} devices (a batch's "
          "calls spread over them; JAX_NUM_CPU_DEVICES=1: one core) (no accelerator lent to this "
          "task: CPU figures only); quasi-static kernel: event-driven, closed-form phases")
    pr = push_bench(n_push, n_np, repeat)
    np_rate = pr["rows"][-1]["rate"]
    print_table(f"{pr['n_pushes']}-push plan (goal {pr['goal']}), quasi-static model (samples/s)",
                pr["rows"], "samples/s", np_rate)
    print(f"accuracy: float64 kernel vs the numpy oracle at rtol 1e-12 (first "
          f"{pr['rows'][-1]['n']} samples): max |dxy| {pr['err_np_xy']:.2e} m "
          f"({pr['err_np_xy'] / pr['scale']:.1e} of the part's radius), max |dtheta| "
          f"{pr['err_np_th']:.2e} rad (the former 64-step RK4 kernel: 8.9e-7 m); float32 vs "
          f"float64: max |dxy| {pr['err32_xy']:.2e} m")
    tr = tumble_bench(n_tumble, n_np, n_np * 8, repeat)
    np_rate_t = tr["rows"][-1]["rate"]
    print_table(f"{TUMBLE_LEN}-tumble plan (steps/s = samples x {TUMBLE_LEN} / s)", tr["rows"],
                "steps/s", np_rate_t)
    f = tr["full"]
    print(f"evaluate() of the plan, float64, vertex tolerance and slips: {f['rate']:.4g} "
          f"samples/s = {f['rate'] * TUMBLE_LEN:.4g} steps/s ({f['rate'] * TUMBLE_LEN / np_rate_t:.1f}"
          f" x numpy); the draws alone (threefry, 3 x {drawn_steps(TUMBLE_LEN)} slip uniforms a sample): "
          f"{f['draws_rate']:.4g} samples/s, the ceiling of evaluate() with this random stream")
    h = tr["hull"]
    print(f"hull check of the perturbed hulls: JAX {h['jax_rate']:.4g} samples/s, host reference "
          f"(Qhull) {h['ref_rate']:.4g} samples/s ({h['jax_rate'] / h['ref_rate']:.0f} x); "
          f"agreement {h['agree']}/{h['k']} ({h['changed']} changed) at the bench's tolerance, "
          f"{h['agree2']}/{h['k']} ({h['changed2']} changed) at 13 x; evaluate()'s check equals "
          f"the reference: {h['eval_agrees']}")
    print(f"float32 vs float64 tumble replay: max |dxy| {tr['err32_xy']:.2e} m")
    n_ls = args.ls_samples or (128 if q else 512)
    ps = point_support_bench(n_ls, repeat, float32=not q)   # --quick: float64 only

    def rate(support, model, dtype="float64"):
        return next(r["rate"] for r in ps["rows"] if (r["support"], r["model"], r["dtype"])
                    == (support, model, dtype))

    qs_rigid = rate("rigid", "quasistatic")
    print_table(f"{ps['n_pushes']}-push plan of the nice-stable pentagon (goal {PS_GOAL}) on a point "
                "support (samples/s; ratio to quasistatic float64 on rigid draws)", ps["rows"],
                "samples/s", qs_rigid, ref="x qs")
    for support in ("rigid", "any"):
        e32 = ps[f"err32_{support}"]
        print(f"support {support}: limit_surface {rate(support, 'quasistatic') / rate(support, 'limit_surface'):.0f} x "
              f"slower than quasistatic on the same draws; float32 vs float64 final positions: "
              + (f"max {e32:.1e} m" if e32 == e32 else "not run (--quick)")
              + f"; the two models' final positions apart (median): "
              f"{ps[f'models_apart_{support}']:.1e} m")
    push_rate = pr["rows"][0]["rate"]
    tumble_rate = next(r["rate"] for r in tr["rows"] if r["method"] == "replay in evaluate float64")
    print(f"RESULT push_samples_per_s={push_rate:.0f} tumble_steps_per_s={tumble_rate:.0f} "
          f"tumble_eval_samples_per_s={f['rate']:.0f} "
          f"ls_samples_per_s={rate('rigid', 'limit_surface'):.0f} "
          f"ls_any_samples_per_s={rate('any', 'limit_surface'):.1f} "
          f"ls_over_quasistatic={qs_rigid / rate('rigid', 'limit_surface'):.0f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
