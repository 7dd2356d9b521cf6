"""Candidate reorientation sequences of the pose planner: what is searched.

A candidate fixes the reorient pushes of a plan (their stable edges, senses and
angles) up to the start and goal orientations; the pose LP then fixes every
push length (:mod:`planning.pushing.pose_lp`), exactly, and the planner keeps
the candidate with the best objective.  A candidate is a *template* (one row of
:func:`candidate_table`) expanded for a start/goal pair by :func:`expand`: the
main run turns the part by ``Delta`` in its sense ``sigma`` (``Delta`` in
``(0, 2 pi]``: the goal orientation reached in that sense) plus ``turns`` full
turns, optionally preceded by a *pre-excursion* and/or followed by a
*post-excursion* in the opposite sense (the main run then turns that much
more).  Every reorient push lands a stable edge and turns at most that
edge's step angle in its sense (:class:`~planning.pushing.part.PushPart`).

``strategy="paper"`` (Akella & Mason, section 5): a translation plan when the
orientations agree; for every stable edge and sense the angle-eating
sequence on that edge (``n - 1`` full step angles and a last smaller one);
only when none of these is feasible, the singularity handlers: a pre-excursion
on the same edge by the smaller of its two step angles, then the main run.

``strategy="search"`` (default) searches, for every main sense:

* the number of steps: ``n_min .. n_min + extra_steps`` equal steps
  (``n_min`` the fewest the step angle allows); more, smaller steps start
  farther from the divergent orientation, where the distance rule's
  ``ln tan`` grows slowly, but make more pushes.  Uni-stable parts also try
  ``n_min + m extra_steps`` for ``m`` in ``UNI_STEP_MULTIPLES`` (2, 3, 4): with
  one stable edge their reorient runs are their only way to steer, a turn
  with small steps sweeps a tighter circle, and the extra-turn plans that
  cover missing push directions need a full turn's worth of steps.  Their
  main runs may also end with a step of its own (rule ``LAST``): a quarter,
  half, three quarters or all of the step angle, the steps before it sharing
  the rest equally; the last push direction then falls elsewhere, which often
  turns a detour into a direct approach (on the bundled part a fifth of the
  goals get 8 % to 69 % shorter plans);
* the stable edge of each step: one edge for the whole run (nice-stable parts:
  among the edges whose distance per radian of small steps, ``gain /
  sin(beta2)``, is within ``RATE_PRUNE`` of the best edge's in that sense), and
  (biplus-stable parts) two edges, the first one for a third or two thirds of
  the steps, the other for the rest, which steers the net displacement of the
  reorient pushes;
* uni- and biplus-stable parts: one extra full turn, and a pre- or a
  post-excursion of half or one step angle of the cheapest edge in the
  opposite sense (cheapest: the smallest ``gain / sin(beta2)``, the distance
  per radian of small steps), split into the fewest steps.

Not searched: unequal steps within a run (beyond the two-edge split, the
last step of its own and the paper's angle-eating runs), more
than two edges per run, more than one excursion per plan or one extra turn,
excursions and turns for nice-stable parts (their translations span the plane
at every orientation, so nearly every candidate is feasible without them), and
reorient pushes that roll over unstable edges (the paper's maximum reorient
angle stops at the nearest edge).  No plan has more than ``max_reorients``
reorient pushes (the effort budget): a candidate that would is skipped.

The paper's candidates are among the search's and compete on cost (tier
0), so the search plans wherever the paper's planner does and its plan is
never longer (for ``pushes``: never more pushes) than the paper's.  The one
exception is exact too: a nice-stable part's singularity handlers stay a
fallback (tier 1), as in the paper's strategy, which never reaches them
there: its stable edges' push directions span the plane, so every
angle-eating candidate is feasible within the budget, and a handler needs
more reorient pushes than its own angle-eating run (short of plans too long
to replay, ``PushPart.longest_plan``); they would slow the batched planner
down for nothing.  (Without the paper's candidates a biplus-stable part asked
for a tiny rotation in place found no plan, the search's excursions using the
cheapest edge, the paper's singularity handler the main run's own; and as a
mere fallback they lost on cost: on random triangles one plan in 40 was 0.2 %
to 15 % longer than the paper's, whose full steps plus a remainder, or whose
edge pruned by ``RATE_PRUNE``, were shorter.)  An angle-eating run of one
step that an equal-steps candidate makes too is skipped (``twin``).

Both planners (:func:`planning.pushing.planner.plan_pose`, numpy, and
:func:`planning.pushing.batch.plan_pose_batch`, JAX) read the same table, in
the same order, and break ties the same way (the lowest row within a relative
``COST_TIE`` of the best).
"""
from __future__ import annotations

