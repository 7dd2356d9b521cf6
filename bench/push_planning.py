"""Benchmark: complete pose plans per second (batched JAX, default search and
the paper's strategy, vs cvxpy per LP) and plan lengths on the bundled parts.

Run by hand:  python bench/push_planning.py [--plans N] [--ref N] [--chunk N] [--goals N]

A "complete plan" is the whole planner: every candidate reorientation
sequence, its LP, the choice of the best, and the exact replay that verifies
it.  The fast paths are ``plan_pose_batch`` with the default strategy
(``search``) and with ``strategy="paper"`` (the paper's candidates), measured on
the same problems in the same run; the reference is ``plan_pose(...,
solver="cvxpy")``, which solves every candidate's LP with cvxpy, on a subset
(its plans are checked to agree with the batch).  No assertions on time.

Plan lengths: on the bundled polygon parts (``examples/*.yaml``), ``--goals``
random goals within 15 cm of the start (uniform in the disc, any orientation;
margin 7 deg, safety factor 1.15), the median of total push distance over the
straight start-goal distance, per part and strategy.

The last line is ``RESULT plans_per_s=N ratio_vs_cvxpy=R plans_per_s_paper=N
ratio_vs_paper=R median_length_ratio_unistable=R median_length_ratio_other=R2
single_plans_per_s=S`` (``other``: the largest median among the parts that
are not uni-stable; ``single``: ``plan_pose`` one plan at a time, numpy
closed form, on the reference's problems).
"""
from __future__ import annotations

import argparse
import glob
import math
import os
import sys
import time
import warnings

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

from planning import PushOptions, plan_pose, plan_pose_batch, prepare_part  # noqa: E402
from sweeps.partfile import load_part  # noqa: E402
from timing import best_of  # noqa: E402

# A nice-stable, irregular pentagon (metres), a few centimetres across like the paper's parts.
PENTAGON = [[0.024, 0.0], [0.010, 0.017], [-0.014, 0.012], [-0.018, -0.008], [0.004, -0.018]]


def problems(n: int, seed: int = 0):
    """Random start/goal pairs: positions within 20 cm, any orientation."""
    rng = np.random.default_rng(seed)
    starts = np.c_[rng.uniform(-0.1, 0.1, (n, 2)), rng.uniform(-math.pi, math.pi, n)]
    goals = np.c_[rng.uniform(-0.1, 0.1, (n, 2)), rng.uniform(-math.pi, math.pi, n)]
    return starts, goals


def near_goals(n: int, reach: float = 0.15, seed: int = 0):
    """Start at the origin (any orientation), goals uniform in the disc of radius ``reach`` (m)."""
    rng = np.random.default_rng(seed)
    r = reach * np.sqrt(rng.uniform(0.0, 1.0, n))
    a = rng.uniform(-math.pi, math.pi, n)
    starts = np.c_[np.zeros((n, 2)), rng.uniform(-math.pi, math.pi, n)]
    goals = np.c_[r * np.cos(a), r * np.sin(a), rng.uniform(-math.pi, math.pi, n)]
    return starts, goals


def bundled_polygons():
    """``{name: (vertices, com, class name)}`` of the polygon part files in examples/."""
    out = {}
    here = os.path.join(os.path.dirname(__file__), "..", "examples", "*.yaml")
    for path in sorted(glob.glob(here)):
        try:
            part = load_part(path)
        except Exception:   # certify configs, studies: not part files
            continue
        if part.kind != "polygon":
            continue
        cls = prepare_part(part.vertices, part.com).class_name
        out[part.name] = (part.vertices, part.com, cls)
    return out


