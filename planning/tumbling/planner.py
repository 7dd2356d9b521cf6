"""Marigo-Bicchi tumble planner: ``analyze_polyhedron`` and ``plan_tumble``.

``analyze_polyhedron`` computes (and caches, per part, start face, tau_v and
tau_g) the paper's structure of the part: plane development, transit paths,
rotations ``R_j``, GCD of the defect angles, ``R_bar``, the translation
generators ``t_jk``, their lattice (HNF) and the class of the reachable set
(:mod:`planning.tumbling.generators`).

``plan_tumble`` plans one goal:

1. the paper's algorithm (steps 1-5, :mod:`planning.tumbling.paper`): its
   residuals, verdict checks, analytic bounds and tumble count
   (``n_tumbles_paper``, never materialised when huge);
2. with ``shorten=True`` (default) a short plan
   (:mod:`planning.tumbling.shorten`): meet-in-the-middle cores plus short
   translation loops (and, for irrational defect angles, short rotation loops);
3. every candidate plan (the short plan; the paper's own plan when it is
   small enough to build, at most ``PAPER_MATERIALISE_CAP`` tumbles, and
   shorter than the short plan or needed as a fallback) is replayed from
   ``start`` with the JAX kernel :func:`kernels.tumble.replay` in float64;
   the shortest one within ``eps`` is returned, else the most accurate one
   (verdict ``not_solvable``).

``plan.bounds`` holds the paper's bounds (keys of
:data:`planning.tumbling.plan.BOUND_KEYS`) plus ``orientation_residual`` (rad)
and ``position_residual`` (m) of the paper's steps 3 and 4 (exact for a
discrete reachable set).

The error is the paper's metric ``max(|dxy|, |dtheta| wrapped, 1 - delta(face))``
between the replayed final configuration and the goal.  "solved" needs
error <= eps and, when ``tau_v > 0``, the paper's step-5 checks (eqs. 5, 6).
"""
from __future__ import annotations

import math
import numbers
from collections import OrderedDict
from typing import Optional

import jax.numpy as jnp
import numpy as np

from kernels.polyhedron import make_polyhedron
from kernels.precision import float64
from kernels.tumble import make_config, replay
from planning.tumbling.generators import TumbleAnalysis, build_analysis
from planning.tumbling.motions import Motion, compose, inverse_motion
from kernels.planar import wrap_angle_np
from planning.tumbling.paper import paper_plan
from planning.tumbling.plan import Tumble, TumblePlan, config_error
from planning.tumbling.shorten import ShortPlanner
from planning.tumbling.words import purge

__all__ = ["analyze_polyhedron", "plan_tumble", "TumbleAnalysis", "replay_faces", "clear_cache"]

_CACHE_SIZE = 32
_analyses: "OrderedDict[tuple, TumbleAnalysis]" = OrderedDict()
_parts: "OrderedDict[tuple, object]" = OrderedDict()
REPLAY_BUCKETS = (256, 4096, 65536, 1 << 20)


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


def _polyhedron(vertices, com):
    try:
        key = _part_key(vertices, com)
    except (TypeError, ValueError):
        return make_polyhedron(vertices, com)  # raises the kernel's message
    return _lru_get(_parts, key, lambda: make_polyhedron(vertices, com))


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


@float64
def analyze_polyhedron(vertices, com=None, tau_v: float = 0.0, tau_g: Optional[float] = None,
                       start_face: int = 0) -> TumbleAnalysis:
    """The Marigo-Bicchi analysis of a part, rooted at ``start_face`` (cached).

    Args:
      vertices: (m, 3) body-frame points (metres), any order (hull taken).
      com: optional centre of mass (default: volume centroid).
      tau_v: vertex tolerance (m, >= 0); > 0 sets the defect-angle
        representation tolerance ``Delta_beta = 2 (l - 1) tau_v / d_min``.
      tau_g: generator-coefficient tolerance (eq. 3); None (or 0) = exact when
        the coefficients are rational (discrete case), else ``DEFAULT_TAU_G``.
      start_face: the paper's ``F_1``.

    Returns a :class:`~planning.tumbling.generators.TumbleAnalysis`.
    Raises ValueError naming the bad argument (part errors come from
    :func:`kernels.polyhedron.make_polyhedron`).
    """
    tau_v = _check_tol(tau_v, "tau_v", False)
    tau_g = _check_tol(tau_g, "tau_g", True)
    P = _polyhedron(vertices, com)
    if isinstance(start_face, bool) or not isinstance(start_face, numbers.Integral):
        raise ValueError(f"start_face: must be a face number (int), got {start_face!r}")
    if not 0 <= int(start_face) < P.n_faces:
        raise ValueError(f"start_face: {start_face} is out of range; the part has faces "
                         f"0..{P.n_faces - 1}")
    key = (_part_key(vertices, com), tau_v, tau_g, int(start_face))
    return _lru_get(_analyses, key, lambda: build_analysis(
        P.vertices, P.com, tau_v=tau_v, tau_g=tau_g, start_face=int(start_face), polyhedron=P))


