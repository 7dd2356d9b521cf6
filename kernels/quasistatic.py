r"""Quasi-static simulation of a fence pushing a convex polygon (pusher-slider).

Where :mod:`kernels.push` replays the paper's idealised push (no slip at the
fence, the slowest rotation rate that support friction allows), this kernel
integrates the motion for one *sampled* support friction distribution and one
fence friction coefficient, so that the ways a plan fails on a real part show
up: incomplete reorientation, slip along the fence, and landing on another
edge.  It is pure, unbatched JAX; lift it with ``jax.vmap`` over perturbed parts
(:class:`kernels.polygon.PolygonGeometry` with a common vertex count), limit
surface ratios, fence friction, poses, directions and distances.

Frames and units
----------------
Metres, radians, CCW positive.  A pose ``(x, y, theta)`` maps body to world,
``p = R(theta) p_body + (x, y)``; ``(x, y)`` is the centre of mass C.  The
fence is an infinite line moving along the unit world direction ``d`` (normal
push; ``t = perp(d) = (-d_y, d_x)``).  Fence travel ``s`` (m) is the
integration variable: the model is quasi-static, so the fence speed only scales
time and every rate below is *per metre of fence travel*.  The fence line is
``{p : <p, d> = h(s)}`` with ``h(s) = h0 + s`` and ``h0 = min_j <p_j, d>``: the push
starts with the fence touching the part (approach travel is not part of the
push, as in :func:`kernels.push.replay_push`).

Support friction: ellipsoidal limit surface
-------------------------------------------
(Goyal, Ruina & Papadopoulos 1991; Lee & Cutkosky 1991; Lynch, Maekawa & Tanie 1992.)
The wrench the fence applies, ``F = (f_x, f_y, m)`` about C, balances the
support friction wrench, which lies on the limit surface
``H(F) = |f|^2 / f_max^2 + m^2 / m_max^2 = 1``.  The body twist at C,
``V = (v_x, v_y, w)``, is normal to it (maximum dissipation):

.. math::  V = k\,(f_x,\ f_y,\ m / c^2),\quad k > 0,\quad c = m_{max}/f_{max}\ \text{(m)}.

For a support pressure sampled as weights ``w_i`` at points ``p_i`` (relative
to C) with a uniform coefficient ``mu_s``: ``f_max = mu_s sum w_i`` and
``m_max = mu_s sum w_i |p_i|`` (the moment for a pure rotation about C), so
``c = sum w_i |p_i| / sum w_i`` (:func:`limit_surface_ratio`); ``mu_s`` and the
total weight cancel (so does the magnitude of the fence speed).  ``0 < c <= a``
where ``a`` is the part's largest vertex radius, since every support point lies
in the part.  (For a part resting on a flat support the pressure's centroid is
C; the sampler, :mod:`robustness.support`, centres its weights so; this helper
does not check it.)

Point contact (one vertex P, ``r = P - C``)
-------------------------------------------
A contact force ``f`` gives ``m = r x f``; the contact point moves with

.. math::  v_P = v + w\,r_\perp = k\,A f,\qquad A = I + r_\perp r_\perp^T / c^2,\quad r_\perp = (-r_y, r_x)

(the motion cone of Mason 1986 / Lynch & Mason 1996 is ``A`` applied to the
friction cone).  Write
``a = <r, d>`` (< 0: P is behind C) and ``b = r x d``.  *Sticking* (P moves
with the fence, ``v_P = d``) needs ``f ∝ A^{-1} d``, whose tangential/normal
ratio is

.. math::  \tau = f_t / f_n = -a b / (c^2 + a^2).

If ``|tau| <= mu_f`` the contact sticks; otherwise it slides with the force on
the friction cone edge ``f ∝ d + sign(tau) mu_f t``, the only edge for which the
normal velocity is positive and the slip opposes the friction force.  Both cases
are ``f ∝ d + tau_c t`` with ``tau_c = clip(tau, -mu_f, mu_f)``; scaling ``k`` so
that ``<v_P, d> = 1`` (P stays on the fence) gives, with ``g = b + tau_c a``,

.. math::  w = \frac{g}{c^2 + b g},\qquad
           u = \langle v_P, t\rangle = \frac{c^2 \tau_c + a g}{c^2 + b g}\ (0\ \text{when sticking}),

``w`` the rotation rate (rad/m) and ``u`` the slip rate of P along the fence.
When sticking, ``w = b / (c^2 + |r|^2)``: with ``|r| = rho`` and ``beta`` the
angle between ``d`` and ``P -> C`` this is ``d beta/ds = rho sin(beta) /
(c^2 + rho^2)``, which is at least Peshkin's bound ``rho sin(beta)/(a^2 + rho^2)``
(the replay's rate) for every ``c <= a``.  Friction never reverses the sense of
rotation: ``sign(w) = sign(b)``, so C falls back towards the fence; ``b = 0`` is
the divergent equilibrium (the part translates without turning).

Line contact (an edge flush with the fence, end points r1, r2)
-------------------------------------------------------------
Translating with the fence (``V = (d, 0)``) needs ``F = (lambda d, 0)``.  Forces
at the two end points (each in its friction cone) produce it iff
``lambda d`` through C crosses the edge strictly between them, i.e.
``(r1 x d)(r2 x d) < 0`` (the foot of C on the edge lies inside it: a *stable*
edge); tangential components cancel between the two ends and are free, and
the tangential force needed is zero, so for a normal push a flush edge never
slides along the fence.  Otherwise the part pivots about the end with the
smaller ``|r x d|`` (towards the foot of C) as a point contact; the other end
lifts off (this is the consistent mode, with or without slip).

Integration: events and closed forms
------------------------------------
No time steps.  A push is a short sequence of *phases*, each in one contact
mode, that end at *events*; every phase is integrated in closed form, so the
result is exact up to rounding (and one safeguarded Newton solve, below).

With ``beta`` the angle between ``d`` and ``P -> C`` (``a = -rho cos(beta)``,
``|b| = rho sin(beta)``), a pivot turns the part in the sense ``sign(b)`` and
``beta`` grows from its start value towards ``pi/2`` (C falls back towards the
fence; it stays ahead of it, so ``0 < beta < pi/2``).  The friction ratio is

.. math::  |\tau| = \frac{\sin 2\beta}{\kappa + \cos 2\beta},\qquad \kappa = 1 + 2c^2/\rho^2,

so the contact *slides* exactly in one window ``beta_a < beta < beta_b``
(``sqrt(1 + mu^2) sin(2 beta - alpha) > mu kappa``, ``alpha = atan(mu_f)``):
``beta_{a,b} = (alpha + A) / 2, (alpha + pi - A) / 2``, ``A = asin(mu kappa / sqrt(1 + mu^2))``,
and sticks on both sides of it (no window when ``mu kappa > sqrt(1 + mu^2)``).
Per vertex these are computed once per part.  The travel ``s`` and the signed
slip ``q`` as functions of ``beta`` are

* sticking (``|tau| <= mu``): ``ds/dbeta = (c^2 + rho^2) / (rho sin beta)``,
  ``s = K ln(tan(beta/2) / tan(beta_0/2))`` with ``K = (c^2 + rho^2)/rho``:
  Peshkin's integral with ``c`` in place of ``a`` (:func:`kernels.polygon.peshkin_length`),
  inverted in closed form ``tan(beta/2) = tan(beta_0/2) exp(s / K)``; ``q = 0``.
* sliding: ``h = sin beta - mu cos beta = sqrt(1 + mu^2) sin(beta - alpha) > 0`` and
  ``ds/dbeta = c^2 / (rho h) + rho sin beta``,
  ``dq/dbeta = sign(b) (mu c^2 / (rho h) - rho cos beta)``, so
  ``s = C_1 ln(tan((beta - alpha)/2) / tan((beta_0 - alpha)/2)) + rho (cos beta_0 - cos beta)``
  and ``q = sign(b) (mu C_1 ln(...) - rho (sin beta - sin beta_0))`` with
  ``C_1 = c^2 / (rho sqrt(1 + mu^2))``.  ``s(beta)`` is smooth and increasing;
  the push's last phase, if it ends mid-slide, solves ``s = s_left`` by
  Newton's method in ``ln tan((beta - alpha)/2)``, safeguarded by the bracket
  and started from an upper bound of the root (converged to rounding in the
  iterations used; the tests check pushes ending mid-slide against the oracle
  at 1e-9 of the part's size, c from 0.3 % of it).

In the loop, angles are carried by their half-angle tangents and the
orientation by its (cos, sin) pair, so a phase costs one ``log`` and one
``atan`` and otherwise only algebra (on a CPU a float64 ``tan``, ``sin`` or
``atan2`` costs as much as ~50 multiply-adds): with ``T = tan(beta/2)``,
``cos beta = (1 - T^2)/(1 + T^2)``, a rotation by ``dt`` takes ``T`` to
``(T + t)/(1 - T t)`` with ``t = tan(dt/2)``, and the landing's ``t`` comes
from the cross and dot products of the fence direction and the edge normal.

Events, in order of the rotation at which they happen: the next edge landing
(the rotation left comes from the edge normals), the contact crossing
``beta_a`` or ``beta_b`` (sticking <-> sliding), and the end of the push's
travel.  A phase that reaches its event before the travel runs out is
clamped there exactly (a landing makes the edge flush); the travel left goes
to the next phase.  A stable flush edge (or the divergent equilibrium
``b = 0``) translates with the fence for the rest of the push.  The position
is rebuilt from the contact point, which moves by ``s d + q t``, so P stays
exactly on the fence and the total travel is exact.

A pivot has at most two friction events and one landing; a convex polygon
lands at most ``n`` edges before a stable one, so a push has at most about
``3 n + 2`` phases.  The loop is a ``lax.while_loop`` (under ``vmap`` it runs
to the batch's largest phase count) capped at ``6 n + 8`` phases; a push that
has travel left at the cap is flagged ``truncated`` (never seen; the tests
check it over c/a from 3e-3 to 1 and mu_f from 0 to inf: at most 2 n + 6
phases).  The final pose of a push that ends flush does not depend on the
rates when the fence does not slip: it equals :func:`kernels.push.replay_push`'s
to rounding; with slip it agrees with the independent numpy oracle
(:mod:`oracles.quasistatic_numpy`, adaptive DOP853) to the oracle's own
tolerance (~1e-13 m at rtol 1e-13), where the former fixed-step kernel (RK4,
64 steps a push) was ~1e-6 m off.

Assumptions and limits: quasi-static, normal push, fence longer than the part,
uniform support friction, ellipsoidal limit surface (an approximation of the
exact one for the sampled pressure), ``c > 0``, ``mu_f >= 0``.
"""
from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

