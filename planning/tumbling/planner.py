"""Marigo-Bicchi tumble planner: ``analyze_polyhedron`` and ``plan_tumble``.

``analyze_polyhedron`` computes (and caches, per part, start face, tau_v and
tau_g) the paper's structure of the part: plane development, transit paths,
rotations ``R_j``, GCD of the defect angles, ``R_bar``, the translation
generators ``t_jk``, their lattice (HNF) and the class of the reachable set,
exactly and at the part's tolerance (:mod:`planning.tumbling.analysis`).

``plan_tumble`` plans one goal within an effort budget
(:mod:`planning.tumbling.effort`):

1. the paper's algorithm (steps 1-5, :mod:`planning.tumbling.paper`): its
   residuals, verdict checks, analytic bounds and tumble count
   (``n_tumbles_paper``, never materialised when huge);
2. with ``shorten=True`` (default) a short plan
   (:mod:`planning.tumbling.shorten`): meet-in-the-middle cores plus short
   translation loops (and, for irrational defect angles, short rotation
   loops).  A near-tame part is planned on its class at the part's tolerance
   first, then, if that gives no plan within ``eps``, on its exact class;
3. every candidate plan (the short plan; the paper's own plan when it is
   small enough to build, at most ``PAPER_MATERIALISE_CAP`` tumbles, and
   shorter than the short plan or needed as a fallback) is replayed from
   ``start`` with the JAX kernel :func:`kernels.tumble.replay` in float64;
   the shortest one on the goal face within ``eps`` is returned, else the
   most accurate one.  With ``tau_v > 0`` the part's faces are those at its
   tolerance (noise below it splits and renumbers no face); where they differ
   from its hull as given, a plan must also land within ``eps`` replayed on
   that hull (:mod:`planning.tumbling.given_hull`).

``plan.bounds`` holds the paper's bounds (keys of
:data:`planning.tumbling.plan.BOUND_KEYS`) plus ``orientation_residual`` (rad)
and ``position_residual`` (m) of the paper's steps 3 and 4 (exact for a
discrete reachable set).  Verdicts: :mod:`planning.tumbling.verdict`.

The error is the paper's metric ``max(|dxy|, |dtheta| wrapped, 1 - delta(face))``
between the replayed final configuration and the goal.
"""
from __future__ import annotations

import dataclasses

import math
import numbers
import warnings
from collections import OrderedDict
from typing import Optional

import jax.numpy as jnp
import numpy as np

from kernels import (PartWarning, merge_distance, wrap_angle_np, DEFAULT_MERGE_TOL,
                     make_polyhedron, float64, make_config, replay)
from planning.tumbling.analysis import TumbleAnalysis, build_analysis
from planning.tumbling.effort import (DEFAULT_EFFORT, DEFAULT_TIME_LIMIT_S, VECTOR_OPS,
                                      BudgetExhausted, Effort)
from planning.tumbling.given_hull import GivenHull
from planning.tumbling.motions import Motion, compose, inverse_motion
from planning.tumbling.paper import paper_plan
from planning.tumbling.plan import Tumble, TumblePlan, config_error
from planning.tumbling.shorten import ShortPlanner, tame_model_usable
from planning.tumbling.verdict import verdict
from planning.tumbling.words import purge

__all__ = ["analyze_polyhedron", "plan_tumble", "TumbleAnalysis", "replay_faces", "clear_cache"]

_CACHE_SIZE = 32
_analyses: "OrderedDict[tuple, TumbleAnalysis]" = OrderedDict()
_parts: "OrderedDict[tuple, object]" = OrderedDict()
REPLAY_BUCKETS = (256, 4096, 65536, 1 << 20)
#: The paper's R_bar^k is offered to the short planner as a core when at most
#: this many tumbles long.
PAPER_CORE_CAP = 20_000


def clear_cache() -> None:
    """Forget cached analyses (and their short-plan tables)."""
    _analyses.clear()
    _parts.clear()


def _part_key(vertices, com):
    v = np.asarray(vertices, dtype=float)
    c = None if com is None else np.asarray(com, dtype=float)
    return (v.shape, v.tobytes(), None if c is None else (c.shape, c.tobytes()))


