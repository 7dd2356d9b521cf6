"""Hypothesis strategies (and numpy generators) for random convex polygonal parts.

A part is ``(vertices (m, 2), com (2,))`` in the caller's frame (metres), with
the centre of mass strictly inside.  The class of a part (uni-, biplus-,
nice-stable) is decided here independently of the library
(:func:`oracles.push_numpy.object_class`), so tests can use it as an
expectation.

How each class is hit:

* nice- and biplus-stable: hull of random points with a random centre of mass
  inside, filtered on the class (about 70 % / 30 % of draws are nice / biplus
  with the biases used below; each example makes several attempts before it
  is rejected).
* uni-stable parts are rare among random polygons (~0.1 %), so they are
  *constructed*: a "spiral" polygon around the centre of mass in which every
  edge but one has the foot of the centre of mass beyond one of its ends
  (edge ``a -> b`` is unstable when ``|b| cos(angle(a, b)) >= |a|`` or
  ``|a| cos(angle(a, b)) >= |b|``), so the radius function has a single
  minimum.

Two filters.  :func:`well_conditioned` (the numpy generators, for kernel
tests that compare rates and events): hull sizes 3..6, exterior angles >= 12
degrees, edges >= 5 % of the diameter, centre of mass at least 3 % of the
diameter inside, every foot at least 1e-3 from an edge end.  :func:`valid_part`
(the hypothesis strategies, for the planner's property tests, which must hold
on every valid part): hull sizes 3..12, exterior angles >= 1 degree, edges >= 1 %
of the diameter, the centre of mass at least 1 % of the diameter inside; no
condition on the feet.

The hard cases are drawn on purpose: :func:`near_marginal` moves the centre of
mass so that its foot on one edge lies within 1e-9..1e-5 (relative to the
edge's length) of an end, on either side (the edge stable or unstable by a
hair: near-marginal stability is where real parts fail); uni-stable parts come
from two families (spirals and "houses": a short stable base under a tall
roof); start/goal pairs include orientations exactly pi and pi +- 1e-9 apart
and start angles given unwrapped (several turns away from (-pi, pi]).
"""
from __future__ import annotations

import math

import numpy as np
from hypothesis import assume, strategies as st
from scipy.spatial import ConvexHull

from oracles import push_numpy as oracle

UNI, BIPLUS, NICE = 0, 1, 2
MIN_EXTERIOR = math.radians(12.0)


def _rot(t):
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, -s], [s, c]])


def _part_ok(vertices, com, max_vertices: int, min_edge: float, min_exterior: float,
             min_inside: float, min_foot) -> bool:
    """Hull of 3..``max_vertices`` vertices; every edge at least ``min_edge`` of the
    diameter, every exterior angle at least ``min_exterior`` (rad), the centre of mass
    at least ``min_inside`` of the diameter inside every edge and, unless
    ``min_foot`` is None, its foot on every edge at least ``min_foot`` from an end."""
    pts = np.asarray(vertices, float)
    try:
        body, _, _ = oracle.body_from_part(pts, com)
    except Exception:  # qhull: degenerate
        return False
    n = len(body)
    if not 3 <= n <= max_vertices:
        return False
    diam = max(float(np.linalg.norm(a - b)) for a in body for b in body)
    if diam <= 0:
        return False
    for k in range(n):
        a, b, c = body[k - 1], body[k], body[(k + 1) % n]
        e1, e2 = b - a, c - b
        if np.linalg.norm(e2) < min_edge * diam:
            return False
        if math.atan2(e1[0] * e2[1] - e1[1] * e2[0], float(e1 @ e2)) < min_exterior:
            return False
        # distance of the com (origin) to edge k -> k+1, and foot position
        if (b[0] * c[1] - b[1] * c[0]) / np.linalg.norm(e2) < min_inside * diam:
            return False
        if min_foot is not None:
            f = float(-b @ e2) / float(e2 @ e2)
            if min(abs(f), abs(f - 1.0)) < min_foot:
                return False
    return True


def well_conditioned(vertices, com) -> bool:
    """The part is a sane test subject for rate and event comparisons (module docstring)."""
    return _part_ok(vertices, com, 6, 0.05, MIN_EXTERIOR, 0.03, 1e-3)