from kernels.planar import cross2, wrap_angle
from kernels.polygon import PolygonGeometry
from kernels.push import contact_vertex


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class SimOutcome:
    """Result of simulating one push (a JAX pytree).

    Attributes:
      pose: (3,) final pose ``(x, y, theta)``, world frame (m, rad wrapped to (-pi, pi]).
      edge: () int, hull edge lying flush and stable (line contact that
        translates) on the fence at the end; -1 if the push ended on a vertex
        (incomplete rotation, divergent equilibrium) or on an unstable edge.
      complete: () bool, ``edge >= 0``.
      rotation: () signed total rotation of the part (rad, CCW +).
      slip: () slip distance along the fence, ``int |u| ds`` (m).
      slipped: () bool, ``slip > 0``.
      landed_other_edge: () bool, ``expected_edge >= 0`` and the push ended
        flush on a stable edge other than ``expected_edge``.
      landings: () int, number of edges that landed flush during the push.
      fence: () offset of the fence line at the end, ``{p : <p, d> = fence}``
        (m, world; ``d`` normalised): the part touches it and lies ahead of it.
      phases: () int, contact phases the push took (loop iterations; diagnostics).
      truncated: () bool, the push still had travel left at the phase cap
        (:func:`phase_cap`): its outcome is not to be trusted.
    """

    pose: jax.Array
    edge: jax.Array
    complete: jax.Array
    rotation: jax.Array
    slip: jax.Array
    slipped: jax.Array
    landed_other_edge: jax.Array
    landings: jax.Array
    fence: jax.Array
    phases: jax.Array = None
    truncated: jax.Array = None


