"""Benchmark: the Marigo-Bicchi tumble planner and batched tumble replay.

Run by hand from the repository root (no assertions on time)::

    python bench/tumble_planning.py            # full: 25 parts x 50 goals, 10,000 parts replayed
    python bench/tumble_planning.py --quick    # small sizes, well under a minute

Two parts, each comparing a fast path with its reference in the same run:

1. **Planning** over the fixed set of ``bench/polyhedra_set.py`` (25 convex
   polyhedra), start ``(0, 0, 0, 0)``, ``eps = 0.01 x the part's diameter``
   (metres, and the same number in radians for the heading).  Per part,
   ``--goals`` random goals (seeded: face uniform, position uniform in a disc
   of 3 part diameters about the start, heading uniform in (-pi, pi]) and
   ``--walk-goals`` reachable goals (the configuration after a seeded random
   walk of 10..40 tumbles; random headings are out of reach for parts whose
   defect angles are all rational multiples of pi).  Reported per part: the
   planning time (the first goal includes the analysis and compilations, so
   it is shown separately), the solved rate, the tumbles of the paper's
   construction (``plan.n_tumbles_paper``, purged; often astronomically
   large) and of the returned, shortened plan (``plan.n_tumbles``), and
   whether the solved plans replayed by the exact float64 kernel end within
   eps.  Median shortening: the median over the solved random goals of
   ``n_tumbles_paper / n_tumbles`` (exact integers; printed in e-notation).
   Parts are spread over ``--jobs`` worker processes (spawned).
2. **Tumble-replay throughput**: one 200-tumble face sequence (a seeded
   random walk) on ``examples/irregular_polyhedron.yaml`` replayed with
   ``jax.vmap(replay)`` over ``--parts`` perturbed vertex sets (each
   coordinate uniform in +-tau_v, tau_v = 0.1 mm), geometries built with
   ``jax.vmap(tumble_geometry)`` (timed separately), in float64 and float32,
   against the plain-numpy oracle (``tests/oracles/tumble_numpy.py``, a
   per-part loop of 3-D rotations) on a subset, scaled to tumble-steps/s.

Last line: ``RESULT median_shortening=R tumble_steps_per_s=N`` (R over the
solved random goals, ``nan`` if none; N: the float64 vmapped replay).
"""
from __future__ import annotations

import argparse
import concurrent.futures
import math
import multiprocessing
import os
import pathlib
import re
import statistics
import sys
import time
import warnings
from decimal import Decimal
from fractions import Fraction

ROOT = pathlib.Path(__file__).resolve().parents[1]
for p in (str(ROOT), str(ROOT / "bench")):
    if p not in sys.path:
        sys.path.insert(0, p)

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from kernels.polyhedron import PartWarning, make_polyhedron  # noqa: E402
from kernels.tumble_geometry import tumble_geometry  # noqa: E402
from kernels.planar import wrap_angle  # noqa: E402
from kernels.tumble import make_config, replay  # noqa: E402
from polyhedra_set import polyhedra_set  # noqa: E402
from timing import best_of  # noqa: E402

EPS_REL = 1e-2          # eps = EPS_REL * part diameter
GOAL_RADIUS_DIAM = 3.0  # goal positions within this many diameters of the start
TAU_V = 1e-4            # throughput: vertex perturbation half-width, metres
SEQ_LEN = 200


def _poly(vertices, com=None):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PartWarning)
        return make_polyhedron(vertices, com)


# --------------------------------------------------------------------------
# 2. replay throughput
# --------------------------------------------------------------------------
def random_walk(poly, rng, start_face: int, length: int) -> list[int]:
    seq, f = [], start_face
    for _ in range(length):
        g = int(rng.choice(poly.neighbors(f)))
        seq.append(g)
        f = g
    return seq


def throughput(n_parts: int, n_numpy: int, repeat: int) -> dict:
    """Replay throughput (see the module doc); kernels are called on float64
    arrays, so this runs inside ``jax.enable_x64(True)`` (scoped)."""
    with jax.enable_x64(True):
        return _throughput(n_parts, n_numpy, repeat)


