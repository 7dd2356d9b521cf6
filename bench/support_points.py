"""Benchmark: how many feet the pad and rim support families need (issue 38).

Run by hand from the repository root (no assertions)::

    python bench/support_points.py                # uniform and ring as nudge builds them (~16 min)
    python bench/support_points.py --both         # each count with and without corners (~30 min)
    python bench/support_points.py --families ring --counts 24,48 --reference 128

The ``uniform`` (a compliant pad) and ``ring`` (a rim) families of
:mod:`kernels.support` stand a part on ``UNIFORM_FEET`` / ``RING_FEET`` feet
(and, before December 2026, ``kernels.support.FEET_AT_CORNERS``, on its
corners too), loaded as equal springs; the MuJoCo scene stands it on the
same feet.  A pad or rim is continuous, so the question is how far a count
leaves a plan's outcome from the continuous limit.  For each family and count
(``--counts``, as nudge builds them and, ``--both``, with and without the
corners), in a
child process with :mod:`kernels.support`'s count set: the default plans of
the four bundled polygons to fixed goals (``GOALS``), ``--samples`` draws each
at fence friction 0.5, 0.8 and 1.5 (the tolerances of ``bench/throughput.py``;
support friction 0.3-0.5), replayed by the exact limit surface
(:mod:`kernels.quasistatic_points`, float64).  Against the reference count
without corners (``--reference``, the nearest to the continuous limit), per
count: the worst and median final position difference over the 12 cases
(mm; the orientations agree: every push lands the same edge), the fraction
of samples whose success (3 mm / 0.05 rad, and 1 mm / 1 degree) differs, and
the replay's samples per second (the nice-stable pentagon at fence friction
0.8, ``TIMED`` draws, timed on a second call) and its cost against today's
count.

Measured 2026-12-06, when the feet stood on the corners too
(``python bench/support_points.py --no-corners``, today ``--both``, 2 cores,
quiet, 29 min): worst / median final position difference against 256 feet
without corners (mm), the share of samples whose 3 mm and 1 mm verdicts
differ, samples/s of the timed case and its cost (the samples/s of the
counts then, with corners, over the count's; below 1: faster; * those
counts)::

    family  feet  corners  worst  median  flip 3 mm  flip 1 mm  samples/s  cost
    uniform   12   yes      3.91   0.706      0.138      0.005      1,567  0.32x
    uniform   12   no       3.51   0.574      0.034      0.000      1,260  0.40x
    uniform   25*  yes      2.72   0.403      0.117      0.000        507  1.00x
    uniform   25   no       2.19   0.420      0.023      0.000        913  0.56x
    uniform   48   yes      1.63   0.231      0.029      0.000        258  1.97x
    uniform   48   no       0.60   0.144      0.005      0.000        356  1.43x
    uniform  128   yes      0.74   0.156      0.000      0.000        136  3.73x
    uniform  128   no       0.50   0.039      0.005      0.000        143  3.55x
    ring      12   yes      0.98   0.348      0.102      0.008      1,451  0.55x
    ring      12   no       0.90   0.109      0.023      0.029      1,804  0.45x
    ring      24*  yes      0.69   0.052      0.055      0.008        803  1.00x
    ring      24   no       0.16   0.030      0.010      0.018      1,123  0.71x
    ring      48   yes      0.38   0.087      0.023      0.008        461  1.74x
    ring      48   no       0.05   0.007      0.005      0.003        491  1.64x
    ring     128   yes      0.16   0.039      0.010      0.005        130  6.19x
    ring     128   no       0.01   0.000      0.000      0.000        120  6.71x

(the RESULT line then, of the rows with corners; it now reports the rows
as nudge builds them)

``RESULT uniform_12_mm=3.91 uniform_12_flip3mm=0.138 uniform_25_mm=2.72
uniform_25_flip3mm=0.117 uniform_48_mm=1.63 uniform_48_flip3mm=0.029
uniform_128_mm=0.74 uniform_128_flip3mm=0.000 ring_12_mm=0.98
ring_12_flip3mm=0.102 ring_24_mm=0.69 ring_24_flip3mm=0.055 ring_48_mm=0.38
ring_48_flip3mm=0.023 ring_128_mm=0.16 ring_128_flip3mm=0.010``

What it says:

* **Today's pad is not converged.**  25 feet and the corners leave a plan's
  final position up to 2.7 mm from the dense pad (the fence slip it
  accumulates: the orientations agree) and change the 3 mm verdict of 12 %
  of the samples (1 mm / 1 degree: none; these plans fail there anyway).
  The rim's 24 feet and corners: 0.7 mm, 5.5 %.
* **The corners are most of the error.**  They carry a concentrated load (4
  of 29 feet on the rectangle; the slip of a pivot about a loaded point is
  not a pad's).  Without them the same counts are closer and faster (fewer
  feet, fewer warm solves that fail next to a loaded corner): the pad's 25
  feet 2.2 mm and 2.3 % at 1.8x the speed, 48 feet 0.6 mm and 0.5 % at 0.7x;
  the rim's 24 feet 0.16 mm and 1 % at 1.4x.  The pad converges slowly in
  the count (a quasi-random set in the area), the rim fast (equal spacing on
  a line).
* **Changed since** (``FEET_AT_CORNERS = False``): the pad and rim stand on
  their 25 and 24 feet alone, the rows marked "no" above; a part whose
  centre of mass falls outside the feet's hull stands on its corners in
  place of some feet (``kernels.support.standing_feet``).  The sampler's
  ``c`` and the MuJoCo scene follow (both read ``family_points``);
  ``bench/fidelity.py`` and ``bench/calibration.py`` were rerun after it
  (their docstrings).

Last line: ``RESULT <family>_<count>_mm=<worst position difference> ...
<family>_<count>_flip3mm=<fraction of samples whose 3 mm success differs>``.
"""
from __future__ import annotations