def limit_surface_ratio(points, weights):
    """Ratio ``c = m_max / f_max`` (m) of the ellipsoidal limit surface.

    For a support pressure concentrated at points ``p_i`` with weights
    ``w_i >= 0`` and a uniform friction coefficient, ``f_max = mu sum w_i`` (pure
    translation) and ``m_max = mu sum w_i |p_i|`` (pure rotation about the centre
    of mass), so ``c = sum w_i |p_i| / sum w_i``; neither the coefficient nor the
    total weight matters.

    Args:
      points: (m, 2) support points relative to the centre of mass, body frame, m.
      weights: (m,) non-negative weights (any scale, not all zero).

    Returns:
      () ``c`` in metres, in the dtype of ``points``.  Pure; vmap-able.
    """
    points = jnp.asarray(points)
    w = jnp.asarray(weights, points.dtype)
    return jnp.sum(w * jnp.linalg.norm(points, axis=-1)) / jnp.sum(w)


def contact_rates(a, b, c2, mu):
    """Rates of a pivoting point contact per metre of fence travel.

    Args:
      a: ``<r, d>`` (m), ``r`` contact point minus centre of mass, ``d`` the unit push direction.
      b: ``r x d`` (m).
      c2: ``c^2`` (m^2), squared limit surface ratio (> 0).
      mu: fence friction coefficient (>= 0).

    Returns:
      ``(w, u, sliding)``: rotation rate (rad/m, CCW +), slip rate of the contact
      point along ``t = perp(d)`` (m/m; 0 when sticking), and whether it slides.
      Equations in the module docstring.
    """
    tau = -a * b / (c2 + a * a)
    tc = jnp.clip(tau, -mu, mu)
    g = b + tc * a
    den = c2 + b * g
    w = g / den
    sliding = jnp.abs(tau) > mu
    u = jnp.where(sliding, (c2 * tc + a * g) / den, 0.0)
    return w, u, sliding


def _flush_tolerance(dtype):
    return jnp.asarray(jnp.finfo(dtype).eps, dtype) ** 0.75


def phase_cap(n: int) -> int:
    """Most contact phases one push may take on an ``n``-gon (static loop bound)."""
    return 6 * int(n) + 8