def _short_planner(A: TumbleAnalysis) -> ShortPlanner:
    if "short" not in A.cache:
        A.cache["short"] = ShortPlanner(A)
    return A.cache["short"]


def _geom(A: TumbleAnalysis):
    if "geom" not in A.cache:
        A.cache["geom"] = A.polyhedron.geometry(jnp.float64)
    return A.cache["geom"]


@float64
def replay_faces(A: TumbleAnalysis, start, faces) -> tuple[tuple, bool]:
    """Replay landing faces from configuration ``start`` with the JAX kernel
    (float64, padded to a few fixed lengths so that compilations are shared);
    returns ``((x, y, theta, face), ok)``."""
    n = len(faces)
    size = next((b for b in REPLAY_BUCKETS if b >= n), None)
    if size is None:
        size = 1 << int(math.ceil(math.log2(max(n, 1))))
    seq = np.full(size, -1, dtype=np.int32)
    seq[:n] = np.asarray(faces, dtype=np.int32)
    cfg = make_config(start[0], start[1], start[2], start[3], dtype=jnp.float64)
    final, ok = replay(_geom(A), cfg, jnp.asarray(seq))
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
    for i, (v, lab) in enumerate(zip(t[:3], ("x", "y", "theta"))):
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


def _pose(c) -> Motion:
    return Motion(float(c[2]), complex(c[0], c[1]))


@float64
def plan_tumble(vertices, goal, start=None, com=None, eps: float = 1e-3, tau_v: float = 0.0,
                tau_g: Optional[float] = None, shorten: bool = True) -> TumblePlan:
    """Plan a sequence of tumbles from ``start`` to ``goal`` (see module doc).

    Args:
      vertices, com: the part (body frame, metres).
      goal: ``(x, y, theta, face)``; start: the same, default ``(0, 0, 0, 0)``.
      eps: required accuracy in the paper's metric (> 0).
      tau_v: vertex tolerance (m, >= 0); tau_g: generator tolerance (>= 0 or
        None).
      shorten: False returns the paper's own construction (when it is small
        enough to build).

    Returns a :class:`~planning.tumbling.plan.TumblePlan`.
    Raises ValueError naming the bad field and how to fix it.
    """
    if isinstance(eps, bool) or not isinstance(eps, numbers.Real) or not (float(eps) > 0) \
            or not math.isfinite(float(eps)):
        raise ValueError(f"eps: must be a finite number > 0 (the accuracy in metres / radians), "
                         f"got {eps!r}")
    eps = float(eps)
    tau_v = _check_tol(tau_v, "tau_v", False)
    tau_g = _check_tol(tau_g, "tau_g", True)
    start = (0.0, 0.0, 0.0, 0) if start is None else start
    goal_c = _config(goal, "goal", None)
    start_c = _config(start, "start", None)
    P = _polyhedron(vertices, com)
    goal_c = _config(goal_c, "goal", P.n_faces)
    start_c = _config(start_c, "start", P.n_faces)
    A = analyze_polyhedron(vertices, com, tau_v=tau_v, tau_g=tau_g, start_face=start_c[3])
    F, G = start_c[3], goal_c[3]
    M = compose(inverse_motion(_pose(start_c)), _pose(goal_c))

    paper = paper_plan(A, M, G, eps)

    # ---- candidates, verified by the kernel ----
    cands = []
    if shorten:
        SP = _short_planner(A)
        pc = None
        if A.rbar_word is not None and paper.k * A.rbar_length <= 20_000:
            pc = purge(tuple(A.rbar_word) * paper.k + tuple(A.transit_paths[G]), F)
        res = SP.plan(M, G, eps, paper_core=pc)
        if res is not None:
            cands.append(("short", res.word))
    checked = []
    for kind, word in cands:
        final, ok = replay_faces(A, start_c, word)
        err = config_error(final, goal_c) if ok else math.inf
        checked.append((kind, word, final, err))
    shortest_ok = min((len(w) for _, w, _, e in checked if e <= eps), default=None)
    if paper.word is not None and (shortest_ok is None or len(paper.word) < shortest_ok):
        final, ok = replay_faces(A, start_c, paper.word)
        err = config_error(final, goal_c) if ok else math.inf
        checked.append(("paper", paper.word, final, err))
    if checked:
        good = [c for c in checked if c[3] <= eps]
        pick = (min(good, key=lambda c: len(c[1])) if good else
                min(checked, key=lambda c: (round(c[3], 9), len(c[1]))))
        kind, word, final, err = pick
    else:
        kind, word = "none", ()
        final, _ = replay_faces(A, start_c, ())
        err = config_error(final, goal_c)

    # ---- verdict ----
    verdict, reason = _verdict(A, paper, M, G, eps, err, kind, len(word), shorten)
    bounds = dict(paper.bounds)
    bounds["orientation_residual"] = float(paper.orientation_residual)
    bounds["position_residual"] = float(paper.position_residual)
    tumbles = []
    prev = F
    for g in word:
        tumbles.append(Tumble(edge=tuple(int(i) for i in P.shared_edge(prev, g)), face=int(g)))
        prev = g
    return TumblePlan(
        vertices=tuple(tuple(float(c) for c in v) for v in np.asarray(vertices, dtype=float)),
        com=tuple(float(c) for c in P.com),
        start=start_c, goal=goal_c, eps=eps, tau_v=tau_v, tau_g=tau_g,
        tumbles=tuple(tumbles),
        predicted_final=(final[0], final[1], float(wrap_angle_np(final[2])), int(final[3])),
        error=float(err), bounds=bounds, verdict=verdict, reason=reason,
        reachable_class=A.reachable_class, n_tumbles_paper=int(paper.n_tumbles),
    )


