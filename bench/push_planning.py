"""Benchmark: complete pose plans per second, batched JAX vs cvxpy per LP.

Run by hand:  python bench/push_planning.py [--plans N] [--ref N] [--chunk N]

A "complete plan" is the whole planner: every candidate plan class, its LP,
the choice of the best, and the exact replay that verifies it.  The fast path
is ``plan_pose_batch`` (closed-form LP, jit + vmap); the reference is
``plan_pose(..., solver="cvxpy")`` which solves every candidate's LP with
cvxpy, measured in the same run on a subset of the same problems (and its
plans are checked to agree with the batch).  No assertions on time.

The last line is ``RESULT plans_per_s=N ratio_vs_cvxpy=R``.
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

from planning import plan_pose, plan_pose_batch, prepare_part  # noqa: E402
from timing import best_of  # noqa: E402

# A nice-stable, irregular pentagon (metres), a few centimetres across like the paper's parts.
PENTAGON = [[0.024, 0.0], [0.010, 0.017], [-0.014, 0.012], [-0.018, -0.008], [0.004, -0.018]]


def problems(n: int, seed: int = 0):
    """Random start/goal pairs: positions within 20 cm, any orientation."""
    rng = np.random.default_rng(seed)
    starts = np.c_[rng.uniform(-0.1, 0.1, (n, 2)), rng.uniform(-math.pi, math.pi, n)]
    goals = np.c_[rng.uniform(-0.1, 0.1, (n, 2)), rng.uniform(-math.pi, math.pi, n)]
    return starts, goals


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plans", type=int, default=65536, help="plans in the batched run")
    ap.add_argument("--ref", type=int, default=24, help="plans solved with cvxpy per LP")
    ap.add_argument("--chunk", type=int, default=1024, help="plans per compiled batch")
    ap.add_argument("--repeat", type=int, default=3, help="timed repetitions (best is kept)")
    args = ap.parse_args(argv)

    part = prepare_part(PENTAGON)
    starts, goals = problems(args.plans)
    print(f"part: {part.n}-gon, {part.class_name}, stable edges {list(part.stable)}, "
          f"step angles (deg) {np.round(np.degrees(part.step[list(part.stable)]), 1).tolist()}")

    t0 = time.perf_counter()
    plan_pose_batch(PENTAGON, starts[: args.chunk], goals[: args.chunk], chunk=args.chunk)
    compile_s = time.perf_counter() - t0
    runs = []
    best = best_of(lambda: runs.append(plan_pose_batch(PENTAGON, starts, goals, chunk=args.chunk)),
                   args.repeat)
    batch = runs[-1]
    batch_rate = args.plans / best
    ok = float(batch.ok.mean())

    # references on the first `ref` problems of the same set
    t0 = time.perf_counter()
    cv = [plan_pose(PENTAGON, starts[i], goals[i], solver="cvxpy") for i in range(args.ref)]
    cvxpy_rate = args.ref / (time.perf_counter() - t0)
    plan_pose(PENTAGON, starts[0], goals[0])  # warm the replay's compilation
    t0 = time.perf_counter()
    cf = [plan_pose(PENTAGON, starts[i], goals[i]) for i in range(args.ref)]
    single_rate = args.ref / (time.perf_counter() - t0)
    diff_cvx = max(abs(p.total_distance - batch.total_distance[i]) for i, p in enumerate(cv))
    diff_cf = max(abs(p.total_distance - batch.total_distance[i]) for i, p in enumerate(cf))

    print(f"\n{'path':<38} {'plans/s':>12} {'ratio':>9}")
    print(f"{'cvxpy per LP (plan_pose, reference)':<38} {cvxpy_rate:>12.1f} {1.0:>9.1f}")
    print(f"{'numpy closed form (plan_pose)':<38} {single_rate:>12.1f} {single_rate / cvxpy_rate:>9.1f}")
    print(f"{'batched JAX (plan_pose_batch)':<38} {batch_rate:>12.1f} {batch_rate / cvxpy_rate:>9.1f}")
    print(f"\nbatch: {args.plans} plans, chunk {args.chunk}, best of {args.repeat}: {best:.3f} s "
          f"(first compile {compile_s:.1f} s); verified by replay: {ok:.4%}; "
          f"mean pushes {batch.n_pushes.mean():.2f}")
    print(f"agreement on {args.ref} plans: |total distance - batch| max {diff_cvx:.2e} m (cvxpy), "
          f"{diff_cf:.2e} m (numpy closed form)")
    print(f"RESULT plans_per_s={batch_rate:.0f} ratio_vs_cvxpy={batch_rate / cvxpy_rate:.0f}")


if __name__ == "__main__":
    main()