def valid_part(vertices, com, max_vertices: int = 12) -> bool:
    """A valid part for the planner's property tests (module docstring)."""
    return _part_ok(vertices, com, max_vertices, 0.01, math.radians(1.0), 0.01, None)


def near_marginal(pts, com, edge: int, at_end: int, delta: float, inside: bool):
    """Move the centre of mass so that its foot on hull edge ``edge`` lies
    ``delta`` (relative to the edge's length) from the edge's start (``at_end``
    0) or end (1), inside the edge (``inside``) or just beyond that end, at the
    same height.  Returns the new centre of mass (caller's frame) or None."""
    body, hidx, c0 = oracle.body_from_part(pts, com)
    n = len(body)
    a, b = body[edge % n] + c0, body[(edge + 1) % n] + c0
    e = b - a
    length = float(np.linalg.norm(e))
    t = delta if at_end == 0 else 1.0 - delta
    if not inside:
        t = -delta if at_end == 0 else 1.0 + delta
    normal_in = np.array([-e[1], e[0]]) / length            # CCW hull: the interior is on the left
    h = float((c0 - a) @ normal_in)
    new = a + t * e + h * normal_in
    return new if valid_part(pts, new) else None


def _try_random_part(draw, max_points, com_spread, size, cls):
    m = draw(st.integers(3, max_points))
    unit = st.floats(-1.0, 1.0, allow_nan=False)
    if draw(st.booleans()):   # a cloud of points: mostly few hull vertices
        pts = np.array([[draw(unit), draw(unit)] for _ in range(m)])
    else:                     # a noisy ellipse: up to max_points hull vertices
        ang = (np.arange(m) + np.array([draw(st.floats(0.0, 0.6)) for _ in range(m)])) * (2 * math.pi / m)
        rad = np.array([draw(st.floats(0.8, 1.0)) for _ in range(m)])
        squash = draw(st.floats(0.3, 1.0))
        pts = np.c_[rad * np.cos(ang), squash * rad * np.sin(ang)]
    scale = draw(st.floats(*size))
    pts = pts * scale
    w = [draw(st.floats(0.05, 1.0)) for _ in range(m)]
    t = draw(st.floats(*com_spread))
    shift = np.array([draw(st.floats(-1.0, 1.0)), draw(st.floats(-1.0, 1.0))])
    try:
        hull = ConvexHull(pts)
    except Exception:
        return None
    hp = pts[hull.vertices]
    w = np.asarray(w[:len(hp)])
    w = w / w.sum()
    centroid = oracle.body_from_part(pts)[2]
    com = centroid + t * (w @ hp - centroid)
    pts, com = pts + shift, com + shift
    if not valid_part(pts, com):
        return None
    if draw(st.integers(0, 2)) == 0:   # a third of the parts: a near-marginal foot
        n = len(oracle.body_from_part(pts, com)[0])
        com = near_marginal(pts, com, draw(st.integers(0, n - 1)), draw(st.integers(0, 1)),
                            10.0 ** draw(st.sampled_from([-9.0, -7.0, -5.0])), draw(st.booleans()))
        if com is None:
            return None
    if cls is not None and oracle.object_class(oracle.body_from_part(pts, com)[0]) != cls:
        return None
    return pts, com


@st.composite
def random_parts(draw, max_points=12, com_spread=(0.0, 0.95), size=(0.01, 0.2), cls=None, attempts=8):
    """Hull of 3..max_points random points, centre of mass a random interior
    point (of class ``cls`` if given), a third of them near-marginal
    (:func:`near_marginal`); several attempts per example, so that the filters
    rarely reject a whole example."""
    for _ in range(attempts):
        part = _try_random_part(draw, max_points, com_spread, size, cls)
        if part is not None:
            return part
    assume(False)


