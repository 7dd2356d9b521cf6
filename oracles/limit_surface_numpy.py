"""cvxpy oracle for the quasi-static motion on a point support (test reference only).

Written from the mechanics, independently of :mod:`kernels.limit_surface`: no
Newton iterations and no kink enumeration, but two second-order cone
programmes solved by cvxpy (the support's dissipation ``sum_i w_i |v_i|`` is a
sum of norms of affine functions of the twist):

1. sticking: minimise the dissipation over the twists that move the contact
   point ``r`` with the fence (``v_r = d``); the fence's force is the
   support's friction ``f = sum_i w_i v_i / |v_i|`` (no support point is at
   rest while the contact point sticks, except on the fence line: not tested);
   the contact sticks iff ``|<f, t>| <= mu <f, d>``;
2. sliding: the force on the cone's edge ``e = d + sigma mu t``; minimise the
   dissipation over ``<v_r, e> = 1``, scale to ``<v_r, d> = 1``.

World or body frame alike (whatever frame ``r``, ``d`` and the points share);
metres.
"""
from __future__ import annotations

import numpy as np


def _perp(a):
    a = np.asarray(a, float)
    return np.stack([-a[..., 1], a[..., 0]], -1)


def _solve(points, weights, constraints_of):
    import cvxpy as cp

    V = cp.Variable(3)
    S = len(points)
    Pp = _perp(points)
    A = [np.column_stack([np.eye(2), Pp[i]]) for i in range(S)]
    ts = cp.Variable(S)
    cones = [cp.SOC(ts[i], A[i] @ V) for i in range(S)]
    prob = cp.Problem(cp.Minimize(np.asarray(weights, float) @ ts), cones + constraints_of(V))
    prob.solve(solver=cp.CLARABEL, tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-12)
    V = np.asarray(V.value, float)
    a = V[:2] + V[2] * Pp
    n = np.linalg.norm(a, axis=1)
    moving = n > 1e-9 * max(float(n.max()), 1e-300)
    f = np.sum((np.asarray(weights, float)[moving] / n[moving])[:, None] * a[moving], axis=0)
    return V, f


def support_twist(r, d, points, weights, mu):
    """Twist per metre of fence travel on the point support ``(points,
    weights)`` pushed at ``r`` along the unit ``d``: ``(v (2,), omega, slip,
    sliding)``, ``slip`` the contact point's velocity along ``t = perp(d)``."""
    r, d = np.asarray(r, float), np.asarray(d, float)
    t = _perp(d)
    pr = _perp(r)

    def stick(V):
        return [V[:2] + V[2] * pr == d]

    V, f = _solve(points, weights, stick)
    fn, ft = float(f @ d), float(f @ t)
    if not np.isfinite(mu) or abs(ft) <= mu * fn:
        return V[:2], float(V[2]), 0.0, False
    e = d + np.sign(ft) * mu * t

    def slide(V):
        return [(V[:2] + V[2] * pr) @ e == 1.0]

    V, _ = _solve(points, weights, slide)
    vr = V[:2] + V[2] * pr
    V = V / float(vr @ d)
    vr = vr / float(vr @ d)
    return V[:2], float(V[2]), float(vr @ t), True
