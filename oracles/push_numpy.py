"""Plain-numpy oracle for pushing a convex polygon with a fence (test reference only).

Written from the physics of Akella & Mason (1992) / Peshkin & Sanderson (1988b),
independently of ``kernels.push``: everything happens in the **world frame** on
the part's world vertices and world centre of mass, event by event.

Model (the paper's assumptions): quasi-static, normal push, a fence of unlimited
length moving along the unit direction ``d``; the fence is the support line of
the part in the direction ``d`` (it touches the vertices with the smallest
``<p, d>``); no slip between fence and part.

Events:

* An edge lies flush with the fence.  If the foot of the perpendicular from the
  centre of mass onto that edge lies strictly inside the edge (more than
  ``MARGINAL_FOOT`` of its length from either end), the part translates with
  the fence for the rest of the push.  If it lies within ``MARGINAL_FOOT`` of
  an end (a marginal edge), the centre of mass is straight above that end
  vertex: an unstable equilibrium without torque, the part translates and the
  push ends there, on a vertex.  Otherwise it pivots about the edge's endpoint
  on the centre-of-mass side.
* A single vertex P touches the fence.  Support friction (acting, whatever the
  pressure distribution, so as to drag the centre of mass C back) turns the part
  about P so that C falls back towards the fence: the sense is the sign of
  ``cross(d, C - P)`` (CCW positive).  The contact vertex P advances with the
  fence (no slip).  The rotation stops when the next vertex reaches the fence
  line; that landing angle is found geometrically in the world frame.  The
  angle ``beta`` between ``d`` and ``P -> C`` grows at the slowest rate the
  support friction allows (Peshkin's bound)
  ``d beta / d s = c sin(beta) / (a^2 + c^2)``, ``c = |PC|``, ``a`` the largest
  distance from C to a vertex, i.e. ``tan(beta/2) = tan(beta1/2) exp(c s / (a^2 + c^2))``.
  A push that ends before the landing stops mid-rotation.
* ``beta = 0`` (C straight ahead of P) is the divergent equilibrium: the part
  translates without turning, and the push is not complete.

With ``rate_c`` (m) the rate is the quasi-static sticking rate of an ellipsoidal
limit surface of ratio ``c``, ``c sin(beta) / (rate_c^2 + c^2)`` (``a`` replaced
by ``rate_c``): the model-based push distances of the planner are checked with it.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy.spatial import ConvexHull

#: fraction of an edge's length: a foot this close to an end is marginal (the
#: library's rule, by specification: kernels.polygon.MARGINAL_FOOT)
MARGINAL_FOOT = 1e-12


@dataclasses.dataclass
class Outcome:
    pose: np.ndarray      # (3,) final (x, y, theta), theta wrapped to (-pi, pi]
    edge: int             # hull edge flush and stable at the end, -1 if none
    complete: bool        # ended with a stable edge flush
    rotation: float       # signed rotation during the push (rad, CCW +)
    landings: int         # vertices that reached the fence (edges that landed)
    marginal: int = -1    # marginal edge flush at the end (its unstable equilibrium), -1 if none


def wrap(a: float) -> float:
    """Angle wrapped to (-pi, pi]."""
    a = math.fmod(a, 2 * math.pi)
    if a <= -math.pi:
        a += 2 * math.pi
    elif a > math.pi:
        a -= 2 * math.pi
    return a


def _cross(a, b) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def _rot(t: float) -> np.ndarray:
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, -s], [s, c]])


def body_from_part(vertices, com=None):
    """CCW convex hull of the caller's points, relative to the centre of mass.

    Returns ``(body (n, 2), hull_index (n,), com (2,))``; the default centre of
    mass is the hull's area centroid (shoelace formula).
    """
    pts = np.asarray(vertices, dtype=float)
    idx = list(ConvexHull(pts).vertices)
    hp = pts[idx]
    q = np.roll(hp, -1, axis=0)
    cr = hp[:, 0] * q[:, 1] - q[:, 0] * hp[:, 1]
    if cr.sum() < 0:
        idx = idx[::-1]
        hp = pts[idx]
        q = np.roll(hp, -1, axis=0)
        cr = hp[:, 0] * q[:, 1] - q[:, 0] * hp[:, 1]
    if com is None:
        com = ((hp + q) * cr[:, None]).sum(axis=0) / (3.0 * cr.sum())
    com = np.asarray(com, dtype=float)
    return hp - com, np.array(idx), com


def stable_edges(body) -> list[int]:
    """Edges (k -> k+1 of a CCW body-frame polygon) whose foot of the
    perpendicular from the centre of mass (origin) lies strictly inside, more
    than ``MARGINAL_FOOT`` of the edge from either end."""
    body = np.asarray(body, float)
    n = len(body)
    out = []
    for k in range(n):
        a, b = body[k], body[(k + 1) % n]
        e = b - a
        f = float(-a @ e) / float(e @ e)
        if MARGINAL_FOOT < f < 1.0 - MARGINAL_FOOT:
            out.append(k)
    return out


def object_class(body) -> int:
    """0 uni-stable, 1 biplus-stable, 2 nice-stable (outward normals of the
    stable edges positively span the plane: every angular gap < pi)."""
    body = np.asarray(body, float)
    st = stable_edges(body)
    if len(st) <= 1:
        return 0
    n = len(body)
    angs = []
    for k in st:
        e = body[(k + 1) % n] - body[k]
        angs.append(math.atan2(-e[0], e[1]) % (2 * math.pi))
    angs.sort()
    gaps = [angs[i + 1] - angs[i] for i in range(len(angs) - 1)] + [angs[0] + 2 * math.pi - angs[-1]]
    return 2 if max(gaps) < math.pi else 1


def replay_push(body, pose, direction, distance, rate_c=None) -> Outcome:
    """Replay one normal push of ``distance`` m along ``direction`` (world);
    ``rate_c``: see the module docstring (default: Peshkin's bound)."""
    body = np.asarray(body, float)
    n = len(body)
    d = np.asarray(direction, float)
    d = d / math.hypot(d[0], d[1])
    x, y, theta = (float(v) for v in pose)
    W = body @ _rot(theta).T + np.array([x, y])   # world vertices
    C = np.array([x, y])                           # world centre of mass
    a2 = float(np.max(np.sum(body * body, axis=1))) if rate_c is None else float(rate_c) ** 2
    s = float(distance)
    rotation = 0.0
    landings = 0

    def result(edge, marginal=-1):
        return Outcome(np.array([C[0], C[1], wrap(theta)]), edge, edge >= 0, rotation, landings,
                       marginal)

    proj = W @ d
    pivot = int(np.argmin(proj))    # the vertex the fence touches first
    flush = -1                      # edge lying on the fence (after a landing, or from the start)
    # an edge already flush at the start (its other end on the fence line to rounding) is in
    # line contact from the start: it does not "land"
    tie = 64.0 * np.finfo(float).eps * (float(np.max(np.abs(body))) + float(np.max(np.abs(W))))
    if proj[(pivot + 1) % n] - proj[pivot] <= tie:
        flush = pivot
    elif proj[(pivot - 1) % n] - proj[pivot] <= tie:
        flush = (pivot - 1) % n
    for _ in range(4 * n + 8):
        if flush >= 0:
            P, Q = W[flush], W[(flush + 1) % n]
            e = Q - P
            f = float((C - P) @ e) / float(e @ e)
            if MARGINAL_FOOT < f < 1.0 - MARGINAL_FOOT:   # stable: translate with the fence
                C = C + s * d
                return result(flush)
            if min(abs(f), abs(f - 1.0)) <= MARGINAL_FOOT:  # marginal: balanced on the end vertex
                C = C + s * d
                return result(-1, flush)
            pivot = (flush + 1) % n if f >= 1.0 else flush   # centre-of-mass side
        P = W[pivot].copy()
        rc = C - P
        cr = _cross(d, rc)
        if cr == 0.0:                  # divergent equilibrium: no torque, no turn
            C = C + s * d
            return result(-1)
        sigma = 1.0 if cr > 0 else -1.0
        # landing: smallest rotation (in sense sigma, about P) that brings another
        # vertex onto the fence line through P
        phi, land = math.inf, -1
        for k in range(n):
            if k == pivot:
                continue
            r = W[k] - P
            psi = math.atan2(_cross(d, r), float(d @ r))   # angle of P->V_k from d
            ang = 0.5 * math.pi - sigma * psi
            if ang < phi:
                phi, land = ang, k
        phi = max(phi, 0.0)
        c = math.hypot(rc[0], rc[1])
        K = (a2 + c * c) / c
        beta1 = math.atan2(abs(cr), float(d @ rc))
        beta2 = beta1 + phi
        assert 0.0 < beta1 and beta2 < math.pi, (beta1, beta2)
        s_need = K * (math.log(math.tan(0.5 * beta2)) - math.log(math.tan(0.5 * beta1)))
        if s < s_need * (1 - 1e-13):   # the push ends mid-rotation (exactly s_need completes)
            rot = 2.0 * math.atan(math.tan(0.5 * beta1) * math.exp(s / K)) - beta1
            s_used, stop = s, True
        else:
            rot, s_used, stop = phi, s_need, False
        Rm = _rot(sigma * rot)
        W = P + (W - P) @ Rm.T + s_used * d
        C = P + Rm @ (C - P) + s_used * d
        theta += sigma * rot
        rotation += sigma * rot
        s -= s_used
        if stop:
            return result(-1)
        landings += 1
        if land == (pivot + 1) % n:
            flush = pivot
        elif land == (pivot - 1) % n:
            flush = land
        else:  # cannot happen for a strictly convex polygon
            raise AssertionError(f"vertex {land} landed, not adjacent to pivot {pivot}")
    raise AssertionError("push did not settle")


def replay_pushes(body, pose, directions, distances, rate_c=None) -> tuple[np.ndarray, list[Outcome]]:
    """Replay pushes in order; returns ``(final_pose, outcomes)``."""
    outs = []
    p = np.asarray(pose, float)
    for dvec, dist in zip(directions, distances):
        o = replay_push(body, p, dvec, dist, rate_c)
        outs.append(o)
        p = o.pose
    return p, outs


def peshkin_distance(body, pivot: int, beta1: float, beta2: float, rate_c=None) -> float:
    """Worst-case push distance (m) to turn from ``beta1`` to ``beta2`` about
    body vertex ``pivot`` (closed form of Peshkin's rate bound; with ``rate_c``
    the sticking rate of that limit-surface ratio)."""
    body = np.asarray(body, float)
    a2 = float(np.max(np.sum(body * body, axis=1))) if rate_c is None else float(rate_c) ** 2
    c = float(np.hypot(*body[pivot]))
    return (a2 + c * c) / c * math.log(math.tan(0.5 * beta2) / math.tan(0.5 * beta1))