import dataclasses
import functools
import math
from typing import Optional

import numpy as np

from kernels import BIPLUS_STABLE, CCW, CW, NICE_STABLE, UNI_STABLE
from planning.pushing.part import PushPart

COST_TIE = 1e-9          # relative: candidates this close in cost tie; the lower row wins
STEP_ROUND = 1e-12       # relative slack of the fewest-steps count (rounding of Delta / step)
EXCURSION_FRACTIONS = (0.5, 1.0)
#: nice-stable parts: a stable edge whose distance per radian of small steps
#: exceeds the best edge's (in that sense) by more than this factor runs no main run
RATE_PRUNE = 1.5
SPLIT_FRACTIONS = (1.0 / 3.0, 2.0 / 3.0)
#: uni-stable parts steer only by their reorient runs: their main runs also try
#: these multiples of ``extra_steps`` more steps (more, smaller steps turn on a
#: tighter circle, towards the distance rule's least distance per radian)
UNI_STEP_MULTIPLES = (2, 3, 4)
#: uni-stable parts: main runs whose last step turns these fractions of the step
#: angle and the steps before it share the rest equally (rule ``LAST``)
LAST_FRACTIONS = (0.25, 0.5, 0.75, 1.0)

# plan classes (index into planning.pushing.plan.PLAN_CLASSES)
TRANSLATION, CLS_CW, CLS_CCW, CLS_SING_CW, CLS_SING_CCW = range(5)
EQUAL, EAT, LAST = 0, 1, 2

FIELDS = ("cls", "trans", "tier", "sense", "turns", "rule", "a", "b", "sa", "sb", "extra",
          "split", "pre_e", "pre_ang", "pre_cnt", "post_e", "post_ang", "post_cnt", "step", "last", "twin")


@dataclasses.dataclass(frozen=True)
class Step:
    """One reorient push of a candidate: hull ``edge`` landed, ``sense`` (CW 0 /
    CCW 1) of the part's rotation and its angle ``alpha`` (rad, > 0)."""

    edge: int
    sense: int
    alpha: float


def _rate(part: PushPart, e: int, sense: int) -> float:
    """Distance per radian (m/rad) of small reorient steps onto ``e`` in ``sense``."""
    return float(part.gain[e, sense] / math.sin(part.beta2[e, sense]))


def _row(**kw) -> dict:
    base = dict(cls=0, trans=0, tier=0, sense=0, turns=0, rule=EQUAL, a=0, b=0, sa=0, sb=0, extra=0,
                split=0.0, pre_e=-1, pre_ang=0.0, pre_cnt=0, post_e=-1, post_ang=0.0, post_cnt=0,
                step=1.0, last=0.0, twin=0)
    base.update(kw)
    return base


def _excursion(part: PushPart, e: int, sense: int, frac: float):
    ang = frac * float(part.step[e, sense])
    return ang, int(math.ceil(frac * (1.0 - STEP_ROUND))) if ang > 0 else 0


@functools.lru_cache(maxsize=64)
def candidate_table(part: PushPart, strategy: str = "search", extra_steps: int = 3) -> dict:
    """The candidate templates of ``part`` (module docstring), as a dict of
    equal-length numpy arrays (fields ``FIELDS``); row 0 is the translation
    plan.  Rows of ``tier`` 1 (the paper's singularity handlers with
    ``strategy="paper"``) are tried only when no row of tier 0 is feasible."""
    rows = [_row(trans=1)]
    stable = list(part.stable)
    usable = {(e, s): part.step[e, s] > 0.0 for e in stable for s in (CW, CCW)}
    sidx = {e: i for i, e in enumerate(stable)}
    if strategy == "paper":
        return _as_arrays(rows + _paper_rows(part, stable, usable, sidx, handler_tier=1))
    rows += _search_rows(part, stable, usable, sidx, extra_steps)
    # the paper's candidates compete on cost (module docstring: its handlers stay a fallback
    # for nice-stable parts, where the paper's strategy never reaches them)
    handlers = 1 if part.object_class == NICE_STABLE else 0
    return _as_arrays(rows + _mark_twins(rows, _paper_rows(part, stable, usable, sidx, handlers)))


def _mark_twins(rows: list, paper: list) -> list:
    """The paper's angle-eating rows whose one-step run is an equal-steps row of
    ``rows`` (same edge and sense, no excursion, turn or extra step) get
    ``twin=1``: :func:`expand` skips them when their run has one step (the same
    sequence; the tie would go to the lower row anyway)."""
    single = {(r["sense"], r["a"]) for r in rows if not r["trans"] and r["rule"] == EQUAL and r["extra"] == 0
              and r["split"] == 0.0 and r["turns"] == 0 and r["pre_cnt"] == 0 and r["post_cnt"] == 0}
    return [{**r, "twin": int(r["pre_cnt"] == 0 and (r["sense"], r["a"]) in single)} for r in paper]