def _lru_get(store: OrderedDict, key, build):
    if key in store:
        store.move_to_end(key)
        return store[key]
    val = build()
    store[key] = val
    if len(store) > _CACHE_SIZE:
        store.popitem(last=False)
    return val


def _polyhedron(vertices, com, tau_v: float):
    """The part with its faces at the tolerance ``tau_v`` (m; cached)."""
    try:
        key = (_part_key(vertices, com), tau_v)
    except (TypeError, ValueError):
        return make_polyhedron(vertices, com, tau_v=tau_v)  # raises the kernel's message
    return _lru_get(_parts, key, lambda: make_polyhedron(vertices, com, tau_v=tau_v))


def _check_tol(x, name: str, allow_none: bool):
    if x is None:
        if allow_none:
            return None
        raise ValueError(f"{name}: must be a non-negative number, got None")
    if isinstance(x, bool) or not isinstance(x, numbers.Real):
        raise ValueError(f"{name}: must be a non-negative number, got {x!r}")
    xf = float(x)
    if math.isnan(xf) or math.isinf(xf) or xf < 0:
        fix = "use None for exact" if allow_none else "use 0 for exact data"
        raise ValueError(f"{name}: must be a finite number >= 0, got {x!r} ({fix})")
    return xf


def _check_budget(effort, time_limit):
    if effort is not None and (isinstance(effort, bool) or not isinstance(effort, numbers.Integral)
                               or effort <= 0):
        raise ValueError(f"effort: must be a positive number of operations (int) or None for no "
                         f"limit, got {effort!r} (default {DEFAULT_EFFORT})")
    if time_limit is not None and (isinstance(time_limit, bool) or
                                   not isinstance(time_limit, numbers.Real) or
                                   not float(time_limit) > 0 or math.isnan(float(time_limit))):
        raise ValueError(f"time_limit: must be a positive number of seconds or None for no cap, "
                         f"got {time_limit!r} (default {DEFAULT_TIME_LIMIT_S:g})")


@float64
def analyze_polyhedron(vertices, com=None, tau_v: float = 0.0, tau_g: Optional[float] = None,
                       start_face: int = 0) -> TumbleAnalysis:
    """The Marigo-Bicchi analysis of a part, rooted at ``start_face`` (cached).

    Args:
      vertices: (m, 3) body-frame points (metres), any order (hull taken).
      com: optional centre of mass (default: volume centroid).
      tau_v: vertex tolerance (m, >= 0): the precision to which the part is
        known.  > 0 takes the part's faces at that tolerance (nearly
        coplanar triangles within it are one face,
        :func:`kernels.polyhedron.make_polyhedron`), sets the defect-angle
        representation tolerance
        ``Delta_beta = 2 (l - 1) tau_v / d_min`` and decides the reachable
        class at that tolerance (``reachable_class``; the class of the
        coordinates as given is ``reachable_class_exact``).
      tau_g: generator-coefficient tolerance (eq. 3); None (or 0) = exact when
        the coefficients are rational (discrete case), rationals determined by
        tau_v when they are so only within it, else ``DEFAULT_TAU_G``.
      start_face: the paper's ``F_1``.

    Returns a :class:`~planning.tumbling.analysis.TumbleAnalysis`.
    Raises ValueError naming the bad argument (part errors come from
    :func:`kernels.polyhedron.make_polyhedron`).
    """
    tau_v = _check_tol(tau_v, "tau_v", False)
    tau_g = _check_tol(tau_g, "tau_g", True)
    P = _polyhedron(vertices, com, tau_v)
    if isinstance(start_face, bool) or not isinstance(start_face, numbers.Integral):
        raise ValueError(f"start_face: must be a face number (int), got {start_face!r}")
    if not 0 <= int(start_face) < P.n_faces:
        raise ValueError(f"start_face: {start_face} is out of range; the part has faces "
                         f"0..{P.n_faces - 1}")
    key = (_part_key(vertices, com), tau_v, tau_g, int(start_face))
    return _lru_get(_analyses, key, lambda: build_analysis(
        P.vertices, P.com, tau_v=tau_v, tau_g=tau_g, start_face=int(start_face), polyhedron=P))