def length_ratios(n_goals: int):
    """Per bundled part and strategy: median, 90th percentile and max of total /
    straight distance, and every plan's verification."""
    rows = []
    starts, goals = near_goals(n_goals)
    straight = np.hypot(goals[:, 0], goals[:, 1])
    for name, (verts, com, cls) in bundled_polygons().items():
        for strategy in ("search", "paper"):
            b = plan_pose_batch(verts, starts, goals, com=com, options=PushOptions(strategy=strategy))
            ratio = b.total_distance / straight
            rows.append(dict(part=name, cls=cls, strategy=strategy, ok=float(b.ok.mean()),
                             median=float(np.median(ratio)), p90=float(np.quantile(ratio, 0.9)),
                             max=float(ratio.max()), pushes=float(np.median(b.n_pushes))))
    return rows


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plans", type=int, default=65536, help="plans in the batched run")
    ap.add_argument("--ref", type=int, default=12, help="plans solved with cvxpy per LP")
    ap.add_argument("--chunk", type=int, default=1024, help="plans per compiled batch")
    ap.add_argument("--repeat", type=int, default=3, help="timed repetitions (best is kept)")
    ap.add_argument("--goals", type=int, default=40, help="goals per bundled part for the length ratios")
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")

    part = prepare_part(PENTAGON)
    starts, goals = problems(args.plans)
    print(f"part: {part.n}-gon, {part.class_name}, stable edges {list(part.stable)}, "
          f"step angles (deg) {np.round(np.degrees(part.step[list(part.stable)]), 1).tolist()}")

    rates, batches, compile_s = {}, {}, {}
    for strategy in ("paper", "search"):
        t0 = time.perf_counter()
        plan_pose_batch(PENTAGON, starts[: args.chunk], goals[: args.chunk], chunk=args.chunk,
                        options=PushOptions(strategy=strategy))
        compile_s[strategy] = time.perf_counter() - t0
    for rep in range(args.repeat):   # interleaved: both see the same machine load
        for strategy in ("paper", "search"):
            runs = []
            t = best_of(lambda: runs.append(plan_pose_batch(
                PENTAGON, starts, goals, chunk=args.chunk, options=PushOptions(strategy=strategy))), 1)
            rates[strategy] = max(rates.get(strategy, 0.0), args.plans / t)
            batches[strategy] = runs[-1]
    batch = batches["search"]

    # references on the first `ref` problems of the same set
    t0 = time.perf_counter()
    cv = [plan_pose(PENTAGON, starts[i], goals[i], options=PushOptions(solver="cvxpy")) for i in range(args.ref)]
    cvxpy_rate = args.ref / (time.perf_counter() - t0)
    plan_pose(PENTAGON, starts[0], goals[0])  # warm the replay's compilation
    t0 = time.perf_counter()
    cf = [plan_pose(PENTAGON, starts[i], goals[i]) for i in range(args.ref)]
    single_rate = args.ref / (time.perf_counter() - t0)
    diff_cvx = max(abs(p.total_distance - batch.total_distance[i]) for i, p in enumerate(cv))
    diff_cf = max(abs(p.total_distance - batch.total_distance[i]) for i, p in enumerate(cf))

    print(f"\n{'path':<44} {'plans/s':>12} {'ratio':>9}")
    print(f"{'cvxpy per LP (plan_pose, reference)':<44} {cvxpy_rate:>12.1f} {1.0:>9.1f}")
    print(f"{'numpy closed form (plan_pose)':<44} {single_rate:>12.1f} {single_rate / cvxpy_rate:>9.1f}")
    print(f"{'batched JAX, paper strategy':<44} {rates['paper']:>12.1f} {rates['paper'] / cvxpy_rate:>9.1f}")
    print(f"{'batched JAX, default (search) strategy':<44} {rates['search']:>12.1f} "
          f"{rates['search'] / cvxpy_rate:>9.1f}")
    print(f"\nbatch: {args.plans} plans, chunk {args.chunk}, best of {args.repeat}; first compile "
          f"{compile_s['search']:.1f} s (search) / {compile_s['paper']:.1f} s (paper); verified by replay: "
          f"{batch.ok.mean():.4%} / {batches['paper'].ok.mean():.4%}; mean pushes {batch.n_pushes.mean():.2f} / "
          f"{batches['paper'].n_pushes.mean():.2f}; mean total distance {batch.total_distance.mean():.4f} / "
          f"{batches['paper'].total_distance.mean():.4f} m (search / paper)")
    print(f"agreement on {args.ref} plans: |total distance - batch| max {diff_cvx:.2e} m (cvxpy), "
          f"{diff_cf:.2e} m (numpy closed form)")

    rows = length_ratios(args.goals)
    print(f"\nplan length / straight distance, {args.goals} goals within 15 cm (margin 7 deg, safety 1.15)")
    print(f"{'part':<16} {'class':<14} {'strategy':<8} {'ok':>6} {'median':>8} {'p90':>8} {'max':>9} "
          f"{'pushes':>7}")
    for r in rows:
        print(f"{r['part']:<16} {r['cls']:<14} {r['strategy']:<8} {r['ok']:>6.1%} {r['median']:>8.2f} "
              f"{r['p90']:>8.2f} {r['max']:>9.2f} {r['pushes']:>7.1f}")
    search = [r for r in rows if r["strategy"] == "search"]
    uni = max((r["median"] for r in search if r["cls"] == "uni-stable"), default=math.nan)
    other = max((r["median"] for r in search if r["cls"] != "uni-stable"), default=math.nan)
    print(f"RESULT plans_per_s={rates['search']:.0f} ratio_vs_cvxpy={rates['search'] / cvxpy_rate:.0f} "
          f"plans_per_s_paper={rates['paper']:.0f} ratio_vs_paper={rates['search'] / rates['paper']:.2f} "
          f"median_length_ratio_unistable={uni:.2f} median_length_ratio_other={other:.2f} "
          f"single_plans_per_s={single_rate:.1f}")


if __name__ == "__main__":
    main()
