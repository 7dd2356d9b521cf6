"""Benchmark: physics rollouts of a push plan (robustness.physics).

Run by hand from the repository root (no assertions on time)::

    python bench/physics.py             # default sizes (a few minutes on 2 cores)
    python bench/physics.py --quick     # smaller, no MJX
    python bench/physics.py --no-mjx    # skip MJX (its CPU compile takes ~1 min)

Workload: a plan of the 40 x 20 mm rectangle (``examples/rectangle.yaml``,
start ``(0, 0, 0)``, goal ``(0.05, 0.05, 1.0)``: translations and reorient
pushes), ``n`` samples with perturbed geometry, friction and execution.

1. **Our layer against raw ``mujoco.rollout``** in the same run:
   :func:`robustness.physics.rollout_push_plan` end to end (part building,
   MjSpec compilation, chunked rollouts, monitors, outcome classification)
   against ONE ``mujoco.rollout`` call of the same per-sample models over the
   same full control sequence (built by the layer's own schedule) on the
   same number of threads.  overhead = ours / raw - 1 (goal < 20 %).
2. **MJX on the CPU** (float32, vmapped): the same plan's first push on a few
   samples, timed on its second call (after the compilation, timed apart),
   in world-steps/s.  No accelerator was lent to the session that wrote this
   (see the closing note of issue 9); on one, ``run`` it with a larger
   ``--mjx-n``.
3. **Soft-friction creep** of a sticking contact: the rectangle's 15 cm
   reorient push (start heading 30 degrees, fence along +x, mu_f 1.5, the
   quasi-static model sticks), the tracked slip of the contact along the
   fence (tripod support, c 8 mm), C engine with noslip 20 (default), with
   noslip 0 at impratio 1, 30 (the soft model both engines run) and 100, and
   MJX itself under the soft model.

Last line: ``RESULT steps_per_s=N overhead=R mjx_cpu_steps_per_s=M``
(physics steps per second per sample summed over samples, C engine, our
layer).
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
import numpy as np  # noqa: E402
from mujoco import rollout as mj_rollout  # noqa: E402

from kernels import polygon as pg  # noqa: E402
from planning import plan_pose  # noqa: E402
from robustness import ExecutionTolerance, FrictionRange, GeometryTolerance, Sampler  # noqa: E402
from robustness.physics import PhysicsSettings, rollout_push_plan  # noqa: E402
from robustness.physics import push as push_mod  # noqa: E402
from robustness.physics import scene  # noqa: E402
from robustness.cpus import cpu_threads  # noqa: E402
from robustness.physics.pushing import FenceStrokes, nominal_polygon, push_parts  # noqa: E402
from robustness.physics.settings import SOFT_IMPRATIO  # noqa: E402
from sweeps.partfile import load_part  # noqa: E402

import mujoco  # noqa: E402


def _sampler(mu_f=(0.5, 1.0)):
    return Sampler(geometry=GeometryTolerance(tau_v=2e-5, tau_com=1e-4),
                   friction=FrictionRange(mu_f=mu_f, mu_s=(0.4, 0.6), support="rigid"),
                   execution=ExecutionTolerance(start_xy=2e-4, start_theta=math.radians(0.2),
                                                fence_angle=math.radians(0.2),
                                                distance_abs=2e-4))


def _params(plan, sampler, n, seed=0):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", pg.PartWarning)
        body = pg.make_polygon(np.asarray(plan.vertices), np.asarray(plan.com)).body
    return sampler.sample(jax.random.key(seed), n, n_vertices=len(plan.vertices), dim=2,
                          n_pushes=plan.n_pushes, body=body)


def raw_rollout(plan, draws, s):
    """Time ONE ``mujoco.rollout`` over the layer's models and controls."""
    poly, _ = nominal_polygon(plan)
    parts = push_parts(plan, poly, draws)
    idx = np.flatnonzero(parts.valid)
    models = push_mod._models(parts, idx, s, s.impratio)
    lay = scene.layout(models[0])
    strokes = FenceStrokes(plan, poly, parts, idx, s)
    sched = strokes.schedule
    ctrl = sched.controls(0, sched.total, len(idx))
    st0 = push_mod._initial_state(parts, idx, lay, sched, s)
    nthread = min(s.threads or cpu_threads(), len(idx))
    datas = [mujoco.MjData(models[0]) for _ in range(nthread)]
    with mj_rollout.Rollout(nthread=nthread if nthread > 1 else 0) as pool:
        t0 = time.perf_counter()
        pool.rollout(models, datas, st0, ctrl, nstep=sched.total)
        return time.perf_counter() - t0, len(idx) * sched.total


def layer_vs_raw(plan, n, s, repeat):
    """Best of ``repeat`` interleaved runs of each (the machine is shared)."""
    draws = _params(plan, _sampler(), n)
    rollout_push_plan(plan, draws.slice(0, 1), backend="c", settings=s)     # warm the caches
    ours = raw = math.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        r = rollout_push_plan(plan, draws, backend="c", settings=s)
        ours = min(ours, time.perf_counter() - t0)
        t_raw, steps = raw_rollout(plan, draws, s)
        raw = min(raw, t_raw)
    return ours, raw, steps, r


def mjx_cpu(plan, n, s):
    one = dataclasses.replace(plan, pushes=plan.pushes[:1], goal=plan.pushes[0].pose_after)
    draws = _params(one, _sampler(), n, seed=1)   # rigid support: MJX mesh-plane contacts
    t0 = time.perf_counter()
    rollout_push_plan(one, draws, backend="mjx", settings=s)
    first = time.perf_counter() - t0
    t0 = time.perf_counter()
    r = rollout_push_plan(one, draws, backend="mjx", settings=s)
    second = time.perf_counter() - t0
    return first - second, second, n * r.steps