# Angles in the loop are carried by their half-angle tangents and rotations
# by (cos, sin) pairs: on a CPU a float64 tan, sin or atan2 costs as much as
# ~50 multiply-adds (log ~40, exp ~2), so the loop body uses one log and one
# atan per phase and otherwise only algebra.  With T = tan(beta / 2):
# cos beta = (1 - T^2) / (1 + T^2), sin beta = 2 T / (1 + T^2); a rotation
# by dt with t = tan(dt / 2) takes T to (T + t) / (1 - T t).
@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class _Part:
    """Per-part constants of the event integration (one sample: a part, ``c``, ``mu_f``)."""

    geom: PolygonGeometry
    rho: jax.Array      # (n,) vertex radii |r_k|, m
    ta: jax.Array       # (n,) tan(beta_a / 2): start of the sliding window of a pivot on k (inf: none)
    tb: jax.Array       # (n,) tan(beta_b / 2): its end
    normals: jax.Array  # (n, 2) outward unit normals of the edges, body frame
    c2: jax.Array       # c^2, m^2
    mu: jax.Array       # mu_f with inf replaced by 0 (the window then is empty)
    ah: jax.Array       # tan(alpha / 2), alpha = atan(mu)
    sq: jax.Array       # sqrt(1 + mu^2)


def _part(geom: PolygonGeometry, c, mu_f) -> _Part:
    """Sliding windows ``(beta_a, beta_b)`` of every vertex (module docstring)."""
    dtype = geom.body.dtype
    c = jnp.asarray(c, dtype)
    mu = jnp.asarray(mu_f, dtype)
    c2 = c * c
    rho2 = jnp.sum(geom.body * geom.body, axis=1)
    finite = jnp.isfinite(mu)
    m = jnp.where(finite, mu, 0.0)
    sq = jnp.sqrt(1.0 + m * m)
    alpha = jnp.arctan(m)
    mhat = m * (1.0 + 2.0 * c2 / rho2) / sq
    valid = finite & (mhat <= 1.0)
    A = jnp.arcsin(jnp.minimum(mhat, 1.0))
    inf = jnp.asarray(jnp.inf, dtype)
    ta = jnp.where(valid, jnp.tan(0.25 * (alpha + A)), inf)
    tb = jnp.where(valid, jnp.tan(0.25 * (alpha + jnp.pi - A)), inf)
    e = jnp.roll(geom.body, -1, axis=0) - geom.body
    normals = jnp.stack([e[:, 1], -e[:, 0]], axis=1) / jnp.linalg.norm(e, axis=1, keepdims=True)
    return _Part(geom=geom, rho=jnp.sqrt(rho2), ta=ta, tb=tb, normals=normals, c2=c2, mu=m,
                 ah=m / (1.0 + sq), sq=sq)


def _half_to(t0, t):
    """tan((x0 + x) / 2) from tan(x0 / 2) and tan(x / 2)."""
    return (t0 + t) / (1.0 - t0 * t)


def _half_between(t0, t1):
    """tan((x1 - x0) / 2) from tan(x0 / 2) and tan(x1 / 2)."""
    return (t1 - t0) / (1.0 + t1 * t0)


def _cos_diff(t0, t1):
    """cos(x0) - cos(x1) from the half-angle tangents (no cancellation)."""
    return 2.0 * (t1 - t0) * (t1 + t0) / ((1.0 + t0 * t0) * (1.0 + t1 * t1))


def _sin_diff(t0, t1):
    """sin(x1) - sin(x0) from the half-angle tangents (no cancellation)."""
    return 2.0 * (t1 - t0) * (1.0 - t1 * t0) / ((1.0 + t0 * t0) * (1.0 + t1 * t1))


def _slide_arg(pp: _Part, t):
    """tan((beta - alpha) / 2) from tan(beta / 2)."""
    return (t - pp.ah) / (1.0 + t * pp.ah)