def _short_planner(A: TumbleAnalysis, at_tolerance: bool, effort: Effort) -> ShortPlanner:
    """The cached short planner (built within ``effort`` if missing); its
    build cost is charged once per call."""
    key = ("short", at_tolerance)
    if key not in A.cache:
        A.cache[key] = ShortPlanner(A, at_tolerance=at_tolerance, effort=effort)
    SP = A.cache[key]
    effort.charge_once(SP, SP.cost, "short-plan tables")
    return SP


def _geom(A: TumbleAnalysis):
    if "geom" not in A.cache:
        A.cache["geom"] = A.polyhedron.geometry(jnp.float64)
    return A.cache["geom"]


@float64
def replay_faces(A: TumbleAnalysis, start, faces) -> tuple[tuple, bool]:
    """Replay landing faces from configuration ``start`` with the JAX kernel
    (float64, padded to a few fixed lengths so that compilations are shared);
    returns ``((x, y, theta, face), ok)``."""
    return _replay(_geom(A), start, faces)


def _replay(geom, start, faces) -> tuple[tuple, bool]:
    n = len(faces)
    size = next((b for b in REPLAY_BUCKETS if b >= n), None)
    if size is None:
        size = 1 << int(math.ceil(math.log2(max(n, 1))))
    seq = np.full(size, -1, dtype=np.int32)
    seq[:n] = np.asarray(faces, dtype=np.int32)
    cfg = make_config(start[0], start[1], start[2], start[3], dtype=jnp.float64)
    final, ok = replay(geom, cfg, jnp.asarray(seq))
    xy = np.asarray(final.xy)
    return (float(xy[0]), float(xy[1]), float(final.theta), int(final.face)), bool(ok)


def _config(x, name: str, n_faces: Optional[int]):
    try:
        t = tuple(x)
    except TypeError:
        raise ValueError(f"{name}: expected (x, y, theta, face), got {x!r}") from None
    if len(t) != 4:
        raise ValueError(f"{name}: expected 4 entries (x, y, theta, face), got {len(t)}; "
                         "give x, y in metres, theta in radians and a face number")
    vals = []
    for v, lab in zip(t[:3], ("x", "y", "theta")):
        if isinstance(v, bool) or not isinstance(v, numbers.Real) or not math.isfinite(float(v)):
            raise ValueError(f"{name}: {lab} = {v!r} is not a finite number; give {lab} in "
                             f"{'radians' if lab == 'theta' else 'metres'}")
        vals.append(float(v))
    f = t[3]
    if isinstance(f, bool) or not (isinstance(f, numbers.Integral) or (
            isinstance(f, numbers.Real) and math.isfinite(float(f)) and float(f).is_integer())):
        raise ValueError(f"{name}: face = {f!r} is not a face number; give an integer face index")
    f = int(f)
    if n_faces is not None and not 0 <= f < n_faces:
        raise ValueError(f"{name}: face {f} is out of range; the part has faces 0..{n_faces - 1} "
                         "(numbered in lexicographic order of their sorted vertex indices)")
    return (vals[0], vals[1], vals[2], f)


def _inputs(vertices, com, goal, start, eps, tau_v, tau_g, effort, time_limit):
    """Validated ``(eps, tau_v, tau_g, start, goal, polyhedron)`` of a plan
    call; ValueError naming the first bad field (cheap checks first)."""
    if isinstance(eps, bool) or not isinstance(eps, numbers.Real) or not (float(eps) > 0) \
            or not math.isfinite(float(eps)):
        raise ValueError(f"eps: must be a finite number > 0 (the accuracy in metres / radians), "
                         f"got {eps!r}")
    tau_v = _check_tol(tau_v, "tau_v", False)
    tau_g = _check_tol(tau_g, "tau_g", True)
    _check_budget(effort, time_limit)
    start = (0.0, 0.0, 0.0, 0) if start is None else start
    goal_c = _config(goal, "goal", None)
    start_c = _config(start, "start", None)
    P = _polyhedron(vertices, com, tau_v)
    return (float(eps), tau_v, tau_g, _config(start_c, "start", P.n_faces),
            _config(goal_c, "goal", P.n_faces), P)