def spiral_uni_stable(n, d_stable, unstable_w, margins, top, r0, rot, shift, scale):
    """Build a uni-stable polygon around the com (see module docstring).

    Vertex k sits at polar angle ``ang[k]`` (com at the origin); edge 0 -> 1
    spans ``d_stable`` (the stable edge), the other edges share the rest in the
    proportions ``unstable_w``.  Radii grow from vertex 1 up to ``top`` and
    from vertex 0 (backwards) up to ``top``, each step by at least
    ``1 / cos(step)`` (times 1 + margin), which puts every such edge's foot
    outside it.
    """
    rest = 2 * math.pi - d_stable
    du = rest * np.asarray(unstable_w, float) / float(np.sum(unstable_w))   # edges 1..n-1
    ang = np.concatenate([[0.0], np.cumsum(np.concatenate([[d_stable], du[:-1]]))])
    r = np.ones(n)
    r[1] = 1.0
    r[0] = r0
    for k in range(2, top + 1):
        r[k] = r[k - 1] / math.cos(du[k - 2]) * (1 + margins[k])
    for k in range(n - 1, top, -1):
        r[k] = r[(k + 1) % n] / math.cos(du[k - 1]) * (1 + margins[k])
    need = max(r[top - 1] / math.cos(du[top - 2]), r[(top + 1) % n] / math.cos(du[top - 1]))
    r[top] = max(r[top], need * (1 + margins[0]))
    body = np.c_[r * np.cos(ang), r * np.sin(ang)]
    body = body / np.max(np.hypot(body[:, 0], body[:, 1])) * scale
    body = body @ _rot(rot).T
    return body + shift, np.asarray(shift, float)


def house_uni_stable(base_half, roof, apex, shoulder_y, tilt, rot, shift, scale):
    """A "house": a short base edge under the centre of mass (the only stable
    edge), two walls that lean out and a roof that rises to an apex far above;
    every other edge has the foot of the centre of mass beyond its lower end.
    Parameters are ratios of the base's half width; returns ``(vertices, com)``."""
    w = base_half
    body = np.array([[-w, -1.0], [w, -1.0], [roof * w + tilt, shoulder_y], [tilt * 0.5, apex],
                     [-roof * w + tilt, shoulder_y]])
    body = body / np.max(np.hypot(body[:, 0], body[:, 1])) * scale
    body = body @ _rot(rot).T
    return body + shift, np.asarray(shift, float)


def _try_house(draw):
    args = (draw(st.floats(0.4, 1.0)), draw(st.floats(1.8, 3.0)), draw(st.floats(4.0, 8.0)),
            draw(st.floats(0.5, 1.5)), draw(st.floats(-0.3, 0.3)), draw(st.floats(-math.pi, math.pi)),
            np.array([draw(st.floats(-1.0, 1.0)), draw(st.floats(-1.0, 1.0))]), draw(st.floats(0.02, 0.2)))
    pts, com = house_uni_stable(*args)
    pts = pts[list(draw(st.permutations(list(range(5)))))]
    if not valid_part(pts, com) or oracle.object_class(oracle.body_from_part(pts, com)[0]) != UNI:
        return None
    return pts, com


def _try_uni(draw):
    if draw(st.booleans()):
        return _try_house(draw)
    n = draw(st.integers(4, 8))
    lo = 130.0 if n == 4 else 100.0
    d_stable = math.radians(draw(st.floats(lo, 160.0)))
    w = [draw(st.floats(1.0, 1.5)) for _ in range(n - 1)]
    margins = [draw(st.floats(0.02, 0.3)) for _ in range(n)]
    top = draw(st.integers(2, n - 1))
    r0 = draw(st.floats(0.5, 1.5))
    rot = draw(st.floats(-math.pi, math.pi))
    shift = np.array([draw(st.floats(-1.0, 1.0)), draw(st.floats(-1.0, 1.0))])
    scale = draw(st.floats(0.02, 0.2))
    perm = draw(st.permutations(list(range(n))))
    du = (2 * math.pi - d_stable) * np.asarray(w) / sum(w)
    if np.max(du) >= math.radians(80.0):
        return None
    pts, com = spiral_uni_stable(n, d_stable, w, margins, top, r0, rot, shift, scale)
    pts = pts[list(perm)]  # handed over in a random order (make_polygon sorts it)
    if not valid_part(pts, com):
        return None
    if oracle.object_class(oracle.body_from_part(pts, com)[0]) != UNI:
        return None
    return pts, com


@st.composite
def uni_stable_parts(draw, attempts=8):
    for _ in range(attempts):
        part = _try_uni(draw)
        if part is not None:
            return part
    assume(False)


def parts_of_class(cls):
    """Strategy of ``(vertices, com)`` whose class (independent oracle) is ``cls``."""
    if cls == UNI:
        return uni_stable_parts()
    return _parts_of_class(cls)


