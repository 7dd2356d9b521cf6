"""Benchmark: how short can uni-stable push plans get under the default
(Peshkin) distance rule?  Evidence for issue 10's length target.

Run by hand from the repository root (no assertions)::

    python bench/push_length_limit.py              # ~15 minutes on 2 cores
    python bench/push_length_limit.py --goals 10

On the bundled uni-stable part (``examples/unistable.yaml``) and the goals of
``bench/push_planning.py`` (within 15 cm of the start, any orientation;
margin 7 deg, safety factor 1.15), each goal's total push distance over the
straight start-goal distance for:

* **default**: ``plan_pose_batch`` with its defaults (the search);
* **blocks**: a richer family than the search, every candidate's LP solved
  exactly: a pre-excursion and a post-excursion in the opposite sense of
  0-90 deg each, 0 or 1 extra turn, the main run in two blocks of unequal
  steps (the first block turning 0-80 % of it), each block with 0-4 steps more
  than the fewest (about 20,000 sequences per goal);
* **fine**: the continuous limit: every step 3 deg or less (so the rule's
  distance per radian is within 0.2 % of its least, ``gain / sin(beta2)``),
  excursions of 0-180 deg in 10 deg steps, 0 or 1 extra turn;
* **local**: from the best ``blocks`` sequence, every step angle optimised
  (Nelder-Mead, then Powell; the total turn held), the LP exact at each try;
* **best**: the shortest of all of these per goal.

These are plans the planner's LP accepts (the same reorient distances and
closed-form LP); none is a proof of optimality, but the median of ``best``
says how far a better search could move the default's.

Last line: ``RESULT median_default=R median_blocks=R median_fine=R
median_local=R median_best=R goals_within_5x=N/M``.
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import time
import warnings

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))   # the repository first
sys.path.append(os.path.dirname(__file__))

from kernels import polygon as pg  # noqa: E402
from planning import plan_pose_batch, prepare_part  # noqa: E402
from planning.pushing import planner as pl, pose_lp, sequences as sq  # noqa: E402
from push_planning import bundled_polygons, near_goals  # noqa: E402


class Goal:
    """One start/goal pair of the uni-stable part and its LP cost function."""

    def __init__(self, part, start, goal):
        self.part, self.start, self.goal = part, start, goal
        self.theta0, self.thetag = pl._orientations(start, goal)
        self.edge = part.stable[0]

    def cost(self, steps) -> float:
        """Least total push distance (m) of the reorient ``steps`` (the LP's optimum)."""
        incs = [(1.0 if s.sense == pg.CCW else -1.0) * s.alpha for s in steps]
        thetas = self.theta0 + np.concatenate([[0.0], np.cumsum(incs)])
        c = pl._lp_data(self.part, 0, steps, thetas, self.start, self.goal)
        sol = pose_lp.solve_closed_form(c.angles, np.ones(len(c.angles), bool), c.merged, c.target,
                                        scale=self.part.size)
        return float(c.need.sum() + sol.weights.sum()) if sol.feasible else math.inf

    def run(self, sense, n, ang):
        return [sq.Step(self.edge, sense, ang / n)] * n if n > 0 and ang > 0 else []

    def sequences(self, excursions, turns=(0, 1)):
        """``(sense, turns, e1, e2, total)`` of every main sense, turn count and
        pre/post excursion (rad)."""
        for sense in (pg.CW, pg.CCW):
            delta = sq.rotation_of(sense, self.theta0, self.thetag)
            for t in turns:
                for e1 in excursions:
                    for e2 in excursions:
                        yield sense, t, e1, e2, delta + 2 * math.pi * t + e1 + e2


def blocks(g: Goal, fracs=(0.0, 0.2, 0.35, 0.5, 0.65, 0.8), extra=4, max_reorients=24):
    """Best of the two-block family (module docstring): ``(cost, steps)``."""
    best = (math.inf, None)
    exc = np.radians([0, 15, 30, 45, 60, 90])
    for sense, _, e1, e2, tot in g.sequences(exc):
        opp = 1 - sense
        stp, sto = g.part.step[g.edge, sense], g.part.step[g.edge, opp]
        pre = g.run(opp, math.ceil(e1 / sto - 1e-9), e1)
        post = g.run(opp, math.ceil(e2 / sto - 1e-9), e2)
        for f in fracs:
            a1, a2 = f * tot, (1 - f) * tot
            n1 = math.ceil(a1 / stp - 1e-9) if a1 > 0 else 0
            n2 = math.ceil(a2 / stp - 1e-9)
            for x1 in range(extra + 1 if a1 > 0 else 1):
                for x2 in range(extra + 1):
                    steps = pre + g.run(sense, n1 + x1, a1) + g.run(sense, n2 + x2, a2) + post
                    if len(steps) <= max_reorients:
                        c = g.cost(steps)
                        if c < best[0]:
                            best = (c, steps)
    return best


def fine(g: Goal, deg=3.0):
    """Best sequence of steps of at most ``deg`` degrees (module docstring)."""
    h = math.radians(deg)
    best = math.inf
    for sense, _, e1, e2, tot in g.sequences(np.radians(np.arange(0, 181, 10))):
        opp = 1 - sense
        steps = (g.run(opp, math.ceil(e1 / h), e1) + g.run(sense, math.ceil(tot / h), tot)
                 + g.run(opp, math.ceil(e2 / h), e2))
        best = min(best, g.cost(steps))
    return best


def local(g: Goal, steps, evals=3000):
    """Every step angle of ``steps`` optimised, the main run's total held."""
    from scipy.optimize import minimize

    main_sense = max((pg.CW, pg.CCW), key=lambda s: sum(st.alpha for st in steps if st.sense == s))
    senses = [st.sense for st in steps]
    alpha = np.array([st.alpha for st in steps])
    is_main = np.array([s == main_sense for s in senses])
    held = alpha[is_main].sum() - alpha[~is_main].sum()     # main minus excursions: the net turn
    lim = np.array([g.part.step[g.edge, s] for s in senses])

    def build(x):
        a = np.exp(x)
        a[is_main] *= (held + a[~is_main].sum()) / a[is_main].sum()
        if np.any(a > lim):
            return None
        return [sq.Step(g.edge, s, float(v)) for s, v in zip(senses, a)]

    def f(x):
        s = build(x)
        return 1e3 if s is None else g.cost(s)

    x0 = np.log(alpha)
    r = minimize(f, x0, method="Nelder-Mead", options=dict(maxfev=evals, xatol=1e-4, fatol=1e-7))
    r2 = minimize(f, r.x, method="Powell", options=dict(maxfev=evals))
    return min(f(x0), r.fun, r2.fun)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--goals", type=int, default=40, help="goals (the first of push_planning.py's)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    verts, com, _ = bundled_polygons()["unistable"]
    part = prepare_part(verts, com)
    starts, goals = near_goals(40, seed=args.seed)
    starts, goals = starts[:args.goals], goals[:args.goals]
    straight = np.hypot(goals[:, 0], goals[:, 1])
    default = plan_pose_batch(verts, starts, goals, com=com).total_distance / straight
    rows = []
    print(f"{'goal':>4}{'cm':>6}{'default':>9}{'blocks':>8}{'fine':>7}{'local':>7}{'best':>7}{'s':>5}")
    for i in range(len(goals)):
        t0 = time.perf_counter()
        g = Goal(part, starts[i], goals[i])
        cb, steps = blocks(g)
        cf = fine(g)
        cl = local(g, steps)
        r = np.array([default[i], cb / straight[i], cf / straight[i], cl / straight[i]])
        rows.append(np.r_[r, r.min()])
        print(f"{i:>4}{straight[i] * 100:>6.1f}" + "".join(f"{v:>{w}.2f}" for v, w in zip(rows[-1], (9, 8, 7, 7, 7)))
              + f"{time.perf_counter() - t0:>5.0f}", flush=True)
    med = np.median(np.array(rows), axis=0)
    best = np.array(rows)[:, -1]
    print(f"median {'':>5}" + "".join(f"{v:>{w}.2f}" for v, w in zip(med, (9, 8, 7, 7, 7))))
    print(f"RESULT median_default={med[0]:.3f} median_blocks={med[1]:.3f} median_fine={med[2]:.3f} "
          f"median_local={med[3]:.3f} median_best={med[4]:.3f} goals_within_5x={int(np.sum(best <= 5.0))}/{len(best)}")


if __name__ == "__main__":
    main()