import argparse
import os
import pathlib
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from kernels import support as ks  # noqa: E402

#: the four bundled polygons and a goal each (from the start (0, 0, 0))
GOALS = {"nice_stable": (0.05, 0.02, 1.0), "biplus_stable": (0.06, -0.03, 2.0),
         "unistable": (0.04, 0.05, -1.5), "rectangle": (0.05, 0.0, 1.57)}
MU_F = (0.5, 0.8, 1.5)
#: the counts nudge uses
TODAY = {"uniform": ks.UNIFORM_FEET, "ring": ks.RING_FEET}
#: draws of the timed case (the nice-stable pentagon at fence friction 0.8)
TIMED = 1024
CRITERIA = {"3mm": (3e-3, 0.05), "1mm": (1e-3, np.radians(1.0))}


def sampler(family: str, mu_f: float):
    """``bench/throughput.py``'s tolerances on one support family and fence
    friction (also ``bench/quadrature.py``'s)."""
    from robustness import ExecutionTolerance, FrictionRange, GeometryTolerance, Sampler

    return Sampler(GeometryTolerance(tau_v=2e-5, tau_com=1e-4),
                   FrictionRange(mu_f=(mu_f, mu_f), mu_s=(0.3, 0.5), support=family),
                   ExecutionTolerance(start_xy=5e-4, start_theta=0.01, fence_angle=0.002,
                                      distance_abs=1e-4, distance_rel=0.005))


def child(family: str, count: int, corners: bool, samples: int, out: str) -> None:
    """One family and count: every case's final poses into ``out`` (npz)."""
    ks.UNIFORM_FEET = ks.RING_FEET = count     # read when the kernels are traced
    ks.FEET_AT_CORNERS = corners
    import jax
    import jax.numpy as jnp

    jax.config.update("jax_enable_x64", True)
    from planning import plan_pose
    from robustness import replay
    from sweeps.partfile import load_part

    res, rate = {}, float("nan")
    for name, goal in GOALS.items():
        part = load_part(ROOT / "examples" / f"{name}.yaml")
        plan = plan_pose(part.vertices, (0.0, 0.0, 0.0), goal, com=part.com)
        body = plan.nominal_part().body
        for mu in MU_F:
            draws = sampler(family, mu).sample(jax.random.key(3), samples, body=body,
                                               **plan.draw_shape())
            r = replay.run_push(plan, draws, "limit_surface", jnp.float64, 4096)[2]
            res[f"{name}_{mu}"] = np.stack([r.x, r.y, r.theta], 1).astype(np.float64)
            if name == "nice_stable" and mu == 0.8:   # timed on TIMED draws, a second call
                many = sampler(family, mu).sample(jax.random.key(4), TIMED, body=body,
                                                  **plan.draw_shape())
                run = lambda: replay.run_push(plan, many, "limit_surface", jnp.float64, 4096)  # noqa: E731
                run()
                t0 = time.perf_counter()
                run()
                rate = TIMED / (time.perf_counter() - t0)
    np.savez(out, rate=rate, **res)


