"""Benchmark: what the limit-surface replay's quadrature buys, speed against
accuracy (issue 38's trade).

Run by hand from the repository root (no assertions)::

    python bench/quadrature.py                    # panels 64 (reference), 8, 4, 3, 2 (~9 min)
    python bench/quadrature.py --panels 64 8 4 --samples 128

:mod:`kernels.quasistatic_points` integrates each pivot of a push by 3-point
Gauss-Legendre on ``PANELS`` panels (8: three motion solves a panel, 24 a
phase); the ellipsoidal model (``quasistatic``) has each phase in closed form.
For each panel count (``--panels``, the first the reference; set in the
module, which the replay reads when it is traced), the default plans of the
four bundled polygons to fixed goals, supports ``rigid`` and ``any``, fence
friction 0.5, 0.8 and 1.5 (``--samples`` draws each; the tolerances of
``bench/throughput.py``), replayed by ``model: limit_surface`` in float64
through :func:`robustness.replay.run_push`.  Per count: the replay's samples
per second on the nice-stable pentagon's 7-push plan at fence friction 0.8
(``TIMED`` draws, rigid and ``any``, best of two warm calls) and its ratio to
``quasistatic`` on the same draws in the same run; against the reference, the
worst, 99th-percentile and median final position difference (mm), the worst
heading difference (rad), and how many samples' success changes (3 mm / 0.05
rad, and 1 mm / 1 degree, to the plan's goal).

The last line is ``RESULT p<P>_rigid=<samples/s> p<P>_x_qs=<ratio, rigid>
p<P>_x_qs_any=<ratio, any> p<P>_mm=<worst mm> p<P>_flip3mm=<samples> ...``
for each count.

Measured 2026-12-07, CPU (2 cores, a CPU device per core, quiet; 8.5 min),
256 draws a case (the timed case 1,024), 7,680 samples against 64 panels;
quasistatic 197,440 samples/s rigid, 264,215 ``any``::

    panels  rigid/s   any/s x qs rigid  x qs any  worst mm   p99 mm median mm worst rad flips 3mm flips 1mm
        64     3856    1342       51.2     196.8    0.0000   0.0000  0.000000  0.00e+00         0         0
         8    22577    5820        8.7      45.4    0.0617   0.0209  0.000000  0.00e+00         0         0
         4    38511    8582        5.1      30.8    0.1330   0.1019  0.000000  0.00e+00         2         4
         3    47738    9874        4.1      26.8    0.3167   0.1659  0.000000  0.00e+00         4         5
         2    58629   10574        3.4      25.0    0.5661   0.3302  0.000000  0.00e+00         3         6

    RESULT p64_rigid=3856 p64_x_qs=51.2 p64_x_qs_any=196.8 p64_mm=0.0000 p64_flip3mm=0
    p8_rigid=22577 p8_x_qs=8.7 p8_x_qs_any=45.4 p8_mm=0.0617 p8_flip3mm=0 p4_rigid=38511
    p4_x_qs=5.1 p4_x_qs_any=30.8 p4_mm=0.1330 p4_flip3mm=2 p3_rigid=47738 p3_x_qs=4.1
    p3_x_qs_any=26.8 p3_mm=0.3167 p3_flip3mm=4 p2_rigid=58629 p2_x_qs=3.4
    p2_x_qs_any=25.0 p2_mm=0.5661 p2_flip3mm=3

(the headings all equal the reference's: every one of these pushes lands an
edge, and a landing's heading is exact).  A first run of the same cases, the
same session: 8 panels 23,913 / 6,294, 4 panels 38,665 / 8,011, 3 panels
44,590 / 8,896 samples/s, the same differences.  The ratios are this plan's
at one fence friction, 0.8; ``bench/robustness.py``'s (friction drawn in
0.5-0.8, more sliding) are higher: 16x rigid at 8 panels.

What it says: the median sample is exact at every count (a phase that sticks
throughout and lands an edge is exact at any node count); the error is the
samples whose fence contact slides (1 % of them over 0.02 mm at 8 panels).
Halving the panels (8 -> 4) gains 1.7x on rigid corners and 1.5x on ``any``,
and leaves 0.13 mm and 2 of 7,680 verdicts at 3 mm changed; the issue's <= 5x
on rigid corners (in this measure) needs 3-4 panels (0.13-0.32 mm, 2-4
verdicts), beyond the 2e-7 m the tests hold against the fixed-step
integration (8 panels meet it; 6 do not, :mod:`kernels.quasistatic_points`),
which the issue asks to keep.  ``any`` stays 25-45x at every count: its pads
and rims (24-25 feet, half of its draws) cost about 9 times a rigid part's
corners a solve.
"""
from __future__ import annotations

import argparse
import os
import pathlib
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
# a CPU device per core, as the command lines give JAX (before it starts)
os.environ.setdefault("JAX_NUM_CPU_DEVICES", str(len(os.sched_getaffinity(0))))

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import support_points  # noqa: E402  (its goals, frictions, tolerances and criteria)
from kernels import quasistatic_points  # noqa: E402
from planning import plan_pose  # noqa: E402
from robustness import release_executables  # noqa: E402
from robustness.replay import run_push  # noqa: E402  (the evaluation's own replay)
from sweeps.partfile import load_part  # noqa: E402