def _throughput(n_parts: int, n_numpy: int, repeat: int) -> dict:
    import yaml

    from oracles import tumble_numpy as oracle

    doc = yaml.safe_load((ROOT / "examples" / "irregular_polyhedron.yaml").read_text())
    P = _poly(doc["vertices"], doc.get("com"))
    topo = P.topology
    rng = np.random.default_rng(0)
    seq = random_walk(P, rng, 0, SEQ_LEN)
    V = P.vertices[None] + rng.uniform(-TAU_V, TAU_V, size=(n_parts,) + P.vertices.shape)
    com = P.com
    start = (0.0, 0.0, 0.0, 0)
    steps = n_parts * SEQ_LEN
    out = {"n_parts": n_parts, "L": SEQ_LEN, "rows": []}
    finals = {}
    for dtype in (jnp.float64, jnp.float32):
        Vd = jnp.asarray(V, dtype=dtype)
        comd = jnp.asarray(com, dtype=dtype)
        seqd = jnp.asarray(seq, dtype=jnp.int32)
        cfg = make_config(*start, dtype=dtype)
        build = jax.jit(jax.vmap(lambda v: tumble_geometry(v, comd, topo)))
        run = jax.jit(jax.vmap(replay, in_axes=(0, None, None)))
        t0 = time.perf_counter()
        geoms = jax.block_until_ready(build(Vd))
        t_build_first = time.perf_counter() - t0
        t0 = time.perf_counter()
        fin, ok = jax.block_until_ready(run(geoms, cfg, seqd))
        t_run_first = time.perf_counter() - t0
        t_build = best_of(lambda: jax.block_until_ready(build(Vd)), repeat)
        t_run = best_of(lambda: jax.block_until_ready(run(geoms, cfg, seqd)), repeat)
        assert bool(jnp.all(ok)), "replay reported an invalid tumble"
        finals[dtype] = (np.asarray(fin.xy, dtype=np.float64), np.asarray(fin.theta, dtype=np.float64))
        name = jnp.dtype(dtype).name
        out["rows"].append(dict(method=f"jax vmap replay {name}", parts=n_parts, seconds=t_run,
                                steps_per_s=steps / t_run, first_call=t_run_first,
                                build=t_build, build_first=t_build_first))
    # numpy oracle, per-part loop on a subset
    n_np = min(n_numpy, n_parts)
    t0 = time.perf_counter()
    np_final = []
    for i in range(n_np):
        fin, _ = oracle.replay(V[i], com, topo.face_cycles, start, seq, check_landing=False)
        np_final.append(fin)
    t_np = time.perf_counter() - t0
    np_final = np.array(np_final, dtype=float)
    out["rows"].append(dict(method="numpy oracle loop", parts=n_np, seconds=t_np,
                            steps_per_s=n_np * SEQ_LEN / t_np, first_call=math.nan,
                            build=math.nan, build_first=math.nan))
    xy64, th64 = finals[jnp.float64]
    xy32, th32 = finals[jnp.float32]
    out["err64_vs_numpy_xy"] = float(np.max(np.abs(xy64[:n_np] - np_final[:, :2])))
    out["err64_vs_numpy_th"] = float(np.max(np.abs(np.asarray(wrap_angle(th64[:n_np] - np_final[:, 2])))))
    out["err32_vs_64_xy"] = float(np.max(np.abs(xy32 - xy64)))
    out["err32_vs_64_th"] = float(np.max(np.abs(np.asarray(wrap_angle(th32 - th64)))))
    out["spread_xy"] = float(np.max(np.linalg.norm(xy64 - xy64.mean(axis=0), axis=1)))
    return out


def print_throughput(res: dict) -> float:
    print(f"\n## Tumble-replay throughput: one {res['L']}-tumble sequence on irregular_polyhedron, "
          f"vertices perturbed uniformly in +-{TAU_V * 1e3:g} mm")
    np_rate = res["rows"][-1]["steps_per_s"]
    hdr = f"{'method':26s} {'parts':>7s} {'replay s':>9s} {'steps/s':>12s} {'x numpy':>8s} " \
          f"{'1st call s':>10s} {'geom build s':>12s} {'1st build s':>11s}"
    print(hdr)
    print("-" * len(hdr))
    for r in res["rows"]:
        print(f"{r['method']:26s} {r['parts']:7d} {r['seconds']:9.4f} {r['steps_per_s']:12.4g} "
              f"{r['steps_per_s'] / np_rate:8.1f} {r['first_call']:10.3f} {r['build']:12.4f} "
              f"{r['build_first']:11.3f}")
    print(f"float64 vs numpy oracle (first {res['rows'][-1]['parts']} parts): max |dxy| "
          f"{res['err64_vs_numpy_xy']:.2e} m, max |dtheta| {res['err64_vs_numpy_th']:.2e} rad")
    print("(the perturbed quadrilateral face is not planar: kernel (edge-matching on projected "
          "corners) and oracle (3-D rotation until the fitted normal points down) differ at second "
          "order in tau_v; at tau_v = 0 they agree to 1e-15)")
    print(f"float32 vs float64 (all parts): max |dxy| {res['err32_vs_64_xy']:.2e} m, "
          f"max |dtheta| {res['err32_vs_64_th']:.2e} rad; spread of final xy over the "
          f"perturbations {res['spread_xy']:.2e} m")
    return res["rows"][0]["steps_per_s"]