def _fmt_count(n: int) -> str:
    return str(n) if n < 10**12 else f"~1e{len(str(n)) - 1}"


def _verdict(A: TumbleAnalysis, paper, M: Motion, G: int, eps: float, err: float, kind: str,
             n: int, shorten: bool) -> tuple[str, str]:
    exact_heading = A.all_rational
    exact_lattice = A.all_rational and A.reachable_class == "discrete"
    if err <= eps and (A.tau_v == 0 or paper.step5_ok):
        src = {"short": "short plan", "paper": "paper's construction"}.get(kind, kind)
        extra = "; step 5 checks passed (tau_v = %g)" % A.tau_v if A.tau_v > 0 else ""
        return "solved", (f"{src}: {n} tumbles (paper's construction: "
                          f"{_fmt_count(paper.n_tumbles)}), error {err:.3g} <= eps {eps:g} "
                          f"({A.reachable_class} reachable set){extra}")
    parts = []
    beta = math.pi / A.q
    if exact_heading and paper.orientation_residual > eps:
        step = float(A.smallest_rotation) * math.pi
        parts.append(f"orientation residual {paper.orientation_residual:.4g} rad > eps: face {G} "
                     f"only reaches headings spaced {step:.4g} rad apart")
        if beta > 2 * eps:
            parts.append(f"beta = pi/{A.q} = {beta:.4g} > 2 eps: orientation grid too coarse")
    elif exact_lattice and paper.position_residual > eps:
        parts.append(f"position residual {paper.position_residual:.4g} m > eps: the nearest "
                     f"reachable position (translation lattice, mesh Delta = "
                     f"{A.mesh_area:.4g} m^2) is too far")
        if 2 * math.sqrt(A.mesh_area / math.pi) >= eps:
            parts.append(f"lattice mesh too coarse: 2 sqrt(Delta/pi) = "
                         f"{2 * math.sqrt(A.mesh_area / math.pi):.4g} >= eps")
    elif err <= eps and A.tau_v > 0 and not paper.step5_ok:
        parts.extend(paper.step5_reasons)
    elif not shorten and paper.word is None:
        parts.append(f"paper's construction needs {_fmt_count(paper.n_tumbles)} tumbles, more "
                     "than this planner builds; use shorten=True")
    else:
        what = "dense reachable set: a longer plan exists; " if A.reachable_class != "discrete" else ""
        parts.append(f"search limit: best plan error {err:.4g} > eps {eps:g} ({what}"
                     "increase eps or the search budgets)")
    if A.tau_v > 0 and not paper.step5_ok and not any(p.startswith("step 5") for p in parts):
        parts.extend(paper.step5_reasons)
    return "not_solvable", "; ".join(parts)