def _parts_of_class(cls):
    if cls == NICE:
        return random_parts(com_spread=(0.0, 0.4), cls=NICE)
    return random_parts(com_spread=(0.4, 0.97), cls=BIPLUS)


def any_class_parts():
    return st.one_of(parts_of_class(UNI), parts_of_class(BIPLUS), parts_of_class(NICE))


ANGLE = st.floats(-math.pi, math.pi, allow_nan=False)


RELATIONS = ("random", "equal", "opposite", "near-opposite", "tiny")


@st.composite
def start_goal(draw, relation=None, reach=0.5):
    """``(start, goal, relation)``: poses (x, y, theta); the orientation relation
    is one of random / equal / opposite (exactly pi apart) / near-opposite (pi
    +- 1e-9, or +- 1e-12..1e-6) / tiny (1e-12..1e-3 rad), drawn unless given.
    A quarter of the start angles are given unwrapped (1 or 2 turns away)."""
    coord = st.floats(-reach, reach, allow_nan=False)
    t0 = draw(ANGLE)
    rel = relation or draw(st.sampled_from(RELATIONS))
    sign = draw(st.sampled_from([-1, 1]))
    if rel == "random":
        tg = draw(ANGLE)
    elif rel == "equal":
        tg = t0
    elif rel == "opposite":
        tg = oracle.wrap(t0 + math.pi)
    elif rel == "near-opposite":
        eps = draw(st.one_of(st.just(1e-9), st.floats(-12.0, -6.0).map(lambda x: 10.0 ** x)))
        tg = oracle.wrap(t0 + math.pi + sign * eps)
    else:
        tg = oracle.wrap(t0 + sign * 10.0 ** draw(st.floats(-12.0, -3.0)))
    if draw(st.integers(0, 3)) == 0:
        t0 = t0 + 2 * math.pi * draw(st.sampled_from([-2, -1, 1, 2]))
    start = np.array([draw(coord), draw(coord), t0])
    if draw(st.booleans()):
        goal = np.array([draw(coord), draw(coord), tg])
    else:  # short moves (incl. none at all)
        goal = np.array([start[0] + draw(st.sampled_from([0.0, 1e-6, 1e-3])),
                         start[1] + draw(st.sampled_from([0.0, -1e-6, 1e-3])), tg])
    return start, goal, rel


# --------------------------------------------------------------------------
# numpy generators (for bulk tests outside hypothesis)
# --------------------------------------------------------------------------
def numpy_random_part(rng, max_points=6, cls=None, tries=10_000):
    """Hull of random points + random interior com, well conditioned (and of
    class ``cls`` if given).  Returns ``(vertices, com)``."""
    for _ in range(tries):
        m = int(rng.integers(3, max_points + 1))
        pts = rng.uniform(-1, 1, (m, 2)) * rng.uniform(0.01, 0.2)
        try:
            hp = pts[ConvexHull(pts).vertices]
        except Exception:
            continue
        w = rng.dirichlet(np.ones(len(hp)))
        centroid = oracle.body_from_part(pts)[2]
        com = centroid + rng.uniform(0.0, 0.95) * (w @ hp - centroid)
        if not well_conditioned(pts, com):
            continue
        if cls is not None and oracle.object_class(oracle.body_from_part(pts, com)[0]) != cls:
            continue
        return pts, com
    raise RuntimeError("no part found")


def numpy_uni_stable_part(rng, n=5):
    """A constructed uni-stable part (numpy rng)."""
    while True:
        d_stable = math.radians(rng.uniform(100.0, 160.0))
        w = rng.uniform(1.0, 1.5, n - 1)
        du = (2 * math.pi - d_stable) * w / w.sum()
        if np.max(du) >= math.radians(80.0):
            continue
        pts, com = spiral_uni_stable(n, d_stable, w, rng.uniform(0.02, 0.3, n), int(rng.integers(2, n)),
                                     rng.uniform(0.5, 1.5), rng.uniform(-math.pi, math.pi),
                                     rng.uniform(-1, 1, 2), rng.uniform(0.02, 0.2))
        if well_conditioned(pts, com) and oracle.object_class(oracle.body_from_part(pts, com)[0]) == UNI:
            return pts, com