def _paper_rows(part: PushPart, stable, usable, sidx, handler_tier: int) -> list:
    """Akella & Mason's candidates: angle-eating on every stable edge and sense
    (tier 0), then the singularity handlers (tier ``handler_tier``: 1 for the
    paper's strategy, which tries them only where no angle-eating one is feasible)."""
    rows = []
    for sing in (0, 1):
        for e in stable:
            for sense in (CW, CCW):
                if not usable[e, sense]:
                    continue
                kw = dict(cls=(CLS_SING_CW if sing else CLS_CW) + sense, tier=handler_tier * sing,
                          sense=sense, rule=EAT, a=e, b=e, sa=sidx[e], sb=sidx[e], step=part.step[e, sense])
                if sing:
                    pre = float(min(part.step[e, 0], part.step[e, 1]))
                    if pre <= 0.0:
                        continue
                    kw.update(pre_e=e, pre_ang=pre, pre_cnt=1)
                rows.append(_row(**kw))
    return rows


def step_extras(object_class: int, extra_steps: int) -> tuple:
    """The steps a main run may take beyond the fewest (module docstring):
    ``0 .. extra_steps``, and for uni-stable parts also ``UNI_STEP_MULTIPLES``
    times ``extra_steps``."""
    extras = set(range(extra_steps + 1))
    if object_class == UNI_STABLE:
        extras |= {m * extra_steps for m in UNI_STEP_MULTIPLES}
    return tuple(sorted(extras))


def _search_rows(part: PushPart, stable, usable, sidx, extra_steps: int) -> list:
    """The search's own candidates (module docstring), all of tier 0."""
    rows = []
    cls = part.object_class
    turns = (0,) if cls == NICE_STABLE else (0, 1)
    fracs = () if cls == NICE_STABLE else EXCURSION_FRACTIONS
    splits = SPLIT_FRACTIONS if cls == BIPLUS_STABLE else ()
    extras = step_extras(cls, extra_steps)
    for sense in (CW, CCW):
        opp = 1 - sense
        cheap = [e for e in stable if usable[e, opp]]
        excs = [(-1, 0.0, 0, -1, 0.0, 0)]
        if cheap and fracs:
            ex = min(cheap, key=lambda e: (_rate(part, e, opp), e))
            for f in fracs:
                ang, cnt = _excursion(part, ex, opp, f)
                excs.append((ex, ang, cnt, -1, 0.0, 0))
            for f in fracs:
                ang, cnt = _excursion(part, ex, opp, f)
                excs.append((-1, 0.0, 0, ex, ang, cnt))
        main = [e for e in stable if usable[e, sense]]
        if main and cls == NICE_STABLE:
            best = min(_rate(part, e, sense) for e in main)
            main = [e for e in main if _rate(part, e, sense) <= RATE_PRUNE * best]
        pairs = [(a, a, 0.0) for a in main] + [(a, b, f) for a in main for b in main if a != b
                                               for f in splits]
        for t in turns:
            for pre_e, pre_ang, pre_cnt, post_e, post_ang, post_cnt in excs:
                sing = pre_e >= 0 or post_e >= 0
                for a, b, f in pairs:
                    step = min(part.step[a, sense], part.step[b, sense])
                    lasts = [(EQUAL, 0.0)] + ([(LAST, fr * step) for fr in LAST_FRACTIONS]
                                              if cls == UNI_STABLE and a == b and step > 0 else [])
                    for rule, last in lasts:
                        for extra in extras:
                            rows.append(_row(cls=(CLS_SING_CW if sing else CLS_CW) + sense, sense=sense,
                                             turns=t, rule=rule, a=a, b=b, sa=sidx[a], sb=sidx[b],
                                             extra=extra, split=f, pre_e=pre_e, pre_ang=pre_ang,
                                             pre_cnt=pre_cnt, post_e=post_e, post_ang=post_ang,
                                             post_cnt=post_cnt, step=step, last=last))
    return rows


def _as_arrays(rows: list) -> dict:
    out = {}
    for k in FIELDS:
        vals = [r[k] for r in rows]
        out[k] = np.array(vals, dtype=float if isinstance(rows[0][k], float) else int)
    return out


def rotation_of(sense: int, theta0: float, thetag: float) -> float:
    """Rotation ``Delta`` (rad, in (0, 2 pi]) that takes ``theta0`` to ``thetag``
    turning in ``sense`` (a full turn when they are equal)."""
    sgn = 1.0 if sense == CCW else -1.0
    delta = float(np.remainder(sgn * (thetag - theta0), 2 * math.pi))
    return 2 * math.pi if delta == 0.0 else delta