SUPPORTS = ("rigid", "any")
#: the timed case and its draws
TIMED = ("nice_stable", 0.8)
TIMED_SAMPLES = support_points.TIMED


def cases(n: int) -> list:
    """``(part, support, mu_f, plan, draws, goal)`` for every case (the plans and
    tolerances of ``bench/support_points.py``)."""
    out = []
    for name, goal in support_points.GOALS.items():
        part = load_part(ROOT / "examples" / f"{name}.yaml")
        plan = plan_pose(part.vertices, (0.0, 0.0, 0.0), goal, com=part.com)
        body = plan.nominal_part().body
        for support in SUPPORTS:
            for mu in support_points.MU_F:
                k = TIMED_SAMPLES if (name, mu) == TIMED else n
                draws = support_points.sampler(support, mu).sample(
                    jax.random.key(2), k, body=body, **plan.draw_shape())
                out.append((name, support, mu, plan, draws, np.asarray(goal)))
    return out


def finals(plan, draws, model: str = "limit_surface") -> np.ndarray:
    """(n, 3) final poses (x, y, theta), world frame, m and rad."""
    _, _, res = run_push(plan, draws, model, jnp.float64, 4096)
    return np.stack([np.asarray(res.x), np.asarray(res.y), np.asarray(res.theta)], 1)


def rate(plan, draws, model: str, repeat: int = 2) -> float:
    """Samples/s of a warm replay (best of ``repeat``)."""
    finals(plan, draws, model)
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        finals(plan, draws, model)
        best = min(best, time.perf_counter() - t0)
    return draws.n / best


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--panels", type=int, nargs="+", default=[64, 8, 4, 3, 2],
                    help="panel counts; the first is the reference (default 64 8 4 3 2)")
    ap.add_argument("--samples", type=int, default=256, help="draws a case (default 256)")
    args = ap.parse_args(argv)
    jax.config.update("jax_enable_x64", True)
    all_cases = cases(args.samples)
    timed = {c[1]: c for c in all_cases if (c[0], c[2]) == TIMED}
    qs = {s: rate(c[3], c[4], "quasistatic", 3) for s, c in timed.items()}
    today = quasistatic_points.PANELS
    runs = {}
    try:
        for p in args.panels:
            quasistatic_points.PANELS = p          # read when the replay is traced
            jax.clear_caches()
            release_executables()
            poses = [finals(c[3], c[4]) for c in all_cases]
            rates = {s: rate(c[3], c[4], "limit_surface") for s, c in timed.items()}
            runs[p] = (poses, rates)
            print(f"panels {p}: {rates['rigid']:,.0f} samples/s rigid, {rates['any']:,.0f} any",
                  flush=True)
    finally:
        quasistatic_points.PANELS = today
    ref = runs[args.panels[0]][0]
    n_all = sum(len(r) for r in ref)
    print(f"\nquasistatic (reference for speed): {qs['rigid']:,.0f} samples/s rigid, "
          f"{qs['any']:,.0f} any; {n_all} samples against {args.panels[0]} panels")
    hdr = (f"{'panels':>6s} {'rigid/s':>8s} {'any/s':>7s} {'x qs rigid':>10s} {'x qs any':>9s} "
           f"{'worst mm':>9s} {'p99 mm':>8s} {'median mm':>9s} {'worst rad':>9s} "
           f"{'flips 3mm':>9s} {'flips 1mm':>9s}")
    print(hdr + "\n" + "-" * len(hdr))
    result = []
    for p, (poses, rates) in runs.items():
        pos = np.concatenate([np.hypot(*(f[:, :2] - r[:, :2]).T) for f, r in zip(poses, ref)])
        head = np.concatenate([np.abs(f[:, 2] - r[:, 2]) for f, r in zip(poses, ref)])
        flips = [sum(int(np.sum(support_points.succeeds(f, c[5], crit)
                                != support_points.succeeds(r, c[5], crit)))
                     for f, r, c in zip(poses, ref, all_cases))
                 for crit in support_points.CRITERIA]
        x_rigid, x_any = qs["rigid"] / rates["rigid"], qs["any"] / rates["any"]
        print(f"{p:6d} {rates['rigid']:8.0f} {rates['any']:7.0f} {x_rigid:10.1f} {x_any:9.1f} "
              f"{pos.max() * 1e3:9.4f} {np.quantile(pos, 0.99) * 1e3:8.4f} "
              f"{np.median(pos) * 1e3:9.6f} {head.max():9.2e} {flips[0]:9d} {flips[1]:9d}")
        result.append(f"p{p}_rigid={rates['rigid']:.0f} p{p}_x_qs={x_rigid:.1f} "
                      f"p{p}_x_qs_any={x_any:.1f} p{p}_mm={pos.max() * 1e3:.4f} "
                      f"p{p}_flip3mm={flips[0]}")
    print("\nRESULT " + " ".join(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
