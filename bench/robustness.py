"""Benchmark: Monte-Carlo evaluation of plans on perturbed parts.

Run by hand from the repository root (no assertions on time)::

    python bench/robustness.py            # full sizes
    python bench/robustness.py --quick    # small sizes, well under a minute

Two workloads, each comparing the JAX path (jit + vmap over samples) with a
plain-numpy per-sample loop in the same run:

1. **Push plan, quasi-static model**: a 6-push plan of the biplus-stable
   triangle (``examples/biplus_stable.yaml``, start ``(0, 0, 0)``, goal
   ``(0.08, 0.03, 0)``); every sample perturbs the vertices (+-0.02 mm), the
   centre of mass (0.1 mm disc), fence friction (0.3..0.8), the support
   pressure (16 points -> c), the start pose, every fence angle and push
   distance (the example certification config's tolerances).  JAX:
   :func:`kernels.quasistatic.simulate_pushes` vmapped over the samples
   (``--steps`` integration steps per push), float64 and float32; "kernel"
   times the compiled batch on pre-drawn parameters, "evaluate()" the whole
   :func:`robustness.evaluation.evaluate` call (sampling, kernel, table and
   summary; the analytic bound excluded).  numpy: the quasi-static oracle
   ``tests/oracles/quasistatic_numpy.py`` (world-frame mechanics integrated by
   ``scipy.integrate.solve_ivp`` DOP853, rtol 1e-8, with landing events) per
   sample in a Python loop on a subset, scaled to samples/s; its final poses
   are compared with the float64 kernel's (the kernel's fixed-step error).
   float32 runs the same draws as float64 (cast).
2. **Tumble plan**: a 200-tumble face sequence (seeded random walk) on
   ``examples/irregular_polyhedron.yaml``, vertices perturbed by +-0.1 mm and a
   planar slip after every tumble.  JAX: the vmapped replay of
   :mod:`robustness.evaluation` (``jax.vmap(tumble_geometry)`` + a scan of
   :func:`kernels.tumble.tumble` with slip and the nominal-frame conversion),
   float64 and float32, in tumble-steps/s (samples x 200 / s).  numpy: the
   oracle ``tests/oracles/tumble_numpy.py`` (3-D rotations, no slip) per sample
   on a subset.  The host-side combinatorics check of every perturbed hull
   (part of ``evaluate()``) is timed separately.

Prints a table of rates and ratios; the last line is
``RESULT push_samples_per_s=N tumble_steps_per_s=M`` (float64 kernels).
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
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from kernels import polygon as pg  # noqa: E402
from kernels.planar import rot2_np, wrap_angle_np  # noqa: E402
from planning import plan_pose  # noqa: E402
from robustness import ExecutionTolerance, FrictionRange, GeometryTolerance, Sampler  # noqa: E402
from robustness import evaluation as ev_mod  # noqa: E402
from robustness.samplers import broadcast  # noqa: E402
from sweeps.partfile import load_part  # noqa: E402
from timing import best_of  # noqa: E402

TUMBLE_LEN = 200
PUSH_START, PUSH_GOAL = (0.0, 0.0, 0.0), (0.08, 0.03, 0.0)

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


# --------------------------------------------------------------------------
# 1. push plan
# --------------------------------------------------------------------------
def push_bench(n: int, n_np: int, steps: int, repeat: int) -> dict:
    part = load_part(ROOT / "examples" / "biplus_stable.yaml")
    plan = plan_pose(part.vertices, PUSH_START, PUSH_GOAL, com=part.com)
    assert plan.n_pushes == 6, plan.n_pushes
    poly = pg.make_polygon(np.asarray(plan.vertices), np.asarray(plan.com))
    rows, finals = [], {}
    params64, ax64 = PUSH_SAMPLER.sample(jax.random.key(0), n, n_vertices=len(plan.vertices),
                                         dim=2, n_pushes=6, body=poly.body)
    for dtype in (jnp.float64, jnp.float32):
        name = jnp.dtype(dtype).name
        # the same draws in both dtypes (drawing in float32 would give other samples)
        params = jax.tree_util.tree_map(lambda x: jnp.asarray(x, dtype), params64)
        ax = ax64
        jax.block_until_ready(params)

        def kernel():
            return ev_mod._run_push(plan, params, ax, n, "quasistatic", steps, dtype, n)

        t0 = time.perf_counter()
        _, _, res = kernel()
        first = time.perf_counter() - t0
        t = best_of(kernel, repeat)
        finals[name] = np.stack([res["x"], res["y"], res["theta"]], 1).astype(np.float64)
        rows.append(dict(method=f"jax vmap kernel {name}", n=n, seconds=t, rate=n / t, first=first))

        def full():
            return ev_mod.evaluate(plan, PUSH_SAMPLER, n, jax.random.key(1), model="quasistatic",
                                   dtype=dtype, n_steps=steps, chunk=n, bound=False)

        full()
        t = best_of(full, max(1, repeat - 1))
        rows.append(dict(method=f"jax evaluate() {name}", n=n, seconds=t, rate=n / t,
                         first=math.nan))
    # numpy loop on a subset: the quasi-static oracle (adaptive DOP853, rtol 1e-8)
    from oracles import quasistatic_numpy as oracle

    p = broadcast(params64, ax64, n)
    angles = [math.atan2(q.direction[1], q.direction[0]) for q in plan.pushes]
    dists = [q.distance for q in plan.pushes]
    k = min(n_np, n)
    out = []
    t0 = time.perf_counter()
    for i in range(k):
        q = jax.tree_util.tree_map(lambda x: np.asarray(x[i]), p)
        out.append(numpy_push_plan(
            oracle, np.asarray(plan.vertices), np.asarray(plan.com), list(poly.hull_index),
            np.asarray(plan.start), angles, dists, q.geometry.vertex_offset,
            q.geometry.com_offset, q.execution.start_offset, q.execution.fence_angle,
            q.execution.distance_rel, q.execution.distance_abs, float(q.friction.c),
            float(q.friction.mu_f), 1e-8))
    t_np = time.perf_counter() - t0
    rows.append(dict(method="numpy oracle loop", n=k, seconds=t_np, rate=k / t_np, first=math.nan))
    out = np.array(out)
    f64 = finals["float64"]
    dth = wrap_angle_np(out[:, 2] - f64[:k, 2])
    return dict(rows=rows, steps=steps,
                err_np_xy=float(np.max(np.abs(out[:, :2] - f64[:k, :2]))),
                err_np_th=float(np.max(np.abs(dth))),
                err32_xy=float(np.max(np.abs(finals["float32"][:, :2] - f64[:, :2]))))


# --------------------------------------------------------------------------
# 2. tumble plan
# --------------------------------------------------------------------------
def tumble_plan_200():
    import yaml

    from kernels.polyhedron import PartWarning, make_polyhedron
    from kernels.tumble import make_config, replay
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
    fin, ok = replay(P.geometry(jnp.float64), make_config(0.0, 0.0, 0.0, 0), jnp.asarray(seq))
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
    from robustness.hulls import face_merge_tol, polyhedron_combinatorics_changed
    from oracles import tumble_numpy as oracle

    P, plan = tumble_plan_200()
    rows, finals = [], {}
    steps = n * TUMBLE_LEN
    params64, ax = TUMBLE_SAMPLER.sample(jax.random.key(0), n, n_vertices=len(plan.vertices),
                                         dim=3, n_tumbles=TUMBLE_LEN)
    for dtype in (jnp.float64, jnp.float32):
        name = jnp.dtype(dtype).name
        params = jax.tree_util.tree_map(lambda x: jnp.asarray(x, dtype), params64)
        jax.block_until_ready(params)

        def kernel():
            return ev_mod._run_tumble(plan, params, ax, n, dtype, n)

        t0 = time.perf_counter()
        _, res = kernel()
        first = time.perf_counter() - t0
        t = best_of(kernel, repeat)
        finals[name] = np.stack([res["x"], res["y"], res["theta"]], 1).astype(np.float64)
        rows.append(dict(method=f"jax vmap kernel {name}", n=n, seconds=t, rate=steps / t,
                         first=first))
    # host-side combinatorics check (part of evaluate() for a vertex tolerance)
    V = np.asarray(P.vertices)[None] + np.asarray(params64.geometry.vertex_offset)
    diam = float(np.max(np.linalg.norm(P.vertices[:, None] - P.vertices[None], axis=-1)))
    k = min(n_hull, n)
    t0 = time.perf_counter()
    polyhedron_combinatorics_changed(V[:k], P, face_merge_tol(1e-4, diam))
    t_hull = time.perf_counter() - t0
    hull_rate = k / t_hull
    # numpy oracle (no slip) on a subset, against the float64 kernel without slip
    k = min(n_np, n)
    t0 = time.perf_counter()
    out = []
    for i in range(k):
        fin, _ = oracle.replay(V[i], P.com, P.topology.face_cycles, plan.start,
                               list(plan.faces), check_landing=False)
        out.append(fin[:3])
    t_np = time.perf_counter() - t0
    rows.append(dict(method="numpy oracle loop", n=k, seconds=t_np, rate=k * TUMBLE_LEN / t_np,
                     first=math.nan))
    no_slip = Sampler(TUMBLE_SAMPLER.geometry)
    p2, ax2 = no_slip.sample(jax.random.key(0), k, n_vertices=len(plan.vertices), dim=3,
                             n_tumbles=TUMBLE_LEN)
    # same vertex draws as above (the geometry group has its own sub-key, same layout)
    _, res = ev_mod._run_tumble(plan, p2, ax2, k, jnp.float64, k)
    # the kernel reports nominal face frames, the oracle perturbed ones: compare the spread
    # of both around the nominal final pose instead of sample by sample
    kern = np.stack([res["x"], res["y"]], 1)
    orc = np.asarray(out)[:, :2]
    spread = (float(np.max(np.linalg.norm(kern - np.asarray(plan.goal[:2]), axis=1))),
              float(np.max(np.linalg.norm(orc - np.asarray(plan.goal[:2]), axis=1))))
    f64 = finals["float64"]
    return dict(rows=rows, spread=spread, hull_rate=hull_rate,
                err32_xy=float(np.max(np.abs(finals["float32"][:, :2] - f64[:, :2]))))


def print_table(title: str, rows: list, unit: str, ref_rate: float) -> None:
    print(f"\n## {title}")
    hdr = f"{'method':30s} {'n':>7s} {'seconds':>9s} {unit:>14s} {'x numpy':>8s} {'1st call s':>10s}"
    print(hdr)
    print("-" * len(hdr))
    for r in rows:
        print(f"{r['method']:30s} {r['n']:7d} {r['seconds']:9.4f} {r['rate']:14.4g} "
              f"{r['rate'] / ref_rate:8.1f} {r['first']:10.3f}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="small sizes (< 1 min)")
    ap.add_argument("--samples", type=int, help="push samples (default 16384; quick 2048)")
    ap.add_argument("--tumble-samples", type=int, help="tumble samples (default 8192; quick 1024)")
    ap.add_argument("--numpy", type=int, help="samples in the numpy loops (default 64; quick 8)")
    ap.add_argument("--steps", type=int, default=64,
                    help="quasi-static steps per push (default 64, as evaluate() and certify)")
    args = ap.parse_args(argv)
    q = args.quick
    n_push = args.samples or (2048 if q else 16384)
    n_tumble = args.tumble_samples or (1024 if q else 8192)
    n_np = args.numpy or (8 if q else 64)
    repeat = 2 if q else 3
    print(f"# bench/robustness.py {'--quick' if q else '(full)'}: jax {jax.__version__}, backend "
          f"{jax.default_backend()}, {os.cpu_count()} CPUs, {args.steps} quasi-static steps/push")
    pr = push_bench(n_push, n_np, args.steps, repeat)
    np_rate = pr["rows"][-1]["rate"]
    print_table("6-push plan, quasi-static model (samples/s)", pr["rows"], "samples/s", np_rate)
    print(f"numpy oracle vs float64 kernel (first {pr['rows'][-1]['n']} samples): max |dxy| "
          f"{pr['err_np_xy']:.2e} m, max |dtheta| {pr['err_np_th']:.2e} rad; float32 vs float64: "
          f"max |dxy| {pr['err32_xy']:.2e} m")
    tr = tumble_bench(n_tumble, n_np, n_np * 4, repeat)
    np_rate_t = tr["rows"][-1]["rate"]
    print_table(f"{TUMBLE_LEN}-tumble plan (tumble-steps/s = samples x {TUMBLE_LEN} / s)",
                tr["rows"], "steps/s", np_rate_t)
    print(f"host-side combinatorics check of the perturbed hulls (part of evaluate() with a "
          f"vertex tolerance): {tr['hull_rate']:.4g} samples/s")
    print(f"float32 vs float64: max |dxy| {tr['err32_xy']:.2e} m; spread of final positions "
          f"about the plan's goal, kernel {tr['spread'][0]:.2e} m / numpy oracle "
          f"{tr['spread'][1]:.2e} m")
    push_rate = pr["rows"][0]["rate"]
    tumble_rate = tr["rows"][0]["rate"]
    print(f"RESULT push_samples_per_s={push_rate:.0f} tumble_steps_per_s={tumble_rate:.0f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