def pivot_contact(body, normals, rho, d, st):
    """The contact of a phase (shared with :mod:`kernels.quasistatic_points`):
    from the state's orientation ``(st["c"], st["s"])`` (cos, sin), its flush
    edge ``st["flush"]`` (-1: none) and pivot vertex ``st["kv"]``, with the
    world push direction ``d``.

    Returns ``(translate, k, r, sigma, target, t_land, t0)``: whether the part
    translates (a stable flush edge, or the divergent equilibrium ``r x d =
    0``), the pivot vertex ``k`` and its body-frame ``r``, the rotation sense
    ``sigma = sign(r x d)``, the edge that lands next (``target``) and
    ``tan(dt/2)`` of the rotation ``dt`` to its landing, and ``tan(beta0/2)``
    (``beta0`` the angle between ``d`` and ``P -> C``).
    """
    n = body.shape[0]
    dtype = body.dtype
    c, s, flush, kv = st["c"], st["s"], st["flush"], st["kv"]
    d_b = jnp.stack([c * d[0] + s * d[1], -s * d[0] + c * d[1]])   # push direction, body frame
    is_flush = flush >= 0
    fl = jnp.maximum(flush, 0)
    fl1 = jnp.where(fl == n - 1, 0, fl + 1)
    x1 = cross2(body[fl], d_b)
    x2 = cross2(body[fl1], d_b)
    hold = is_flush & (x1 * x2 < 0.0)     # line contact that translates (stable edge)
    k = jnp.where(is_flush, jnp.where(jnp.abs(x1) <= jnp.abs(x2), fl, fl1), kv)
    r = body[k]
    a0 = jnp.dot(r, d_b)
    b0 = cross2(r, d_b)
    sigma = jnp.sign(b0)
    translate = hold | (sigma == 0)
    # rotation to the next edge landing: its normal turns onto the fence side -d_b (the
    # body-frame fence side turns by -dtheta); an edge already past by rounding lands now
    target = jnp.where(sigma < 0, k, jnp.where(k == 0, n - 1, k - 1))
    nt = normals[target]
    tiny = jnp.finfo(dtype).tiny
    t_land = jnp.maximum(sigma * cross2(d_b, nt) / jnp.maximum(1.0 - jnp.dot(d_b, nt), tiny), 0.0)
    t0 = jnp.abs(b0) / (rho[k] - a0)                 # tan(beta0 / 2); a0 <= 0: no cancellation
    return translate, k, r, sigma, target, t_land, t0


def _setup(pp: _Part, d, st):
    """Contact mode at the start of a phase and the travel to its event.

    Returns a dict: ``translate`` (stable flush edge or divergent vertex), the
    pivot ``k`` and its ``r``, rotation sense ``sigma``, ``t0 = tan(beta0/2)``,
    ``t = tan(dt/2)`` of the rotation ``dt`` to the event, whether it is a
    landing (``land``) on ``target``, ``sliding``, the travel ``s_t`` and
    signed slip ``q_t`` to the event, and the sliding bracket ``(lo, hi)``
    (half-angle tangents clamped into the window).
    """
    dtype = pp.geom.body.dtype
    translate, k, r, sigma, target, t_land, t0 = pivot_contact(pp.geom.body, pp.normals, pp.rho,
                                                               d, st)
    rho = pp.rho[k]
    # rotation to the ends of the sliding window ahead; an end reached by rounding is behind
    ta, tb = pp.ta[k], pp.tb[k]
    tol = _flush_tolerance(dtype) * 0.5 * (1.0 + t0 * t0)
    inf = jnp.asarray(jnp.inf, dtype)

    def ahead(tw):
        return jnp.where(jnp.isfinite(tw) & (tw - t0 > tol), _half_between(t0, tw), inf)

    t_sw = jnp.minimum(ahead(ta), ahead(tb))
    land = t_land <= t_sw
    t = jnp.minimum(t_land, t_sw)
    t1 = _half_to(t0, t)
    tm = _half_to(t0, t / (1.0 + jnp.sqrt(1.0 + t * t)))    # the phase's middle
    sliding = (ta < tm) & (tm < tb)
    # travel and slip: one log of the sticking or the sliding argument
    lo = jnp.where(sliding, jnp.maximum(t0, ta), t0)
    hi = jnp.where(sliding, jnp.maximum(jnp.minimum(t1, tb), lo), t1)
    c1 = pp.c2 / (rho * pp.sq)
    kc = (pp.c2 + rho * rho) / rho
    lg = jnp.log(jnp.where(sliding, _slide_arg(pp, hi) / _slide_arg(pp, lo), t1 / t0))
    s_t = jnp.where(sliding, c1 * lg + rho * _cos_diff(lo, hi), kc * lg)
    q_t = jnp.where(sliding, sigma * (pp.mu * c1 * lg - rho * _sin_diff(lo, hi)), 0.0)
    return dict(translate=translate, k=k, r=r, sigma=sigma, t0=t0, t=t, land=land, target=target,
                sliding=sliding, rho=rho, kc=kc, c1=c1, lo=lo, hi=hi, s_t=s_t, q_t=q_t)


def _rotate(st, su, d, tv, s_used, t, q):
    """Turn the part by ``sigma dt`` (``t = tan(dt/2)``) about its contact point,
    which moves by ``s_used d + q tv`` (world); returns the new
    ``(pos, theta, cos theta, sin theta)`` and the rotation."""
    c, s, r, sigma = st["c"], st["s"], su["r"], su["sigma"]
    den = 1.0 + t * t
    cd, sd = (1.0 - t * t) / den, sigma * 2.0 * t / den
    cn, sn = c * cd - s * sd, s * cd + c * sd
    norm = jnp.sqrt(cn * cn + sn * sn)          # keep the pair on the unit circle
    cn, sn = cn / norm, sn / norm
    rw0 = jnp.stack([c * r[0] - s * r[1], s * r[0] + c * r[1]])
    rw1 = jnp.stack([cn * r[0] - sn * r[1], sn * r[0] + cn * r[1]])
    dtheta = sigma * 2.0 * jnp.arctan(t)
    return st["pos"] + rw0 + s_used * d + q * tv - rw1, st["theta"] + dtheta, cn, sn, dtheta