def creep(backends_settings):
    part = load_part(ROOT / "examples" / "rectangle.yaml")
    poly = pg.make_polygon(part.vertices, part.com)
    th0 = math.radians(30.0)
    W = poly.body @ np.array([[math.cos(th0), math.sin(th0)], [-math.sin(th0), math.cos(th0)]])
    edge = None
    from planning.pushing.plan import Push, PushPlan
    from kernels.push import replay_pushes
    import jax.numpy as jnp

    with jax.enable_x64(True):
        geom = pg.polygon_geometry(jnp.asarray(poly.body))
        fin, outs = replay_pushes(geom, jnp.array([0.0, 0.0, th0]), jnp.array([[1.0, 0.0]]),
                                  jnp.array([0.15]))
        edge = poly.edge_vertices(int(outs.edge[0]))
        after = tuple(float(v) for v in np.asarray(fin))
    del W
    push = Push("reorient", (1.0, 0.0), 0.15, edge, 0, 0.15, after)
    plan = PushPlan(vertices=tuple(map(tuple, part.vertices)), com=tuple(poly.com),
                    start=(0.0, 0.0, th0), goal=after, pushes=(push,), plan_class="cw",
                    reorient_edge=edge, object_class="nice-stable", objective_value=0.15,
                    total_distance=0.15, final_error=(0.0, 0.0))
    sam = Sampler(friction=FrictionRange(mu_f=(1.5, 1.5), mu_s=(0.5, 0.5), c=(0.008, 0.008)))
    draws = _params(plan, sam, 1, seed=2)
    rows = []
    for label, backend, s in backends_settings:
        r = rollout_push_plan(plan, draws, backend=backend, settings=s, stroke="contact")
        rows.append((label, float(r.slip[0]) * 1e3, float(r.err_pos[0]) * 1e3))
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small sizes, no MJX")
    ap.add_argument("--no-mjx", action="store_true", help="skip the MJX rows")
    ap.add_argument("--n", type=int, default=8, help="samples of the C-engine workload")
    ap.add_argument("--mjx-n", type=int, default=4, help="samples of the MJX workload")
    ap.add_argument("--repeat", type=int, default=3, help="best of this many timed runs")
    args = ap.parse_args()
    s = PhysicsSettings()
    part = load_part(ROOT / "examples" / "rectangle.yaml")
    plan = plan_pose(part.vertices, (0.0, 0.0, 0.0), (0.05, 0.05, 1.0), com=part.com)
    n = 2 if args.quick else args.n
    if args.quick:
        plan = dataclasses.replace(plan, pushes=plan.pushes[:2], goal=plan.pushes[1].pose_after)
    print(f"plan: {plan.n_pushes} pushes, {plan.total_distance:.3f} m; {n} samples; "
          f"{cpu_threads()} threads; timestep {s.timestep * 1e3:g} ms")
    ours, raw, steps, r = layer_vs_raw(plan, n, s, 1 if args.quick else args.repeat)
    sps, raw_sps = steps / ours, steps / raw
    overhead = ours / raw - 1.0
    print(f"{'path':<34}{'wall s':>9}{'steps/s':>12}{'rollouts/s':>12}")
    print(f"{'raw mujoco.rollout (C, threads)':<34}{raw:>9.2f}{raw_sps:>12.0f}{n / raw:>12.3f}")
    print(f"{'rollout_push_plan (C, threads)':<34}{ours:>9.2f}{sps:>12.0f}{n / ours:>12.3f}")
    print(f"overhead of the layer: {overhead * 100:.1f} %  (per-thread steps/s: "
          f"{sps / min(cpu_threads(), n):.0f})")
    print(f"outcomes: success {r.success.mean():.2f}, modes "
          f"{dict(zip(*np.unique(r.failure_mode, return_counts=True)))}")
    mjx_sps = float("nan")
    if not (args.quick or args.no_mjx):
        compile_s, run_s, msteps = mjx_cpu(plan, args.mjx_n, dataclasses.replace(
            s, noslip_iterations=0, impratio=SOFT_IMPRATIO))
        mjx_sps = msteps / run_s
        print(f"MJX on CPU (float32, {args.mjx_n} worlds): compile {compile_s:.1f} s, "
              f"{mjx_sps:.0f} world-steps/s ({mjx_sps / sps:.3f} x the C layer)")
    soft = dataclasses.replace(s, noslip_iterations=0, impratio=SOFT_IMPRATIO)
    rows = [("C noslip 20 (default)", "c", s),
            ("C noslip 0, impratio 1", "c", dataclasses.replace(s, noslip_iterations=0)),
            ("C noslip 0, impratio 30 (soft)", "c", soft),
            ("C noslip 0, impratio 100", "c", dataclasses.replace(s, noslip_iterations=0,
                                                                 impratio=100.0))]
    if not (args.quick or args.no_mjx):
        rows.append(("MJX (soft, float32)", "mjx", soft))
    print(f"{'creep of a sticking 15 cm reorient push':<40}{'slip mm':>9}{'pose err mm':>13}")
    for label, sl, ep in creep(rows):
        print(f"{label:<40}{sl:>9.3f}{ep:>13.3f}")
    print(f"RESULT steps_per_s={sps:.0f} overhead={overhead:.3f} mjx_cpu_steps_per_s={mjx_sps:.0f}")


if __name__ == "__main__":
    main()