def _pose(c) -> Motion:
    return Motion(float(c[2]), complex(c[0], c[1]))


def _short_candidates(A, M: Motion, G: int, eps: float, paper, effort: Effort):
    """Short plans (words) and the stage where the budget ran out (or None):
    on the class at the part's tolerance, then, for a near-tame part whose
    model gives no plan within eps, on the exact class (only the latter when
    the model's rotation grid is too fine for its tolerance to guide the
    search, :func:`~planning.tumbling.shorten.tame_model_usable`)."""
    F = A.start_face
    words, exhausted = [], None
    pc = None
    if A.rbar_word is not None and paper.k * A.rbar_length <= PAPER_CORE_CAP:
        effort.add(paper.k * A.rbar_length)
        pc = purge(tuple(A.rbar_word) * paper.k + tuple(A.transit_paths[G]), F)
    tries = (True,) if not A.near_tame else (True, False) if tame_model_usable(A) else (False,)
    for at_tol in tries:
        try:
            res = _short_planner(A, at_tol, effort).plan(M, G, eps, paper_core=pc, effort=effort)
        except BudgetExhausted as exc:
            return words, exhausted or exc.stage
        if res is not None:
            exhausted = exhausted or res.exhausted
            if res.word is not None:
                words.append(res.word)
            if res.error <= eps or res.exhausted:
                break
    return words, exhausted


def _given_hull(A, vertices, com):
    """``(GivenHull, float64 geometry of the hull as given)`` when the part's
    faces at its tolerance differ from its hull as given (cached), else None."""
    if "given" not in A.cache:
        A.cache["given"] = None
        if A.tau_v > 0:
            try:
                with warnings.catch_warnings():  # its nearly coplanar faces are merged at tau_v
                    warnings.simplefilter("ignore", PartWarning)
                    P0 = _polyhedron(vertices, com, 0.0)
            except ValueError:  # only the part at its tolerance is a polyhedron
                P0 = None
            if P0 is not None and P0.faces != A.polyhedron.faces:
                dist = merge_distance(P0.vertices, DEFAULT_MERGE_TOL, A.tau_v)
                A.cache["given"] = (GivenHull(A.polyhedron, P0, dist), P0.geometry(jnp.float64))
    return A.cache["given"]