def succeeds(pose, goal, criterion: str):
    """(n,) whether the final poses ``pose`` (n, 3) are within ``CRITERIA[criterion]``
    of ``goal`` (position m, heading rad)."""
    pe, te = CRITERIA[criterion]
    dth = np.abs((pose[:, 2] - goal[2] + np.pi) % (2 * np.pi) - np.pi)
    return (np.hypot(pose[:, 0] - goal[0], pose[:, 1] - goal[1]) < pe) & (dth < te)


def compare(run, ref) -> dict:
    """Worst and median position difference (m), success flips, per case and overall."""
    worst, med, flips = [], [], {c: [] for c in CRITERIA}
    for name, goal in GOALS.items():
        for mu in MU_F:
            a, b = run[f"{name}_{mu}"], ref[f"{name}_{mu}"]
            d = np.hypot(a[:, 0] - b[:, 0], a[:, 1] - b[:, 1])
            worst.append(d.max())
            med.append(np.median(d))
            for c in CRITERIA:
                flips[c].append(np.mean(succeeds(a, goal, c) != succeeds(b, goal, c)))
    return dict(worst=max(worst), median=float(np.median(med)),
                **{f"flip{c}": float(np.mean(v)) for c, v in flips.items()})


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--families", default="uniform,ring")
    ap.add_argument("--counts", default=None,
                    help="feet counts to measure (default: 12, today's, 48, 128)")
    ap.add_argument("--reference", type=int, default=256,
                    help="the reference count (without corners)")
    ap.add_argument("--samples", type=int, default=32, help="draws per part and fence friction")
    ap.add_argument("--both", action="store_true",
                    help="measure each count with and without the corners")
    ap.add_argument("--child", nargs=4, metavar=("FAMILY", "COUNT", "CORNERS", "OUT"),
                    help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        fam, count, corners, out = args.child
        return child(fam, int(count), corners == "1", args.samples, out)

    result = []
    with tempfile.TemporaryDirectory() as tmp:
        def measure(fam, count, corners):
            out = os.path.join(tmp, f"{fam}-{count}-{int(corners)}.npz")
            t0 = time.perf_counter()
            subprocess.run([sys.executable, __file__, "--samples", str(args.samples), "--child",
                            fam, str(count), "1" if corners else "0", out], check=True)
            print(f"  {fam} {count} feet{'' if corners else ' (no corners)'}: "
                  f"{time.perf_counter() - t0:.0f} s", flush=True)
            return dict(np.load(out))

        for fam in args.families.split(","):
            today = TODAY[fam]
            counts = ([int(c) for c in args.counts.split(",")] if args.counts
                      else [12, today, 48, 128])
            ref = measure(fam, args.reference, False)
            print(f"\n{fam}: against {args.reference} feet without corners "
                  f"({args.samples} samples x 12 cases)")
            print(f"{'feet':>5} {'corners':>7} {'worst mm':>9} {'median mm':>9} "
                  f"{'flip 3mm':>8} {'flip 1mm':>8} {'samples/s':>9} {'cost':>6}")
            base = None
            rows = []
            for count in counts:
                for corners in ((True, False) if args.both else (ks.FEET_AT_CORNERS,)):
                    r = measure(fam, count, corners)
                    rows.append((count, corners, compare(r, ref), float(r["rate"])))
            base = next((rate for count, corners, _, rate in rows
                         if corners == ks.FEET_AT_CORNERS and count == today), rows[0][3])
            for count, corners, c, rate in rows:
                print(f"{count:5d} {'yes' if corners else 'no':>7} {c['worst'] * 1e3:9.2f} "
                      f"{c['median'] * 1e3:9.3f} {c['flip3mm']:8.3f} {c['flip1mm']:8.3f} "
                      f"{rate:9.0f} {base / rate:5.2f}x", flush=True)
                if corners == ks.FEET_AT_CORNERS:
                    result.append(f"{fam}_{count}_mm={c['worst'] * 1e3:.2f} "
                                  f"{fam}_{count}_flip3mm={c['flip3mm']:.3f}")
    print("RESULT " + " ".join(result))


if __name__ == "__main__":
    main()