def _event(pp: _Part, d, tv, st):
    """One loop phase: translate to the end, or turn to the next event if the
    travel left reaches it; a phase whose travel runs out first is left for
    :func:`_finish` (``final``)."""
    su = _setup(pp, d, st)
    tr = su["translate"]
    s_left = st["s_left"]
    event = (~tr) & (su["s_t"] <= s_left)
    pos_e, th_e, c_e, s_e, dth = _rotate(st, su, d, tv, su["s_t"], su["t"], su["q_t"])
    land = event & su["land"]
    new = dict(st)
    new["pos"] = jnp.where(tr, st["pos"] + s_left * d, jnp.where(event, pos_e, st["pos"]))
    new["theta"] = jnp.where(event, th_e, st["theta"])
    new["c"] = jnp.where(event, c_e, st["c"])
    new["s"] = jnp.where(event, s_e, st["s"])
    new["flush"] = jnp.where(event, jnp.where(land, su["target"], -1), st["flush"])
    new["kv"] = jnp.where(event, su["k"], st["kv"])
    new["s_left"] = jnp.where(tr, 0.0, jnp.where(event, s_left - su["s_t"], s_left))
    new["rot"] = st["rot"] + jnp.where(event, dth, 0.0)
    new["slip"] = st["slip"] + jnp.where(event, jnp.abs(su["q_t"]), 0.0)
    new["landings"] = st["landings"] + land.astype(jnp.int32)
    new["final"] = (~tr) & (~event)
    new["phases"] = st["phases"] + 1
    return new


NEWTON_ITERS = 8   # Newton steps on s = s_left in a final sliding phase


def _invert_slide(pp: _Part, su, s_left):
    """Half-angle tangent of ``beta`` with sliding travel ``s(beta) = s_left``
    from the bracket's start ``lo`` (its end ``hi`` is the event).

    Newton's method in ``v = ln(X / X_lo)``, ``X = tan((beta - alpha)/2)``,
    where ``s(v) = C_1 v + rho (cos beta_lo - cos beta)`` and
    ``ds/dv = C_1 + rho sin(beta) sin(beta - alpha)`` take only algebra and one
    exp; safeguarded by the bracket (a step that leaves it bisects) and
    started from an upper bound of the root (each of the two terms of ``s``
    is increasing and non-negative, so the root lies below where either term
    alone reaches ``s_left``).  Converged to rounding in the iterations used
    (checked against a root finder in the tests)."""
    lo, hi, rho, c1 = su["lo"], su["hi"], su["rho"], su["c1"]
    x_lo = _slide_arg(pp, lo)
    v_hi = jnp.log(_slide_arg(pp, hi) / x_lo)
    # the cosine term alone: cos(beta) = cos(beta_lo) - s_left / rho
    cl = (1.0 - lo * lo) / (1.0 + lo * lo) - s_left / rho
    reach = cl > -1.0                                # else the cosine term never gets there
    t_cos = jnp.sqrt(jnp.maximum(1.0 - cl, 0.0) / jnp.where(reach, 1.0 + cl, 1.0))
    v_cos = jnp.where(reach, jnp.log(jnp.maximum(_slide_arg(pp, t_cos), x_lo) / x_lo), v_hi)
    v0 = jnp.minimum(jnp.minimum(s_left / c1, v_cos), v_hi)

    def it(_, x):
        v, a, b = x
        X = x_lo * jnp.exp(v)
        T = (X + pp.ah) / (1.0 - X * pp.ah)                       # tan(beta / 2)
        fx = c1 * v + rho * _cos_diff(lo, T) - s_left
        dfx = c1 + rho * (2.0 * T / (1.0 + T * T)) * (2.0 * X / (1.0 + X * X))
        a = jnp.where(fx < 0.0, v, a)
        b = jnp.where(fx < 0.0, b, v)
        vn = v - fx / dfx
        return jnp.where((vn >= a) & (vn <= b), vn, 0.5 * (a + b)), a, b

    zero = jnp.zeros_like(v_hi)
    v, _, _ = jax.lax.fori_loop(0, NEWTON_ITERS, it, (v0, zero, v_hi))
    X = x_lo * jnp.exp(v)
    return (X + pp.ah) / (1.0 - X * pp.ah), v


