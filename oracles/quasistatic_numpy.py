"""Plain-numpy oracle for the quasi-static fence push (test reference only).

Written from the mechanics, independently of ``kernels.quasistatic``: it works
in the **world frame** on the world vertices and centre of mass, integrates the
pose ``(x, y, theta)`` itself with ``scipy.integrate.solve_ivp`` (DOP853, tight
tolerances) and finds landings with terminal events.

Model (same physics as the kernel, different construction):

* Ellipsoidal limit surface: twist ``V = k (f_x, f_y, m / c^2)`` for the
  applied wrench ``(f, m)``, ``k > 0``.
* Point contact at a vertex ``P`` (``r = P - C``), fence velocity ``d`` per
  metre of travel: the contact velocity is ``k A f`` with
  ``A = I + r_perp r_perp^T / c^2``.  Try sticking (``f = A^{-1} d``, accepted if
  ``|f_t| <= mu f_n``); otherwise try both friction cone edges
  ``d +- mu t`` and keep the one whose contact velocity has a positive normal
  component and a slip opposing the friction force (exactly one does).
* Line contact on edge ``(P1, P2)``: translation needs the normal force
  ``lambda d`` through C; solve ``a1 + a2 = 1``, ``a1 (r1 x d) + a2 (r2 x d) = 0``;
  flush translation iff ``a1, a2 > 0``.  Otherwise try a point contact at each
  end and keep the one whose other end lifts off the fence.
* Events: a neighbour of the pivot vertex reaching the fence line
  ``<p, d> = h0 + s``.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy.integrate import solve_ivp

from oracles.push_numpy import wrap  # the same angle wrap as the push oracle


@dataclasses.dataclass
class SimResult:
    pose: np.ndarray     # (3,) final pose, theta wrapped to (-pi, pi]
    edge: int            # flush, translating edge at the end (hull index), -1 if none
    complete: bool
    rotation: float      # signed total rotation (rad)
    slip: float          # int |slip velocity| ds (m)
    landings: int
    fence: float         # final fence offset along d


def _rot(t):
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, -s], [s, c]])


def _cross(a, b):
    return float(a[0] * b[1] - a[1] * b[0])


def point_contact_twist(r, d, c, mu):
    """World twist per metre of fence travel for a point contact at ``r``
    (relative to the centre of mass).  Returns ``(v (2,), w, slip_velocity)``
    where ``slip_velocity`` is the contact point's velocity along ``t = perp(d)``."""
    r = np.asarray(r, float)
    t = np.array([-d[1], d[0]])
    rp = np.array([-r[1], r[0]])
    A = np.eye(2) + np.outer(rp, rp) / c ** 2
    f = np.linalg.solve(A, d)            # sticking: A f = d  (k = 1)
    fn, ft = float(f @ d), float(f @ t)
    if fn > 0 and abs(ft) <= mu * fn:
        return f, _cross(r, f) / c ** 2, 0.0
    found = []
    for s in (1.0, -1.0):
        f = d + s * mu * t
        vc = A @ f
        vn = float(vc @ d)
        if vn <= 0:
            continue
        k = 1.0 / vn
        slip = k * float(vc @ t)
        if slip * s <= 0:                # friction (s mu t) opposes the slip
            found.append((k * f, k * _cross(r, f) / c ** 2, slip))
    assert len(found) == 1, ("sliding mode not unique", r, d, c, mu, found)
    return found[0]


def simulate_push(body, pose, direction, distance, c, mu, rtol=1e-12, atol=1e-14):
    """Simulate one normal push (see module docstring).

    Args: body (n, 2) CCW vertices about the centre of mass; pose (3,) world;
    direction (2,) world; distance m; c limit surface ratio m; mu fence friction.
    """
    body = np.asarray(body, float)
    n = len(body)
    d = np.asarray(direction, float)
    d = d / math.hypot(*d)
    t = np.array([-d[1], d[0]])
    x, y, th = (float(v) for v in pose)
    th0 = th
    size = float(np.max(np.hypot(*body.T)))

    def world(th, x, y):
        return body @ _rot(th).T + np.array([x, y])

    W = world(th, x, y)
    h0 = float(np.min(W @ d))
    g = W @ d - h0
    touching = [j for j in range(n) if g[j] <= 1e-10 * size]
    flush = None      # edge index (i -> i+1) when in line contact
    pivot = None
    if len(touching) >= 2:
        i, j = touching[0], touching[1]
        flush = j if (i == 0 and j == n - 1) else i
    else:
        pivot = int(np.argmin(g))
    s = 0.0
    slip = 0.0
    landings = 0

    def edge_translates(e, th):
        r1 = _rot(th) @ body[e]
        r2 = _rot(th) @ body[(e + 1) % n]
        b1, b2 = _cross(r1, d), _cross(r2, d)
        if b1 == b2:
            return False
        a1 = -b2 / (b1 - b2)
        a2 = b1 / (b1 - b2)
        return a1 > 0 and a2 > 0

    for _ in range(4 * n + 4):
        if s >= distance:
            break
        if flush is not None:
            if edge_translates(flush, th):
                x, y = np.array([x, y]) + (distance - s) * d
                s = distance
                break
            ends = [flush, (flush + 1) % n]
            ok = []
            for kk, other in ((ends[0], ends[1]), (ends[1], ends[0])):
                r = _rot(th) @ body[kk]
                ro = _rot(th) @ body[other]
                v, w, _ = point_contact_twist(r, d, c, mu)
                vo = v + w * np.array([-ro[1], ro[0]])
                if float(vo @ d) - 1.0 > 0:
                    ok.append(kk)
            assert len(ok) == 1, ("pivot not unique", body, th, ok)
            pivot = ok[0]
            flush = None
        k = pivot
        nbrs = [(k - 1) % n, (k + 1) % n]

        def rhs(sv, yv):
            r = _rot(yv[2]) @ body[k]
            v, w, u = point_contact_twist(r, d, c, mu)
            return [v[0], v[1], w, abs(u)]

        def make_event(j):
            def ev(sv, yv):
                p = _rot(yv[2]) @ body[j] + yv[:2]
                return float(p @ d) - (h0 + sv)
            ev.terminal = True
            ev.direction = -1
            return ev

        r0 = _rot(th) @ body[k]
        if _cross(r0, d) == 0.0:   # divergent equilibrium: translate
            x, y = np.array([x, y]) + (distance - s) * d
            s = distance
            break
        events = [make_event(j) for j in nbrs]
        sol = solve_ivp(rhs, (s, distance), [x, y, th, slip], method="DOP853", rtol=rtol, atol=atol,
                        events=events)
        x, y, th, slip = sol.y[:, -1]
        landed = [j for j, te in zip(nbrs, sol.t_events) if len(te)]
        if sol.status == 1 and landed:
            s = float(sol.t[-1])
            j = landed[0]
            x, y, th, slip = sol.y_events[nbrs.index(j)][0]
            landings += 1
            flush = k if j == (k + 1) % n else j
            pivot = None
        else:
            s = distance
    edge = -1
    if flush is not None and edge_translates(flush, th):
        edge = flush
    return SimResult(pose=np.array([x, y, wrap(th)]), edge=edge, complete=edge >= 0,
                     rotation=th - th0, slip=float(slip), landings=landings, fence=h0 + distance)