# --------------------------------------------------------------------------
# 1. planning
# --------------------------------------------------------------------------
def make_goals(poly, diam: float, n: int, seed: int) -> list[tuple]:
    """Random goals: face uniform, position uniform in a disc of GOAL_RADIUS_DIAM
    diameters, heading uniform in (-pi, pi]."""
    rng = np.random.default_rng(seed)
    goals = []
    for _ in range(n):
        r = GOAL_RADIUS_DIAM * diam * math.sqrt(rng.uniform())
        a = rng.uniform(-math.pi, math.pi)
        th = float(wrap_angle(rng.uniform(-math.pi, math.pi)))
        goals.append((r * math.cos(a), r * math.sin(a), th, int(rng.integers(poly.n_faces))))
    return goals


def make_walk_goals(poly, n: int, seed: int) -> list[tuple]:
    """Reachable goals: the configuration after a random walk of 10..40 tumbles from
    (0, 0, 0, 0), replayed by the float64 kernel."""
    rng = np.random.default_rng(10_000 + seed)
    goals = []
    with jax.enable_x64(True):
        geom = poly.geometry(jnp.float64)
        for _ in range(n):
            seq = random_walk(poly, rng, 0, int(rng.integers(10, 41)))
            pad = np.full(64, -1, dtype=np.int32)
            pad[: len(seq)] = seq
            f, _ = replay(geom, make_config(0.0, 0.0, 0.0, 0, dtype=jnp.float64), jnp.asarray(pad))
            xy = np.asarray(f.xy, float)
            goals.append((float(xy[0]), float(xy[1]), float(f.theta), int(f.face)))
    return goals


def _bucket(n: int) -> int:
    return 1 << max(4, (max(n, 1) - 1).bit_length())


def verify(poly, plan) -> float:
    """Distance (the paper's max metric) from the kernel replay of a plan to its goal."""
    seq = [int(t.face) for t in plan.tumbles]
    if not seq:
        fin = plan.start
        face = int(fin[3])
        xy, th = np.asarray(fin[:2], float), float(fin[2])
    else:
        pad = np.full(_bucket(len(seq)), -1, dtype=np.int32)
        pad[: len(seq)] = seq
        with jax.enable_x64(True):
            geom = poly.geometry(jnp.float64)
            f, ok = replay(geom, make_config(*plan.start[:3], int(plan.start[3]), dtype=jnp.float64),
                           jnp.asarray(pad))
            if not bool(ok):
                return math.inf
            face, xy, th = int(f.face), np.asarray(f.xy, float), float(f.theta)
    g = plan.goal
    if face != int(g[3]):
        return 1.0
    return max(float(np.hypot(*(xy - np.asarray(g[:2], float)))),
               abs(float(wrap_angle(th - float(g[2])))))


_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:e[-+]?\d+)?")


def _reason_key(reason: str) -> str:
    """A not-solvable reason with its numbers blanked, so reasons group."""
    return _NUMBER.sub("#", " ".join(str(reason).split()))[:90]


def plan_part(task) -> dict:
    """Plan all goals of one part (runs in a worker process)."""
    from planning.tumbling.planner import plan_tumble

    part, n_goals, n_walk, seed = task
    poly = _poly(part.vertices, part.com)
    eps = EPS_REL * part.diameter
    out = dict(name=part.name, F=poly.n_faces, m=poly.n_vertices, eps=eps, classes=set(),
               reasons={}, t_first=math.nan)
    goal_sets = {"random": make_goals(poly, part.diameter, n_goals, seed),
                 "walk": make_walk_goals(poly, n_walk, seed)}
    k = 0
    for family, goals in goal_sets.items():
        res = out[family] = dict(n=len(goals), times=[], paper=[], short=[], errs=[], ver=0, ops=[])
        for goal in goals:
            t0 = time.perf_counter()
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    plan = plan_tumble(part.vertices, goal, com=part.com, eps=eps)
            except Exception as exc:  # noqa: BLE001 - a benchmark reports, it does not stop
                key = f"{type(exc).__name__}: {_reason_key(str(exc))}"
                out["reasons"][key] = out["reasons"].get(key, 0) + 1
                res["times"].append(time.perf_counter() - t0)
                k += 1
                continue
            dt = time.perf_counter() - t0
            if k == 0:
                out["t_first"] = dt  # includes the analysis and compilations
            else:
                res["times"].append(dt)
            k += 1
            out["classes"].add(plan.reachable_class)
            res["ops"].append(plan.effort_used)
            if plan.verdict == "solved":
                res["paper"].append(int(plan.n_tumbles_paper))
                res["short"].append(plan.n_tumbles)
                res["errs"].append(float(plan.error))
                res["ver"] += verify(poly, plan) <= eps * (1 + 1e-9)
            elif family == "random":
                key = _reason_key(plan.reason)
                out["reasons"][key] = out["reasons"].get(key, 0) + 1
    r = out["random"]
    print(f"  {part.name:20s} random goals solved {len(r['short']):3d}/{r['n']:<3d} "
          f"walk goals solved {len(out['walk']['short']):3d}/{out['walk']['n']:<3d} "
          f"median {_med(r['times'] + out['walk']['times']) * 1e3:8.1f} ms/goal",
          file=sys.stderr, flush=True)
    return out