def _finish(pp: _Part, d, tv, st):
    """The last phase of a push whose travel ran out before its event: the
    rotation for the travel left (closed form when sticking, Newton when sliding)."""
    su = _setup(pp, d, st)
    fin = st["final"]
    s_left = st["s_left"]
    t0 = su["t0"]
    # sticking: tan(beta/2) = tan(beta0/2) exp(s / K)
    T_stick = t0 * jnp.exp(s_left / su["kc"])
    T_slide, v = _invert_slide(pp, su, s_left)
    T = jnp.where(su["sliding"], T_slide, T_stick)
    t = jnp.clip(_half_between(t0, T), 0.0, su["t"])
    q = jnp.where(su["sliding"],
                  su["sigma"] * (pp.mu * su["c1"] * v - su["rho"] * _sin_diff(su["lo"], T_slide)),
                  0.0)
    pos, theta, cn, sn, dth = _rotate(st, su, d, tv, s_left, t, q)
    new = dict(st)
    new["pos"] = jnp.where(fin, pos, st["pos"])
    new["theta"] = jnp.where(fin, theta, st["theta"])
    new["c"] = jnp.where(fin, cn, st["c"])
    new["s"] = jnp.where(fin, sn, st["s"])
    new["flush"] = jnp.where(fin, -1, st["flush"])
    new["kv"] = jnp.where(fin, su["k"], st["kv"])
    new["s_left"] = jnp.where(fin, 0.0, s_left)
    new["rot"] = st["rot"] + jnp.where(fin, dth, 0.0)
    new["slip"] = st["slip"] + jnp.where(fin, jnp.abs(q), 0.0)
    new["phases"] = st["phases"] + fin.astype(jnp.int32)
    return new


def push_start(g: PolygonGeometry, pose, direction, distance):
    """The start of a push (shared with :mod:`kernels.quasistatic_points`): the
    pose, the unit push direction ``d`` and ``tv = perp(d)`` (world), the
    distance, the fence's start offset ``h0`` and the loop state (position,
    orientation and its (cos, sin), the flush edge within ``eps**0.75`` rad or
    -1, the support vertex, travel left, rotation, slip, landings, phases), all
    in the dtype of ``g.body``."""
    dtype = g.body.dtype
    pose = jnp.asarray(pose, dtype)
    d = jnp.asarray(direction, dtype)
    d = d / jnp.linalg.norm(d)
    tv = jnp.stack([-d[1], d[0]])
    distance = jnp.asarray(distance, dtype)
    ang_u = jnp.arctan2(-d[1], -d[0])
    theta0 = pose[2]
    c0, s0 = jnp.cos(theta0), jnp.sin(theta0)
    # initial contact: flush edge (within tol) or the support vertex
    R0 = jnp.stack([jnp.stack([c0, -s0]), jnp.stack([s0, c0])])
    h0 = jnp.min((g.body @ R0.T + pose[:2]) @ d)
    phi0 = ang_u - theta0
    off = jnp.abs(wrap_angle(phi0 - g.nu))
    e0 = jnp.argmin(off)
    flush0 = jnp.where(off[e0] <= _flush_tolerance(dtype), e0, -1).astype(jnp.int32)
    kv0 = contact_vertex(g, wrap_angle(phi0)).astype(jnp.int32)
    zero = jnp.zeros((), dtype)
    st = dict(pos=pose[:2], theta=theta0, c=c0, s=s0, flush=flush0, kv=kv0,
              s_left=jnp.maximum(distance, zero), rot=zero, slip=zero,
              landings=jnp.zeros((), jnp.int32), phases=jnp.zeros((), jnp.int32))
    return pose, d, tv, distance, h0, st


def _push(pp: _Part, pose, direction, distance, expected_edge) -> SimOutcome:
    """One push on a prepared part (see :func:`simulate_push`)."""
    g = pp.geom
    n = g.body.shape[0]
    pose, d, tv, distance, h0, st = push_start(g, pose, direction, distance)
    st["final"] = jnp.asarray(False)
    cap = phase_cap(n)
    st = jax.lax.while_loop(
        lambda v: (v["s_left"] > 0) & (~v["final"]) & (v["phases"] < cap),
        lambda v: _event(pp, d, tv, v), st)
    truncated = (st["s_left"] > 0) & (~st["final"])
    st = _finish(pp, d, tv, st)
    return push_outcome(g.body, pose, d, distance, h0, st, expected_edge, truncated)


def push_outcome(body, pose, d, distance, h0, st, expected_edge, truncated) -> SimOutcome:
    """A push's :class:`SimOutcome` from its loop's final state ``st`` (both
    push kernels: this one and :mod:`kernels.quasistatic_points`): the edge flush
    at the end if it translates (the fence direction strictly between its
    vertices' directions from the centre of mass), the final pose (world; the
    start pose where the fence never moved), rotation, slip, landings, the
    fence's final line ``h0 + distance`` (m, along ``d``)."""
    n = body.shape[0]
    c, s, flush = st["c"], st["s"], st["flush"]
    d_b = jnp.stack([c * d[0] + s * d[1], -s * d[0] + c * d[1]])
    fl = jnp.maximum(flush, 0)
    hold = (flush >= 0) & (cross2(body[fl], d_b) * cross2(body[(fl + 1) % n], d_b) < 0.0)
    edge = jnp.where(hold, flush, -1).astype(jnp.int32)
    moved = distance > 0
    out_pose = jnp.where(moved, jnp.concatenate([st["pos"], wrap_angle(st["theta"])[None]]), pose)
    expected_edge = jnp.asarray(expected_edge, jnp.int32)
    slip = st["slip"]
    return SimOutcome(pose=out_pose, edge=edge, complete=edge >= 0,
                      rotation=jnp.where(moved, st["rot"], 0.0), slip=slip, slipped=slip > 0,
                      landed_other_edge=(expected_edge >= 0) & (edge >= 0) & (edge != expected_edge),
                      landings=jnp.where(moved, st["landings"], 0), fence=h0 + distance,
                      phases=st["phases"], truncated=truncated)


