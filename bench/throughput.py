"""Benchmark: the samples/s behind every estimate (robustness.models.THROUGHPUT).

Run by hand from the repository root (no assertions)::

    python bench/throughput.py                        # every row of the table (~12 min)
    python bench/throughput.py --rows mujoco:rigid limit_surface:any

For each (model, support family) it runs one small study of the nice-stable
pentagon (4 random tasks 5-15 cm away, one configuration; the ``tumble-`` rows:
the irregular polyhedron, 4 random tasks of ``examples/studies/tolerances.yaml``),
``nudge sweep`` in a subprocess with a compilation cache of its own, warmed at
both counts, at two sample counts, and takes the throughput from the difference
(start-up, planning and loading the compiled kernels cancel), then prints it
beside the table's figure and their ratio.
Ends with ``RESULT <model>_<support>=<samples/s> ... worst_ratio=R`` (R: the
table's figure over the measured one furthest from 1; an estimate is good
within a factor of 2).
"""
from __future__ import annotations

import argparse
import os
import pathlib
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from robustness import samples_per_second  # noqa: E402

STUDY = """study: throughput
kind: push
part: nice_stable
tasks:
  sample: {{n: {tasks}, annulus: [0.05, 0.15], heading: [-180deg, 180deg]}}
planner: {{margin_deg: 7, safety_factor: 1.15, objective: distance}}
tolerances: {{tau_v: 2.0e-5, tau_com: 1.0e-4}}
friction: {{mu_f: [0.5, 0.8], mu_s: [0.3, 0.5], support: {support}}}
execution: {{start_xy: 5.0e-4, start_theta: 0.01, fence_angle: 0.002, distance_abs: 1.0e-4,
            distance_rel: 0.005}}
eps: {{pos_eps_m: 0.003, theta_eps_rad: 0.05}}
model: {model}
samples: {samples}
seed: 0
report: false
"""
TUMBLE_STUDY = """study: throughput
kind: tumble
part: irregular_polyhedron
tasks:
  sample: {{n: {tasks}, box: [[-0.15, 0.15], [-0.15, 0.15]], heading: [-180deg, 180deg]}}
planner: {{tumble_eps: 2.0e-3, tumble_tau_v: 0.0}}
tolerances: {{tau_v: 1.0e-5}}
friction: {{mu_f: [1.5, 1.5], mu_s: [1.5, 1.5]}}
eps: {{pos_eps_m: 0.004, theta_eps_rad: 0.02}}
model: {model}
samples: {samples}
seed: 0
report: false
"""
#: (model, support, fewer samples, more samples) per task
#: (both at least 8: a batch is padded to 8 or more, and two counts padded alike cost alike)
ROWS = {"quasistatic:any": (200, 4200), "exact:any": (200, 20200),
        "limit_surface:rigid": (64, 2112), "limit_surface:any": (64, 576),
        "mujoco:rigid": (8, 24), "mujoco:any": (8, 24),
        "tumble-exact:any": (200, 20200), "tumble-mujoco:any": (8, 16)}


def _run(folder: pathlib.Path, model: str, support: str, samples: int, tasks: int) -> float:
    cfg = folder / f"{model}-{support}-{samples}.yaml"
    if model.startswith("tumble-"):   # a tumble study of the irregular polyhedron
        text = TUMBLE_STUDY.format(model=model[len("tumble-"):], samples=samples, tasks=tasks)
    else:
        text = STUDY.format(model=model, support=support, samples=samples, tasks=tasks)
    cfg.write_text(text)
    env = {**os.environ, "NUDGE_JAX_CACHE": str(folder / "cache")}
    # a new run folder every time: the same one would resume, finished, in no time
    out = tempfile.mkdtemp(prefix=cfg.stem + "-", dir=folder)
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "sweeps.run", str(cfg), "--out", out, "--quiet",
                        "--yes"], cwd=ROOT, env=env, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"{cfg.name}: exit {r.returncode}\n{r.stderr[-2000:]}")
    return time.perf_counter() - t0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rows", nargs="+", default=list(ROWS), choices=list(ROWS))
    ap.add_argument("--tasks", type=int, default=4)
    a = ap.parse_args(argv)
    results = {}
    with tempfile.TemporaryDirectory(prefix="nudge-throughput-") as tmp:
        folder = pathlib.Path(tmp)
        print(f"{'model':14s} {'support':8s} {'measured/s':>11s} {'table/s':>9s} {'table/measured':>15s}")
        for row in a.rows:
            model, support = row.split(":")
            lo, hi = ROWS[row]
            # warm the compilation cache for both counts: a batch of another size compiles
            # again, and a cold compilation in the difference took limit_surface to 8/s
            # where the study runs at 40/s
            _run(folder, model, support, lo, a.tasks)
            _run(folder, model, support, hi, a.tasks)
            t_lo = _run(folder, model, support, lo, a.tasks)
            t_hi = _run(folder, model, support, hi, a.tasks)
            rate = (hi - lo) * a.tasks / max(t_hi - t_lo, 1e-3)
            kind, name = ("tumble", model[len("tumble-"):]) if model.startswith("tumble-") \
                else ("push", model)
            table = samples_per_second(kind, name, support)
            results[row] = (rate, table)
            print(f"{model:14s} {support:8s} {rate:11.3g} {table:9.3g} {table / rate:15.2f}",
                  flush=True)
    worst = max((t / r for r, t in results.values()), key=lambda x: max(x, 1 / x))
    print("RESULT " + " ".join(f"{k.replace(':', '_').replace('-', '_')}={r:.3g}" for k, (r, _) in results.items())
          + f" worst_ratio={worst:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