def main_count(total: float, step: float, extra: int) -> int:
    """Number of steps of a main run of ``total`` rad with step angle ``step``."""
    return int(math.ceil(total / step * (1.0 - STEP_ROUND))) + int(extra)


def split_count(n: int, frac: float) -> int:
    """Steps on the first edge of a two-edge run of ``n`` steps (``frac`` 0: all)."""
    if frac == 0.0:
        return n
    return min(max(int(round(frac * n)), 1), n - 1)


def _main_run(c: dict, theta0: float, thetag: float) -> Optional[tuple[int, float, float, float]]:
    """``(n, total, rest, delta)`` of candidate ``c`` (one table row as a dict):
    the main run's steps, the angle it turns with the excursions (rad), what its
    equal steps share under rule ``LAST`` and ``Delta``; None where the row does
    not apply whatever the budget (:func:`expand`)."""
    if c["trans"] or c["step"] <= 0.0:
        return None
    delta = rotation_of(int(c["sense"]), theta0, thetag)
    total = delta + 2 * math.pi * int(c["turns"]) + float(c["pre_ang"]) + float(c["post_ang"])
    rest = total
    if c["rule"] == LAST:
        rest = total - float(c["last"])
        if not rest > 0.0:
            return None
        n = main_count(rest, float(c["step"]), int(c["extra"])) + 1
    else:
        n = main_count(total, float(c["step"]), int(c["extra"]))
    if (c["twin"] and n == 1) or (c["rule"] == EQUAL and c["split"] != 0.0 and n < 2):
        return None
    return n, total, rest, delta


def reorient_pushes(table: dict, row: int, theta0: float, thetag: float) -> Optional[int]:
    """How many reorient pushes candidate ``row`` makes from ``theta0`` to
    ``thetag`` (rad) whatever the budget; None where it does not apply
    otherwise (a translation row among them)."""
    c = {k: v[row] for k, v in table.items()}
    run = _main_run(c, theta0, thetag)
    return None if run is None else run[0] + int(c["pre_cnt"]) + int(c["post_cnt"])


def expand(table: dict, row: int, theta0: float, thetag: float,
           max_reorients: int) -> Optional[tuple[list, np.ndarray]]:
    """The reorient steps and orientations of candidate ``row`` for a start
    orientation ``theta0`` and goal ``thetag`` (rad).

    Returns ``(steps, thetas)``: the :class:`Step` list and the ``len(steps) + 1``
    orientations (rad; ``thetas[0] = theta0``, the last one ``theta0 + sgn Delta``
    exactly), or None when the candidate does not apply (a translation plan for
    different orientations, a two-edge split of one step, a last step of its
    own that turns the whole run, an angle-eating run of one step that is an
    equal-steps row's (``twin``), or more than ``max_reorients`` reorient pushes).
    """
    c = {k: v[row] for k, v in table.items()}
    run = _main_run(c, theta0, thetag)
    if run is None or run[0] + int(c["pre_cnt"]) + int(c["post_cnt"]) > max_reorients:
        return None
    n, total, rest, delta = run
    sense = int(c["sense"])
    sgn = 1.0 if sense == CCW else -1.0
    opp = 1 - sense
    steps = []
    if c["pre_cnt"]:
        steps += [Step(int(c["pre_e"]), opp, float(c["pre_ang"]) / int(c["pre_cnt"]))] * int(c["pre_cnt"])
    if c["rule"] == EAT:
        full = float(c["step"])
        steps += [Step(int(c["a"]), sense, full)] * (n - 1) + [Step(int(c["a"]), sense, total - (n - 1) * full)]
    elif c["rule"] == LAST:
        steps += [Step(int(c["a"]), sense, rest / (n - 1))] * (n - 1) + [Step(int(c["a"]), sense, float(c["last"]))]
    else:
        j = split_count(n, float(c["split"]))
        alpha = total / n
        steps += [Step(int(c["a"]), sense, alpha)] * j + [Step(int(c["b"]), sense, alpha)] * (n - j)
    if c["post_cnt"]:
        steps += [Step(int(c["post_e"]), opp, float(c["post_ang"]) / int(c["post_cnt"]))] * int(c["post_cnt"])
    incs = [(1.0 if s.sense == CCW else -1.0) * s.alpha for s in steps]
    thetas = theta0 + np.concatenate([[0.0], np.cumsum(incs)])
    thetas[-1] = theta0 + sgn * (delta + 2 * math.pi * int(c["turns"]))
    return steps, thetas
