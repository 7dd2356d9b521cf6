r"""Closed forms of one reorient push under the quasi-static model: the
distance that completes it for every support in a range, and the fence
friction that keeps its contact sticking.

A reorient push turns the part about the pivot vertex P (on the fence) until a
stable edge lies flush.  ``beta`` is the angle between the push direction ``d``
and the line from P to the centre of mass C (``0 < beta <= pi/2``: C is ahead
of the fence), ``rho = |PC|`` (m); the push turns ``beta`` from ``beta1`` up to
``beta2`` (the edge's alignment angle, :func:`kernels.polygon.alignment_angle`).

The quasi-static model (:mod:`kernels.quasistatic`: ellipsoidal limit surface
of ratio ``c = m_max / f_max``, Coulomb friction ``mu_f`` at the fence) gives,
with ``r = P - C``, ``a = <r, d> = -rho cos(beta)`` and ``b = r x d``
(``|b| = rho sin(beta)``), the rotation rate per metre of fence travel

* sticking (``|tau| <= mu_f``, ``tau = -a b / (c^2 + a^2)``):
  ``|w| = rho sin(beta) / (c^2 + rho^2)`` (:func:`sticking_rate`);
* sliding: ``w = g / (c^2 + b g)`` with ``g = b + tau_c a``,
  ``tau_c = clip(tau, -mu_f, mu_f)``.

**Monotonicity (the claims the planner relies on).**

1. The sticking rate falls as ``c`` grows (its denominator grows), so over a
   support range ``c in [c_lo, c_hi]`` the slowest sticking rotation is at
   ``c_hi``.
2. Sliding never turns the part more slowly than sticking.  Take ``b > 0``
   (``b < 0`` is the mirror image).  ``tau a = -a^2 b / (c^2 + a^2) <= 0``, so
   ``g(t) = b + t a`` for ``t`` between 0 and ``tau`` runs from
   ``g_stick = b c^2 / (c^2 + a^2) > 0`` (at ``t = tau``) up to ``b`` (at
   ``t = 0``); sliding clips ``tau`` towards 0, so
   ``g_slide >= g_stick > 0``.  And ``w(g) = g / (c^2 + b g)`` has
   ``dw/dg = c^2 / (c^2 + b g)^2 > 0``: ``w_slide >= w_stick``.
3. Hence for every ``c <= c_hi`` and every ``mu_f >= 0`` the part turns at
   least at ``rho sin(beta) / (c_hi^2 + rho^2)``, and the push distance that
   completes the rotation from ``beta1`` to ``beta2`` is at most
   ``k ln(tan(beta2/2) / tan(beta1/2))`` with ``k = (c_hi^2 + rho^2) / rho``:
   Peshkin's formula (:func:`kernels.polygon.peshkin_length`) with the part's
   radius ``a`` replaced by ``c_hi`` (:func:`model_gain`).  Every support lies in
   the part, so ``c <= a`` and this distance never exceeds Peshkin's.

The rotation always stays about P and the landing depends on the orientation
only, so the same edge lands.  (tests/test_reorient.py checks 1-3 against
:func:`kernels.quasistatic.simulate_push`.)

**Sticking.**  ``|tau| = rho^2 cos(beta) sin(beta) / (c^2 + rho^2 cos^2(beta))``
(:func:`friction_needed`) falls as ``c`` grows, so the worst support of a range
is ``c_lo``.  In ``u = tan(beta)``, ``|tau| = rho^2 u / (c^2 u^2 + c^2 + rho^2)``:
unimodal with its peak ``rho^2 / (2 c sqrt(c^2 + rho^2))`` at
``u* = sqrt(1 + rho^2 / c^2)``.  A push from ``beta1`` to ``beta2`` sticks
throughout iff the maximum of ``|tau|`` over ``[beta1, beta2]`` is at most
``mu_f`` (:func:`max_friction_needed`); the largest reorient angle that sticks
(:func:`sticking_angle_limit`) follows from the larger root of
``mu c^2 u^2 - rho^2 u + mu (c^2 + rho^2) = 0``.

Numpy/float functions (the planner builds its tables on the host); units
metres and radians.
"""
from __future__ import annotations

import math

import numpy as np

from kernels.polygon import peshkin_gain


def model_gain(c_hi: float, rho: float) -> float:
    """``k = (c_hi^2 + rho^2) / rho`` (m): the gain of the quasi-static
    worst-case reorient distance for supports with ``c <= c_hi`` (m) about a
    pivot ``rho`` m from the centre of mass (module docstring, claim 3):
    Peshkin's gain (:func:`kernels.polygon.peshkin_gain`) with ``c_hi`` for the radius."""
    return float(peshkin_gain(c_hi, rho))


def sticking_rate(rho, c, beta):
    """Rotation rate (rad per metre of fence travel) of a sticking pivot:
    ``rho sin(beta) / (c^2 + rho^2)``."""
    return rho * np.sin(beta) / (c * c + rho * rho)


def friction_needed(rho, c, beta):
    """Fence friction coefficient needed to stick at ``beta`` (rad), for a
    pivot ``rho`` m from the centre of mass and limit-surface ratio ``c`` (m):
    ``|tau| = rho^2 cos(beta) sin(beta) / (c^2 + rho^2 cos^2(beta))``."""
    cb, sb = np.cos(beta), np.sin(beta)
    return rho * rho * cb * sb / (c * c + rho * rho * cb * cb)


def _peak_beta(rho: float, c: float) -> float:
    return math.atan(math.sqrt(1.0 + (rho / c) ** 2))


def max_friction_needed(rho: float, c: float, beta1: float, beta2: float) -> float:
    """Largest :func:`friction_needed` over ``beta`` in ``[beta1, beta2]``
    (rad): the fence friction that keeps the whole push sticking."""
    b = min(max(_peak_beta(rho, c), beta1), beta2)
    return float(friction_needed(rho, c, b))


def sticking_angle_limit(rho: float, c_lo: float, beta2: float, mu: float) -> float:
    """Largest reorient angle ``alpha`` (rad) such that a push from
    ``beta2 - alpha`` to ``beta2`` sticks throughout for every limit-surface
    ratio ``c >= c_lo`` (m) and fence friction ``>= mu``.

    0 when the contact slips at the landing itself (then no push onto this
    edge about this pivot sticks); ``beta2`` when it never slips.
    """
    if mu <= 0.0 or friction_needed(rho, c_lo, beta2) > mu:
        return 0.0              # slips at the landing (a frictionless fence always slips)
    if beta2 <= _peak_beta(rho, c_lo):
        return beta2            # |tau| rises up to beta2: below mu all the way
    r2, c2 = rho * rho, c_lo * c_lo
    disc = r2 * r2 - 4.0 * mu * mu * c2 * (c2 + r2)
    if disc <= 0.0:
        return beta2            # even the peak sticks
    # larger root: the falling side of the peak, where beta2 lies
    u_hi = (r2 + math.sqrt(disc)) / (2.0 * mu * c2)
    return max(0.0, beta2 - math.atan(u_hi))
