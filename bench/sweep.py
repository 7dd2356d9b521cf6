"""Benchmark of the study runner: the bundled ``margins.yaml`` study end to end
(``sweeps.run``, local executor) against calling the robustness layer directly
on the same configurations in the same process (the runner's overhead: design,
chunked Parquet writes, the manifest and log, the per-unit bookkeeping),
and with the Dask executor on 2 workers (a LocalCluster on 127.0.0.1).

Usage::

    python bench/sweep.py [--study margins.yaml] [--set PATH=VALUE ...] [--repeat 2] [--no-dask]

The direct and runner passes alternate (the best of each is kept).  Every
timed pass runs after a warm-up pass of the same kind, so JAX compilation
(cached in memory and on disk) is not counted; the runner's own per-process
caches (plans, the unpacked design) are emptied before each pass, here and in a
warm cluster's workers, as in a fresh ``python -m sweeps.run``; the report is not
written (it is not part of the runner's per-sample cost).  The last line is
``RESULT configs_per_s=N samples_per_s=M overhead=R dask_speedup=S``
(``overhead`` = runner time / direct time - 1; ``dask_speedup`` = local runner
time / Dask runner time on a started, warm cluster of 2 worker processes; the
table also shows a Dask run that starts its own cluster, as ``--executor dask``
does).
"""
from __future__ import annotations

import argparse
import math
import os
import pathlib
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
# first, even when ROOT is already on PYTHONPATH: the package ``robustness`` must win
# over bench/robustness.py (this script's folder is sys.path[0])
sys.path.insert(0, str(ROOT))

os.environ.setdefault("JAX_PLATFORMS", "cpu")


def direct(design) -> int:
    """Plan and evaluate every (configuration, task) with the robustness layer
    itself, blocks and keys as the runner draws them; returns the sample count."""
    import jax
    import pandas as pd

    from robustness.evaluation import evaluate
    from robustness.summary import summarise
    from sweeps.tasks import plan_task

    total = 0
    for cid, cfg in enumerate(design.configs):
        part = design.part(cid)
        size = cfg.chunk_samples or cfg.samples
        for ti, (name, start, goal) in enumerate(design.tasks(cid)):
            plan, _ = plan_task(part, start, goal, cfg.planner, cfg.eps)
            if plan is None:
                continue
            frames = []
            for b, lo in enumerate(range(0, cfg.samples, size)):
                key = jax.random.fold_in(jax.random.fold_in(jax.random.key(cfg.seed), ti), b)
                ev = evaluate(plan, cfg.sampler(), min(size, cfg.samples - lo), key, cfg.eps,
                              cfg.model_spec(physics=cfg.physics_run(part)), task=name)
                frames.append(ev.samples)
            df = pd.concat(frames, ignore_index=True)
            summarise(df, plan, cfg.sampler(), kind=cfg.kind, model=cfg.model, dtype=cfg.dtype,
                      criterion=cfg.eps, confidence=cfg.required.confidence, task=name,
                      bound=cfg.bounds)
            total += len(df)
    return total


def runner(design, executor: str, address=None) -> float:
    """One run of the study into a fresh folder; returns the wall time (s).  With
    ``address``, the Dask run uses that (already started, warm) cluster."""
    from sweeps.run import execute
    from sweeps.study import Executor

    # as a fresh ``python -m sweeps.run``: no plans or design left over from an
    # earlier pass, here or in a warm cluster's workers (the runner's caches are
    # per process; direct() plans every configuration each pass)
    _forget_runs()
    if address is not None:
        from distributed import Client

        with Client(address) as client:
            client.run(_forget_runs)
    spec = Executor(kind=executor, workers=2, address=address)
    with tempfile.TemporaryDirectory() as d:
        t0 = time.perf_counter()
        code = execute(design, pathlib.Path(d) / "run", spec, quiet=True, report=False)
        dt = time.perf_counter() - t0
    if code != 0:
        raise SystemExit(f"the study run failed with status {code}")
    return dt


def _forget_runs() -> None:
    """Empty this process's per-run caches of :mod:`sweeps.work` (the unpacked
    design, plans, syntheses)."""
    from sweeps import work

    for cache in (work.CONTEXTS, work._PLANS, work._SYNTHESES):
        cache.clear()


def main() -> int:
    import warnings

    from sweeps.executors import enable_compilation_cache
    from sweeps.study import load_design
    from sweeps.work import plan_units

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--study", default="margins.yaml")
    ap.add_argument("--set", dest="overrides", action="append", default=[])
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--no-dask", action="store_true")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    enable_compilation_cache()
    design = load_design(args.study, args.overrides)
    blocks, summaries = plan_units(design, {})
    n_samples = sum(u.samples for u in blocks)
    n_configs = len(design.configs)
    print(f"study {design.name}: {n_configs} configurations x {len(design.tasks(0))} tasks, "
          f"{n_samples} samples in {len(blocks)} chunks")
    direct(design)                       # warm-up: compilations
    runner(design, "local")              # warm-up of the runner's own path
    # the two alternate, so that a change in the machine's load between passes
    # (this 2-core machine's speed moves by 20-40 % within minutes) falls on both
    t_direct = t_local = math.inf
    for _ in range(args.repeat):
        t_direct = min(t_direct, _timed(lambda: direct(design)))
        t_local = min(t_local, runner(design, "local"))
    t_dask = float("nan")
    t_dask_cold = float("nan")
    if not args.no_dask:
        from distributed import LocalCluster

        t_dask_cold = runner(design, "dask")   # a cluster of its own: start-up and imports counted
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                          dashboard_address="127.0.0.1:0", silence_logs=50) as cluster:
            runner(design, "dask", cluster.scheduler_address)   # warm-up: workers import, compile
            t_dask = min(runner(design, "dask", cluster.scheduler_address)
                         for _ in range(args.repeat))
    overhead = t_local / t_direct - 1.0
    speedup = t_local / t_dask if t_dask == t_dask else float("nan")
    rows = [("robustness layer, direct", t_direct, 1.0), ("sweeps.run, local", t_local,
                                                         t_local / t_direct),
            ("sweeps.run, dask (2 workers)", t_dask, t_dask / t_direct),
            ("  the same, cluster start counted", t_dask_cold, t_dask_cold / t_direct)]
    print(f"\n{'path':32s} {'seconds':>9s} {'configs/s':>10s} {'samples/s':>10s} {'vs direct':>10s}")
    for name, t, ratio in rows:
        print(f"{name:32s} {t:9.2f} {n_configs / t:10.2f} {n_samples / t:10.0f} {ratio:10.3f}")
    print(f"\nRESULT configs_per_s={n_configs / t_local:.3f} samples_per_s={n_samples / t_local:.0f} "
          f"overhead={overhead:.3f} dask_speedup={speedup:.3f}")
    return 0


def _timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


if __name__ == "__main__":
    sys.exit(main())
