"""Benchmark: how the cost of a Monte-Carlo evaluation grows with the work, so
that a user can size a study.

Run by hand from the repository root (no assertions on time)::

    python bench/scaling.py            # full sweep, several minutes
    python bench/scaling.py --quick    # fewer points

Three sweeps of :func:`robustness.evaluation.evaluate` (the whole call:
sampling, compiled replay, per-sample table, summary; the analytic bound
excluded), float64, quasi-static model for push plans:

* **batch size** 1 .. 10^6 samples: the 6-push plan of ``bench/robustness.py``
  (biplus-stable triangle, its tolerances); the 200-tumble plan up to 10^5
  (a tumble sample draws 600 slip numbers: ~10 KB a sample, 10 GB at 10^6);
* **polygon vertex count** 3 .. 32 (random convex polygons on an ellipse,
  the planner's plan cycled to 6 pushes), 2^14 samples;
* **plan length** 1 .. 50 pushes (the 6-push plan's pushes cycled) and
  10 .. 1000 tumbles (random walks on ``examples/irregular_polyhedron.yaml``),
  2^14 / 2^12 samples.

Each point runs in its own process, so that its peak memory (the process's
peak resident set size, ``ru_maxrss``) is its own; "base" is the same
process before its first evaluation (Python, JAX, the part and the plan).
Each rate is the best of a few calls after a warm-up call (which compiles);
beside it the same configuration's numpy oracle per-sample loop
(``oracles/``), measured in the same process, and their ratio.  The device is
the CPU (no accelerator is lent to this benchmark's task).

Writes ``results/scaling/scaling.csv`` and ``results/scaling/scaling.png``
(log-log); prints the table, where each curve bends and why, and last
``RESULT push_samples_per_s_at_1e5=N peak_mb_at_1e6=M``.
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import math
import os
import pathlib
import resource
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
OUT = ROOT / "results" / "scaling"
# first, even when ROOT is already on PYTHONPATH: the package ``robustness`` must win
# over bench/robustness.py (this script's folder is sys.path[0])
sys.path.insert(0, str(ROOT))


def _bench_robustness():
    """``bench/robustness.py`` as a module (its name would shadow the package)."""
    spec = importlib.util.spec_from_file_location("bench_robustness",
                                                  ROOT / "bench" / "robustness.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0   # kB on Linux


# --------------------------------------------------------------------------
# one configuration, in its own process
# --------------------------------------------------------------------------
def _polygon(n: int):
    """A convex n-gon on an ellipse (40 x 25 mm), seeded angle jitter."""
    import numpy as np

    rng = np.random.default_rng(n)
    ang = np.sort((np.arange(n) + rng.uniform(-0.3, 0.3, n)) * 2 * math.pi / n)
    return [[0.02 * math.cos(a), 0.0125 * math.sin(a)] for a in ang]


def _cycled(plan, k: int):
    """The plan's pushes cycled to ``k`` pushes (the evaluation's cost is what is
    measured; the goal, the last predicted pose, is only used for the errors)."""
    import dataclasses

    pushes = tuple(plan.pushes[i % plan.n_pushes] for i in range(k))
    return dataclasses.replace(plan, pushes=pushes, goal=tuple(pushes[-1].pose_after))


def _push_case(cfg: dict, br):
    from planning import plan_pose

    if cfg.get("verts", 3) == 3:
        plan, _ = br.six_push_plan()
    else:
        plan = plan_pose(_polygon(cfg["verts"]), (0.0, 0.0, 0.0), (0.08, 0.03, 1.0))
    return _cycled(plan, cfg.get("pushes", 6))


def _tumble_case(cfg: dict, br):
    import dataclasses

    import jax.numpy as jnp
    import numpy as np

    from kernels.tumble import make_config, replay

    P, plan = br.tumble_plan_200()
    L = cfg.get("tumbles", 200)
    if L == 200:
        return P, plan
    rng = np.random.default_rng(L)
    seq, f = [], 0
    for _ in range(L):
        f = int(rng.choice(P.neighbors(f)))
        seq.append(f)
    fin, _ = replay(P.geometry(jnp.float64), make_config(0.0, 0.0, 0.0, 0), jnp.asarray(seq))
    pf = (float(fin.xy[0]), float(fin.xy[1]), float(fin.theta), int(fin.face))
    faces = [0] + seq
    tumbles = tuple(type(plan.tumbles[0])(edge=P.shared_edge(a, b), face=b)
                    for a, b in zip(faces[:-1], faces[1:]))
    return P, dataclasses.replace(plan, tumbles=tumbles, goal=pf, predicted_final=pf,
                                  n_tumbles_paper=L)


def worker(cfg: dict) -> dict:
    """Time one configuration; returns the row (rates in samples/s)."""
    import jax

    jax.config.update("jax_enable_x64", True)
    import numpy as np

    from robustness import evaluation as ev_mod

    br = _bench_robustness()
    n = int(cfg["n"])
    if cfg["kind"] == "push":
        plan = _push_case(cfg, br)
        sampler = br.PUSH_SAMPLER
        steps = plan.n_pushes
    else:
        P, plan = _tumble_case(cfg, br)
        sampler = br.TUMBLE_SAMPLER
        steps = plan.n_tumbles
    base = _peak_mb()

    def run():
        return ev_mod.evaluate(plan, sampler, n, jax.random.key(1), bound=False)

    t0 = time.perf_counter()
    run()
    first = time.perf_counter() - t0
    repeat = 3 if n <= 10_000 else (2 if n <= 100_000 else 1)
    best = math.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        run()
        best = min(best, time.perf_counter() - t0)
    peak = _peak_mb()
    # the numpy oracle on a few samples of the same configuration
    k = 3 if steps <= 100 else 2
    if cfg["kind"] == "push":
        from kernels import polygon as pg
        from oracles import quasistatic_numpy as oracle

        poly = pg.make_polygon(np.asarray(plan.vertices), np.asarray(plan.com))
        draws = sampler.sample(jax.random.key(0), k, n_vertices=len(plan.vertices), dim=2,
                               n_pushes=steps, body=poly.body)
        p = draws.broadcast()
        angles = [math.atan2(q.direction[1], q.direction[0]) for q in plan.pushes]
        dists = [q.distance for q in plan.pushes]
        t0 = time.perf_counter()
        for i in range(k):
            q = jax.tree_util.tree_map(lambda x: np.asarray(x[i]), p)
            br.numpy_push_plan(oracle, np.asarray(plan.vertices), np.asarray(plan.com),
                               list(poly.hull_index), np.asarray(plan.start), angles, dists,
                               q.geometry.vertex_offset, q.geometry.com_offset,
                               q.execution.start_offset, q.execution.fence_angle,
                               q.execution.distance_rel, q.execution.distance_abs,
                               float(q.friction.c), float(q.friction.mu_f), 1e-8)
        t_np = time.perf_counter() - t0
    else:
        from oracles import tumble_numpy as oracle

        V = np.asarray(P.vertices)
        t0 = time.perf_counter()
        for i in range(k):
            oracle.replay(V, P.com, P.topology.face_cycles, plan.start, list(plan.faces),
                          check_landing=False)
        t_np = time.perf_counter() - t0
    return dict(cfg, steps=steps, rate=n / best, seconds=best, first=first, base_mb=base,
                peak_mb=peak, np_rate=k / t_np)


def _run(cfg: dict) -> dict:
    out = subprocess.run([sys.executable, __file__, "--worker", json.dumps(cfg)],
                         capture_output=True, text=True, cwd=ROOT)
    for line in out.stdout.splitlines()[::-1]:
        if line.startswith("{"):
            return json.loads(line)
    raise RuntimeError(f"worker {cfg} failed:\n{out.stdout[-2000:]}\n{out.stderr[-4000:]}")


# --------------------------------------------------------------------------
# the sweeps, the table, the figure
# --------------------------------------------------------------------------
def sweeps(quick: bool) -> list:
    cfgs = []
    for n in ([1, 100, 10_000, 100_000, 1_000_000] if quick
              else [1, 10, 100, 1000, 10_000, 100_000, 1_000_000]):
        cfgs.append(dict(sweep="batch", kind="push", n=n))
    for n in ([1, 100, 10_000] if quick else [1, 10, 100, 1000, 10_000, 100_000]):
        cfgs.append(dict(sweep="batch", kind="tumble", n=n))
    for v in ([3, 8, 32] if quick else [3, 4, 6, 8, 12, 16, 24, 32]):
        cfgs.append(dict(sweep="vertices", kind="push", n=16384, verts=v))
    for k in ([1, 6, 50] if quick else [1, 2, 4, 6, 10, 20, 35, 50]):
        cfgs.append(dict(sweep="length", kind="push", n=16384, pushes=k))
    for L in ([10, 100, 1000] if quick else [10, 30, 100, 300, 1000]):
        cfgs.append(dict(sweep="length", kind="tumble", n=4096, tumbles=L))
    return cfgs


def _label(r: dict) -> str:
    if r["sweep"] == "batch":
        return f"{r['kind']} batch n={r['n']}"
    if r["sweep"] == "vertices":
        return f"push {r['verts']}-gon"
    return f"{r['kind']} length {r['steps']}"


def print_table(rows: list) -> None:
    hdr = (f"{'configuration':24s} {'samples':>8s} {'steps':>6s} {'samples/s':>11s} "
           f"{'steps/s':>11s} {'numpy/s':>9s} {'x numpy':>8s} {'base MB':>8s} {'peak MB':>8s} "
           f"{'1st call s':>10s}")
    print(hdr)
    print("-" * len(hdr))
    for r in rows:
        print(f"{_label(r):24s} {r['n']:8d} {r['steps']:6d} {r['rate']:11.4g} "
              f"{r['rate'] * r['steps']:11.4g} {r['np_rate']:9.3g} {r['rate'] / r['np_rate']:8.0f} "
              f"{r['base_mb']:8.0f} {r['peak_mb']:8.0f} {r['first']:10.2f}")


def _slope(a: dict, b: dict, x: str) -> float:
    """Log-log slope of the cost per sample (1 / rate) between two points."""
    return math.log(a["rate"] / b["rate"]) / math.log(b[x] / a[x])


def bends(rows: list) -> list:
    """Where each curve bends, from the measured points (text lines)."""
    out = []
    push = sorted((r for r in rows if r["sweep"] == "batch" and r["kind"] == "push"),
                  key=lambda r: r["n"])
    if push:
        top = max(push, key=lambda r: r["rate"])
        half = next(r for r in push if r["rate"] >= 0.5 * top["rate"])
        out.append(f"batch size (6 pushes): samples/s grow ~ n while a call's fixed cost "
                   f"dominates (~{push[0]['seconds'] * 1e3:.0f} ms with one sample: part and "
                   "plan checks, dispatch of the compiled sampler and kernel, the table, the "
                   f"summary); half the plateau is reached at ~{half['n']} samples, the plateau "
                   f"(~{top['rate']:.3g} samples/s) at {top['n']}: compiled calls are then full "
                   "(chunks of 4096, blocks of 512).")
        big = [r for r in push if r["n"] >= 100_000]
        if len(big) >= 2:
            a, b = big[-2], big[-1]
            per = (b["peak_mb"] - a["peak_mb"]) / (b["n"] - a["n"]) * 1e6 / 1024
            out.append(f"memory (6 pushes): flat at the process's base (~{push[0]['peak_mb']:.0f} "
                       "MB: Python, JAX, compiled code) up to ~1e4 samples, then linear, "
                       f"~{per:.1f} KB a sample (the drawn parameters, the per-sample kernel "
                       "inputs and outputs and the table's ~60 columns of 8 bytes; the kernel "
                       f"works in chunks); at {b['n']:.0e} samples the rate falls to "
                       f"{b['rate']:.3g}/s (memory traffic of the table).")
    tum = sorted((r for r in rows if r["sweep"] == "batch" and r["kind"] == "tumble"),
                 key=lambda r: r["n"])
    if tum:
        top = max(tum, key=lambda r: r["rate"])
        out.append(f"batch size (200 tumbles): the same bend (half the plateau by "
                   f"~{next(r for r in tum if r['rate'] >= 0.5 * top['rate'])['n']} samples), "
                   f"plateau ~{top['rate']:.3g} samples/s: a sample draws 600 slip numbers "
                   "(threefry, ~40 ns each on this CPU: ~24 us), more than its whole replay "
                   f"(~11 us with geometry and hull check, bench/robustness.py); memory ~{(tum[-1]['peak_mb'] - tum[-2]['peak_mb']) / (tum[-1]['n'] - tum[-2]['n']) * 1e6 / 1024:.0f}"
                   " KB a sample (the slips), so 10^6 samples need ~20 GB: split them.")
    vs = sorted((r for r in rows if r["sweep"] == "vertices"), key=lambda r: r["verts"])
    if len(vs) >= 2:
        a, b = vs[0], vs[-1]
        out.append(f"vertex count {a['verts']} -> {b['verts']}: cost a sample x"
                   f"{a['rate'] / b['rate']:.2f} (log-log slope {_slope(a, b, 'verts'):.2f}): "
                   "nearly flat; a contact phase gathers O(1) vertex data, so the cost follows "
                   "the number of phases (landings, friction switches), not n; the O(n) parts "
                   "(geometry, hull check, initial contact) are small.")
    ln = sorted((r for r in rows if r["sweep"] == "length" and r["kind"] == "push"),
                key=lambda r: r["steps"])
    if len(ln) >= 3:
        a, m, b = ln[0], ln[len(ln) // 2], ln[-1]
        out.append(f"pushes {a['steps']} -> {m['steps']} -> {b['steps']}: log-log slope "
                   f"{_slope(a, m, 'steps'):.2f} then {_slope(m, b, 'steps'):.2f}: the fixed "
                   "per-sample cost (sampling, geometry, table) dominates short plans; from "
                   f"~{m['steps']} pushes the cost is linear, ~{1e6 / b['rate'] / b['steps']:.1f} us "
                   "a push a sample; padding to a length bucket is skipped (lax.cond), so "
                   "there are no steps at powers of two.")
    lt = sorted((r for r in rows if r["sweep"] == "length" and r["kind"] == "tumble"),
                key=lambda r: r["steps"])
    if len(lt) >= 3:
        a, m, b = lt[0], lt[len(lt) // 2], lt[-1]
        out.append(f"tumbles {a['steps']} -> {m['steps']} -> {b['steps']}: log-log slope "
                   f"{_slope(a, m, 'steps'):.2f} then {_slope(m, b, 'steps'):.2f}: below ~100 "
                   "tumbles the per-sample geometry, hull check and vertex draws dominate; "
                   f"above, ~{1e6 / b['rate'] / b['steps']:.2f} us a tumble a sample, mostly "
                   "its 3 slip draws (the replay itself composes 2x2 rotations, ~0.05 us a "
                   "tumble, bench/robustness.py).")
    return out


def figure(rows: list, path: pathlib.Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter, ScalarFormatter

    colour = {"push": "C0", "tumble": "C1"}
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.8))
    ax = axes[0]
    for kind, mk in (("push", "o"), ("tumble", "s")):
        rs = sorted((r for r in rows if r["sweep"] == "batch" and r["kind"] == kind),
                    key=lambda r: r["n"])
        if rs:
            label = "6-push plan" if kind == "push" else "200-tumble plan"
            ax.loglog([r["n"] for r in rs], [r["rate"] for r in rs], mk + "-", color=colour[kind],
                      label=f"{label}: evaluate()")
            ax.axhline(rs[0]["np_rate"], ls=":", color=colour[kind], label=f"{label}: numpy oracle")
    ax2 = ax.twinx()
    rs = sorted((r for r in rows if r["sweep"] == "batch" and r["kind"] == "push"),
                key=lambda r: r["n"])
    ax2.loglog([r["n"] for r in rs], [r["peak_mb"] for r in rs], "k--", label="6-push: peak MB")
    rs = sorted((r for r in rows if r["sweep"] == "batch" and r["kind"] == "tumble"),
                key=lambda r: r["n"])
    ax2.loglog([r["n"] for r in rs], [r["peak_mb"] for r in rs], "--", color="0.55",
               label="200-tumble: peak MB")
    ax2.set_ylabel("peak resident memory of the process, MB")
    ax.set_xlabel("samples per evaluate() call")
    ax.set_ylabel("samples / s")
    ax.set_title("batch size")
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, fontsize=7, loc="upper left")
    ax = axes[1]
    rs = sorted((r for r in rows if r["sweep"] == "vertices"), key=lambda r: r["verts"])
    vx = [r["verts"] for r in rs]
    ax.loglog(vx, [r["rate"] for r in rs], "o-", color="C0", label="evaluate()")
    ax.loglog(vx, [r["np_rate"] for r in rs], "o:", color="C0", label="numpy oracle")
    ax.set_xticks(vx)
    ax.xaxis.set_major_formatter(ScalarFormatter())
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel("polygon vertices")
    ax.set_ylabel("samples / s (6-push plan)")
    ax.set_title("vertex count")
    ax.legend(fontsize=7)
    ax = axes[2]
    for kind, mk in (("push", "o"), ("tumble", "s")):
        rs = sorted((r for r in rows if r["sweep"] == "length" and r["kind"] == kind),
                    key=lambda r: r["steps"])
        if rs:
            what = "pushes" if kind == "push" else "tumbles"
            ax.loglog([r["steps"] for r in rs], [r["rate"] for r in rs], mk + "-",
                      color=colour[kind], label=f"{what}: evaluate()")
            ax.loglog([r["steps"] for r in rs], [r["np_rate"] for r in rs], mk + ":",
                      color=colour[kind], label=f"{what}: numpy oracle")
    ax.set_xlabel("plan length (pushes or tumbles)")
    ax.set_ylabel("samples / s")
    ax.set_title("plan length")
    ax.legend(fontsize=7)
    for a in axes:
        a.grid(True, which="both", alpha=0.3)
    fig.suptitle("nudge Monte-Carlo evaluation (whole evaluate() call, float64) on the CPU, 2 cores: "
                 "cost against work; dotted: the numpy oracle per-sample loop")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _read_csv(path: pathlib.Path) -> list:
    rows = []
    with open(path) as fh:
        keys = fh.readline().strip().split(",")
        for line in fh:
            r = {}
            for k, v in zip(keys, line.strip().split(",")):
                if v == "":
                    continue
                try:
                    r[k] = int(v)
                except ValueError:
                    try:
                        r[k] = float(v)
                    except ValueError:
                        r[k] = v
            rows.append(r)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer points")
    ap.add_argument("--replot", action="store_true",
                    help="table, text and figure again from results/scaling/scaling.csv")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        print(json.dumps(worker(json.loads(args.worker))))
        return 0
    print(f"# bench/scaling.py {'--quick' if args.quick else '(full)'}: {os.cpu_count()} CPUs, "
          "CPU only (no accelerator lent to this task); each point in its own process")
    if args.replot:
        rows = _read_csv(OUT / "scaling.csv")
    else:
        rows = []
        for cfg in sweeps(args.quick):
            rows.append(_run(cfg))
            r = rows[-1]
            print(f"  {_label(r):24s} {r['rate']:10.4g} samples/s  peak {r['peak_mb']:.0f} MB",
                  flush=True)
    print()
    print_table(rows)
    print()
    for line in bends(rows):
        print("- " + line)
    OUT.mkdir(parents=True, exist_ok=True)
    if not args.replot:
        keys = sorted({k for r in rows for k in r})
        with open(OUT / "scaling.csv", "w") as fh:
            fh.write(",".join(keys) + "\n")
            for r in rows:
                fh.write(",".join(str(r.get(k, "")) for k in keys) + "\n")
    figure(rows, OUT / "scaling.png")
    print(f"\nwrote {OUT / 'scaling.csv'} and {OUT / 'scaling.png'}")
    push = {r["n"]: r for r in rows if r["sweep"] == "batch" and r["kind"] == "push"}
    at5 = push.get(100_000, {}).get("rate", math.nan)
    at6 = push.get(1_000_000, {}).get("peak_mb", math.nan)
    print(f"RESULT push_samples_per_s_at_1e5={at5:.0f} peak_mb_at_1e6={at6:.0f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