def simulate_push(geom: PolygonGeometry, pose, direction, distance, c, mu_f, expected_edge=-1) -> SimOutcome:
    """Simulate one normal fence push quasi-statically (model in the module docstring).

    Args:
      geom: the part, body frame (possibly a perturbed one); its ``body`` dtype
        (float32 or float64) is the computation dtype.
      pose: (3,) start pose ``(x, y, theta)``, world frame (m, rad).
      direction: (2,) direction of the fence's motion, world frame (normalised here).
      distance: fence travel in contact with the part, m (>= 0); the fence
        starts touching the part.
      c: limit surface ratio ``m_max / f_max`` (m, > 0); see :func:`limit_surface_ratio`.
      mu_f: fence-part friction coefficient (>= 0; ``inf`` allowed: never slips).
      expected_edge: hull edge the push should end flush on (for
        ``landed_other_edge``), -1 to skip.

    Returns:
      :class:`SimOutcome`.  Pure, jit- and vmap-able over every array argument.
      A start pose within ``eps**0.75`` rad of an edge lying flush starts in line
      contact on that edge.
    """
    return _push(_part(geom, c, mu_f), pose, direction, distance, expected_edge)


def simulate_pushes(geom: PolygonGeometry, pose, directions, distances, c, mu_f, expected_edges=None,
                    active=None):
    """Simulate a push plan (a sequence of pushes) with ``lax.scan``.

    Args:
      geom: the part, body frame.
      pose: (3,) start pose, world frame (m, rad).
      directions: (P, 2) fence motion directions, world frame.
      distances: (P,) push distances, m; a zero distance is a no-op (padding).
      c: limit surface ratio (m), one per part (the same support for every push).
      mu_f: fence friction coefficient.
      expected_edges: optional (P,) hull edges each push should end flush on (-1 skip).
      active: optional (P,) bools, the pushes to run: an inactive push is
        skipped (its row: pose unchanged, edge -1, nothing moved).  Padding a
        plan with inactive pushes costs nothing under ``jax.vmap`` when
        ``active`` is not batched (it stays a ``lax.cond``).

    Returns:
      ``(final_pose, outcomes)``: the (3,) pose after the plan and a
      :class:`SimOutcome` with a leading axis of length P (after each push).
    """
    pp = _part(geom, c, mu_f)   # sliding windows: once per part, not per push
    return scan_pushes(lambda p, dvec, dist, exp: _push(pp, p, dvec, dist, exp), geom.body.dtype,
                       pose, directions, distances, expected_edges, active)


def scan_pushes(push, dtype, pose, directions, distances, expected_edges=None, active=None):
    """A push plan with ``lax.scan``: ``push(pose, direction, distance,
    expected_edge) -> SimOutcome`` for each push in turn (shared by
    :func:`simulate_pushes` and :func:`kernels.quasistatic_points.simulate_pushes`);
    arguments and returns as :func:`simulate_pushes`, in ``dtype``."""
    distances = jnp.asarray(distances, dtype)
    if expected_edges is None:
        expected_edges = jnp.full(distances.shape, -1, jnp.int32)

    def run(p, dvec, dist, exp):
        out = push(p, dvec, dist, exp)
        return out.pose, out

    def skip(p, dvec, dist, exp):
        z, i, f = jnp.zeros((), dtype), jnp.zeros((), jnp.int32), jnp.asarray(False)
        return p, SimOutcome(pose=p, edge=i - 1, complete=f, rotation=z, slip=z, slipped=f,
                             landed_other_edge=f, landings=i, fence=jnp.full((), jnp.nan, dtype),
                             phases=i, truncated=f)

    def step(p, xs):
        dvec, dist, exp, act = xs
        if active is None:
            return run(p, dvec, dist, exp)
        return jax.lax.cond(act, run, skip, p, dvec, dist, exp)

    act = jnp.ones(distances.shape, bool) if active is None else jnp.asarray(active, bool)
    final, outs = jax.lax.scan(step, jnp.asarray(pose, dtype),
                               (jnp.asarray(directions, dtype), distances,
                                jnp.asarray(expected_edges, jnp.int32), act))
    return final, outs