def _default_effort() -> float:
    from planning.tumbling.effort import DEFAULT_EFFORT

    return float(DEFAULT_EFFORT)


def _med(x):
    return statistics.median(x) if x else math.nan


def _ratios(res) -> list[Fraction]:
    """Exact paper/short ratios (the paper's counts can exceed any float)."""
    return [Fraction(a, max(b, 1)) for a, b in zip(res["paper"], res["short"])]


def _fmt_big(x) -> str:
    """A possibly astronomically large int or Fraction, 3 significant digits."""
    if x is None:
        return "-"
    if isinstance(x, int) and abs(x) < 10**15:
        x = float(x)
    if isinstance(x, float):
        if math.isnan(x):
            return "-"
        return f"{x:.3g}" if abs(x) < 1e4 else f"{x:.2e}"
    d = Decimal(x.numerator) / Decimal(x.denominator) if isinstance(x, Fraction) else Decimal(int(x))
    if d == 0:
        return "0"
    if abs(d) < 10_000:
        return f"{float(d):.3g}"
    return f"{d:.2e}".replace("E", "e")


def run_planning(parts, n_goals: int, n_walk: int, seed: int, jobs: int) -> dict:
    tasks = [(p, n_goals, n_walk, seed + i) for i, p in enumerate(parts)]
    if jobs > 1:
        ctx = multiprocessing.get_context("spawn")  # JAX is not fork-safe
        with concurrent.futures.ProcessPoolExecutor(max_workers=jobs, mp_context=ctx) as ex:
            rows = list(ex.map(plan_part, tasks))
    else:
        rows = [plan_part(t) for t in tasks]
    rand = [q for r in rows for q in _ratios(r["random"])]
    walk = [q for r in rows for q in _ratios(r["walk"])]
    return {"rows": rows, "jobs": jobs,
            "median_shortening": statistics.median_low(rand) if rand else None,
            "median_shortening_walk": statistics.median_low(walk) if walk else None,
            "n_solved": len(rand), "n_solved_walk": len(walk)}