def _given_error(A, given, start_c, goal_c, word, effort: Effort) -> float:
    """The paper's error of ``word`` replayed on the hull as given
    (:mod:`planning.tumbling.given_hull`: rocks over the creases of the faces
    merged at tau_v included); inf when it cannot be replayed there."""
    gh, geom0 = given
    effort.add(3 * len(word) // VECTOR_OPS + len(word) // 8 + 1)
    mapped = gh.word(start_c[3], word)
    if mapped is None:
        return math.inf
    piece, word0 = mapped
    final0, ok = _replay(geom0, gh.to_given(start_c, piece), word0)
    if not ok:
        return math.inf
    return config_error(gh.from_given(final0, gh.owner[final0[3]]), goal_c)


def _replay_candidates(A, start_c, goal_c, eps, cands, paper, effort: Effort,
                       given=None) -> list:
    """``(kind, word, final, err, err_given)`` for every candidate replayed by
    the kernel (the paper's word only when shorter than the best short plan or
    needed): ``err`` on the part as planned, ``err_given`` on its hull as
    given when its faces at tau_v differ (``given``, :func:`_given_hull`) and
    ``err`` is within eps, else None."""
    def check(kind, word):
        effort.add(len(word) // VECTOR_OPS + 1)  # replays are never cut short
        final, ok = replay_faces(A, start_c, word)
        err = config_error(final, goal_c) if ok else math.inf
        e0 = None
        if given is not None and err <= eps and final[3] == goal_c[3]:
            e0 = _given_error(A, given, start_c, goal_c, word, effort)
        return (kind, word, final, err, e0)

    checked = [check(kind, word) for kind, word in cands]
    ok_lens = [len(c[1]) for c in checked if _lands(c, goal_c, eps)]
    shortest_ok = min(ok_lens, default=None)
    if paper.word is not None and (shortest_ok is None or len(paper.word) < shortest_ok):
        checked.append(check("paper", paper.word))
    return checked


def _lands(c, goal_c, eps) -> bool:
    """Whether a checked candidate lands the goal face within eps (on the hull
    as given too, when that was replayed)."""
    return c[3] <= eps and c[2][3] == goal_c[3] and (c[4] is None or c[4] <= eps)


@float64
def plan_tumble(vertices, goal, start=None, com=None, eps: float = 1e-3, tau_v: float = 0.0,
                tau_g: Optional[float] = None, shorten: bool = True,
                effort: Optional[int] = DEFAULT_EFFORT,
                time_limit: Optional[float] = DEFAULT_TIME_LIMIT_S) -> TumblePlan:
    """Plan a sequence of tumbles from ``start`` to ``goal`` (see module doc).

    Args:
      vertices, com: the part (body frame, metres).
      goal: ``(x, y, theta, face)``; start: the same, default ``(0, 0, 0, 0)``.
        Metres and radians, world frame; faces numbered as in
        :func:`kernels.polyhedron.make_polyhedron` at the tolerance ``tau_v``
        (``make_polyhedron(vertices, com, tau_v=tau_v)``).
      eps: required accuracy in the paper's metric (> 0; metres and radians).
      tau_v: vertex tolerance (m, >= 0; see :func:`analyze_polyhedron`);
        tau_g: generator tolerance (>= 0 or None).
      shorten: False returns the paper's own construction (when it is small
        enough to build).
      effort: operation budget (~1 microsecond each, deterministic: the same
        call gives the same plan); None for no limit.
      time_limit: wall-clock cap in seconds (a backstop); None for no cap.

    Returns a :class:`~planning.tumbling.plan.TumblePlan`; its verdict is
    ``solved``, ``not_solvable`` or ``budget_exhausted``
    (:mod:`planning.tumbling.verdict`), and it carries the best plan found.
    Raises ValueError naming the bad field and how to fix it.
    """
    run = _search(vertices, goal, start, com, eps, tau_v, tau_g, shorten, effort, time_limit)
    good = [c for c in run.checked if _lands(c, run.goal, run.eps)]
    if run.checked:
        pick = (min(good, key=lambda c: len(c[1])) if good else
                min(run.checked, key=lambda c: (round(max(c[3], c[4] or 0.0) / run.A.size, 9),
                                                len(c[1]))))
    else:
        pick = None
    return _make_plan(run, vertices, pick)


@dataclasses.dataclass(frozen=True)
class _Search:
    """What :func:`plan_tumble`'s search found: the analysis, the paper's plan,
    every replayed candidate ``(kind, word, final, err, err_given)``."""

    A: object
    P: object
    paper: object
    checked: list
    exhausted: Optional[str]
    budget: object
    start: tuple
    goal: tuple
    eps: float
    tau_v: float
    tau_g: Optional[float]
    shorten: bool


def _search(vertices, goal, start, com, eps, tau_v, tau_g, shorten, effort, time_limit) -> _Search:
    eps, tau_v, tau_g, start_c, goal_c, P = _inputs(vertices, com, goal, start, eps, tau_v, tau_g,
                                                     effort, time_limit)
    A = analyze_polyhedron(vertices, com, tau_v=tau_v, tau_g=tau_g, start_face=start_c[3])
    G = goal_c[3]
    M = compose(inverse_motion(_pose(start_c)), _pose(goal_c))
    budget = Effort(effort, time_limit)

    paper = paper_plan(A, M, G, eps, effort=budget)
    exhausted = "paper's construction" if paper.budget_skipped else None
    words = []
    if shorten:
        words, why = _short_candidates(A, M, G, eps, paper, budget)
        exhausted = exhausted or why
    given = _given_hull(A, vertices, com)
    checked = _replay_candidates(A, start_c, goal_c, eps, [("short", w) for w in words], paper,
                                 budget, given)
    return _Search(A, P, paper, checked, exhausted, budget, start_c, goal_c, eps, tau_v, tau_g,
                   shorten)


def _make_plan(run: _Search, vertices, pick) -> TumblePlan:
    """The :class:`TumblePlan` of a candidate ``pick`` of the search (None: none)."""
    A, P, paper, budget = run.A, run.P, run.paper, run.budget
    start_c, goal_c, eps, tau_v, tau_g = run.start, run.goal, run.eps, run.tau_v, run.tau_g
    G = goal_c[3]
    if pick is not None:
        kind, word, final, err, err_given = pick
    else:
        kind, word, err_given = "none", (), None
        final, _ = replay_faces(A, start_c, ())
        err = config_error(final, goal_c)

    verd, reason = verdict(A, paper, G, eps, err, int(final[3]), kind, len(word), run.shorten,
                           run.exhausted, budget, err_given=err_given)
    bounds = dict(paper.bounds)
    bounds["orientation_residual"] = float(paper.orientation_residual)
    bounds["position_residual"] = float(paper.position_residual)
    if err_given is not None:
        bounds["error_as_given"] = float(err_given)
    tumbles = []
    prev = start_c[3]
    for g in word:
        tumbles.append(Tumble(edge=tuple(int(i) for i in P.shared_edge(prev, g)), face=int(g)))
        prev = g
    return TumblePlan(
        vertices=tuple(tuple(float(c) for c in v) for v in np.asarray(vertices, dtype=float)),
        com=tuple(float(c) for c in P.com),
        start=start_c, goal=goal_c, eps=eps, tau_v=tau_v, tau_g=tau_g,
        tumbles=tuple(tumbles),
        predicted_final=(final[0], final[1], float(wrap_angle_np(final[2])), int(final[3])),
        error=float(err), bounds=bounds, verdict=verd, reason=reason,
        reachable_class=A.reachable_class, n_tumbles_paper=int(paper.n_tumbles),
        reachable_class_exact=A.reachable_class_exact,
        step5_ok=(bool(paper.step5_ok) if tau_v > 0 else None), effort_used=int(budget.used),
    )


@float64
def tumble_alternatives(vertices, goal, start=None, com=None, eps: float = 1e-3,
                        tau_v: float = 0.0, tau_g: Optional[float] = None, *,
                        effort: Optional[int] = DEFAULT_EFFORT,
                        time_limit: Optional[float] = DEFAULT_TIME_LIMIT_S, limit: int = 8,
                        slack: int = 2) -> list[TumblePlan]:
    """Up to ``limit`` solved tumble plans for one problem: :func:`plan_tumble`'s
    (the shortest word that lands), then the other words its search replayed
    that land within ``eps`` and are at most ``slack`` tumbles longer than the
    shortest (shortest first, then by their exact error).  The arguments are
    :func:`plan_tumble`'s; an empty list when no word lands (``plan_tumble``
    says why).  Every plan has been replayed by the exact kinematics."""
    if not (isinstance(limit, (int, np.integer)) and limit >= 1):
        raise ValueError(f"limit: expected an integer >= 1, got {limit!r}")
    if not (isinstance(slack, (int, np.integer)) and slack >= 0):
        raise ValueError(f"slack: expected an integer >= 0, got {slack!r}")
    run = _search(vertices, goal, start, com, eps, tau_v, tau_g, True, effort, time_limit)
    good = [c for c in run.checked if _lands(c, run.goal, run.eps)]
    if not good:
        return []
    first = min(good, key=lambda c: len(c[1]))
    rest = sorted((c for c in good if c is not first and len(c[1]) <= len(first[1]) + slack),
                  key=lambda c: (len(c[1]), c[3]))
    out, seen = [], set()
    for c in [first] + rest:
        w = tuple(int(f) for f in c[1])
        if w in seen:
            continue
        seen.add(w)
        plan = _make_plan(run, vertices, c)
        if plan.verdict == "solved":
            out.append(plan)
        if len(out) >= limit:
            break
    return out