def print_planning(res: dict, n_goals: int, n_walk: int) -> None:
    print(f"\n## Planning: {len(res['rows'])} polyhedra; start (0,0,0,F0); eps = {EPS_REL:g} x "
          f"diameter (metres; the same number in rad for the heading); {res['jobs']} worker "
          "process(es)")
    print(f"random goals ({n_goals} per part): face and heading uniform, position uniform within "
          f"{GOAL_RADIUS_DIAM:g} diameters; walk goals ({n_walk} per part): the configuration "
          "after a random walk of 10..40 tumbles (reachable exactly)")
    hdr = (f"{'part':20s} {'F':>3s} {'m':>3s} {'class':>11s} {'eps mm':>6s} {'1st s':>6s} "
           f"{'med ms':>7s} {'Mops':>5s} | {'solved':>7s} {'paper':>9s} {'short':>6s} {'ratio':>9s} "
           f"{'err mm':>6s} {'ok':>3s} | {'walk':>5s} {'paper':>9s} {'short':>6s} {'ratio':>9s}")
    print(hdr)
    print("-" * len(hdr))
    for r in res["rows"]:
        a, w = r["random"], r["walk"]
        times = a["times"] + w["times"]
        ra, rw = _ratios(a), _ratios(w)
        print(f"{r['name']:20s} {r['F']:3d} {r['m']:3d} {'/'.join(sorted(r['classes'])) or '-':>11s} "
              f"{r['eps'] * 1e3:6.2f} {r['t_first']:6.2f} {_med(times) * 1e3:7.0f} "
              f"{max(a['ops'] + w['ops'], default=0) / 1e6:5.2f} | "
              f"{len(a['short']):3d}/{a['n']:<3d} "
              f"{_fmt_big(statistics.median_low(a['paper']) if a['paper'] else None):>9s} "
              f"{_fmt_big(_med(a['short'])):>6s} "
              f"{_fmt_big(statistics.median_low(ra) if ra else None):>9s} "
              f"{_fmt_big(_med(a['errs']) * 1e3):>6s} {a['ver']:3d} | "
              f"{len(w['short']):2d}/{w['n']:<2d} "
              f"{_fmt_big(statistics.median_low(w['paper']) if w['paper'] else None):>9s} "
              f"{_fmt_big(_med(w['short'])):>6s} "
              f"{_fmt_big(statistics.median_low(rw) if rw else None):>9s}")
    print("1st s: the part's first goal (analysis + compilations); med ms: median over its other "
          "goals; Mops: the largest effort of a goal (millions of planner operations, default budget "
          f"{_default_effort() / 1e6:g}); paper / short: median tumbles of the paper's construction (purged) / of the "
          "returned plan over solved goals; ratio: median of paper/short; ok: solved plans whose "
          "float64 kernel replay ends within eps")
    reasons = {}
    for r in res["rows"]:
        for k, v in r["reasons"].items():
            reasons[k] = reasons.get(k, 0) + v
    if reasons:
        print("random goals not solved, by reason (numbers blanked):")
        for k, v in sorted(reasons.items(), key=lambda kv: -kv[1])[:8]:
            print(f"  {v:5d}  {k}")
    tot = sum(r["random"]["n"] for r in res["rows"])
    totw = sum(r["walk"]["n"] for r in res["rows"])
    print(f"random goals: solved {res['n_solved']}/{tot}, median shortening "
          f"{_fmt_big(res['median_shortening'])}; walk goals: solved {res['n_solved_walk']}/{totw}, "
          f"median shortening {_fmt_big(res['median_shortening_walk'])}")


def _fmt_result(x) -> str:
    if x is None:
        return "nan"
    if isinstance(x, float):
        return str(x) if not math.isfinite(x) else f"{x:.3f}"
    d = Decimal(x.numerator) / Decimal(x.denominator)
    return f"{float(d):.3f}" if d < 10**6 else f"{d:.3e}".replace("E", "e")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="small sizes (< 1 min)")
    ap.add_argument("--goals", type=int, help="random goals per part (default 50; quick 3)")
    ap.add_argument("--walk-goals", type=int,
                    help="reachable (random-walk) goals per part (default 10; quick 2)")
    ap.add_argument("--jobs", type=int, help="planning worker processes (default min(2, CPUs); "
                    "quick 1)")
    ap.add_argument("--parts", type=int, help="perturbed parts replayed (default 10000; quick 1000)")
    ap.add_argument("--numpy-parts", type=int, help="parts in the numpy loop (default 100; quick 10)")
    ap.add_argument("--only", choices=("planning", "throughput"), help="run one section")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    q = args.quick
    n_goals = args.goals if args.goals is not None else (3 if q else 50)
    n_walk = args.walk_goals if args.walk_goals is not None else (2 if q else 10)
    jobs = args.jobs or (1 if q else max(1, min(2, os.cpu_count() or 1)))
    n_parts = args.parts or (1000 if q else 10_000)
    n_np = args.numpy_parts or (10 if q else 100)
    parts = polyhedra_set()
    if q:
        keep = ("cube", "irregular_polyhedron", "hull_s0_n6")
        parts = [p for p in parts if p.name in keep]
    print(f"# bench/tumble_planning.py {'--quick' if q else '(full)'}: jax {jax.__version__}, "
          f"backend {jax.default_backend()}, {os.cpu_count()} CPUs")
    t_all = time.perf_counter()
    shortening = None
    if args.only in (None, "planning"):
        try:
            import planning.tumbling.planner  # noqa: F401
        except ImportError as exc:
            print(f"\n## Planning: skipped (planning.tumbling.planner not importable: {exc})")
        else:
            res = run_planning(parts, n_goals, n_walk, args.seed, jobs)
            print_planning(res, n_goals, n_walk)
            shortening = res["median_shortening"]
    rate = math.nan
    if args.only in (None, "throughput"):
        res = throughput(n_parts, n_np, repeat=3 if q else 5)
        rate = print_throughput(res)
    print(f"\ntotal wall time {time.perf_counter() - t_all:.1f} s")
    rate_s = f"{rate:.0f}" if math.isfinite(rate) else "nan"
    print(f"RESULT median_shortening={_fmt_result(shortening)} tumble_steps_per_s={rate_s}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
