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
C; the sampler should respect that, the helper does not check it.)

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

Integration
-----------
``lax.scan`` over ``n_steps`` steps; each adds ``distance / n_steps`` of fence
travel to the travel *owed* to the part and runs one *phase*, which spends at
most two steps' worth of it; a bounded ``lax.while_loop`` spends what is still
owed after the last step.  In a phase the part is in one contact mode:

* stable flush edge or divergent vertex: translate along ``d``;
* pivot on vertex P (body vertex ``k``): ``theta`` and the signed slip ``q`` obey
  ``dtheta/ds = w(theta)``, ``dq/ds = u(theta)`` (``a``, ``b`` follow from
  ``theta`` in closed form).  The phase ends early, with the rotation clamped
  exactly, at the nearest of: the next edge landing (the rotation left to it
  comes from the edge normals); the contact switching between sticking and
  sliding (``|tau| = mu_f``, solved in closed form per vertex; ``w`` and ``u``
  have a kink there); and ``STEP_SCALE`` times the angular scale
  ``|w / (dw/dtheta)|`` of the regime ahead (after a stick-to-slide switch that
  scale is ``~ (c / rho)^2`` rad: a boundary layer that fixed steps would not
  resolve for small ``c``).  The travel ``s* = int dtheta / w`` and slip
  ``int u / w dtheta`` to that rotation come from Simpson's rule in ``theta``;
  if ``s*`` fits in the phase's travel the rotation is clamped there and the
  rest stays owed, otherwise one classical RK4 step in ``s`` spends it all.
  A landing makes the edge flush.  The position is rebuilt from the contact
  point, which moves by ``s d + q t``, so P stays exactly on the fence (no
  vertex penetrates it, nothing overshoots) and the total travel is exact.

Because the rates depend only on the orientation, the final pose of a push that
ends flush does not depend on the rates when the fence does not slip: it equals
:func:`kernels.push.replay_push`'s to rounding.  With slip the error is fourth
order in the step; at 200 steps it is below ~1e-5 of the part's size in the
worst cases seen (small ``c``, a stick-to-slide switch) and ~1e-6 at the 99th
percentile.

Assumptions and limits: quasi-static, normal push, fence longer than the part,
uniform support friction, ellipsoidal limit surface (an approximation of the
exact one for the sampled pressure), ``c > 0``, ``mu_f >= 0``.
"""
from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

from kernels.planar import cross2, mod_2pi, rot2, wrap_angle
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


STEP_SCALE = 0.1   # largest rotation per step, in units of the rate's angular scale
MAX_EXTRA_PHASES = 256   # bound on the phases that spend travel carried past the last step


def _flush_tolerance(dtype):
    return jnp.asarray(jnp.finfo(dtype).eps, dtype) ** 0.75


def _pivot_rates(a0, b0, c2, mu):
    """Rates ``(w, u)`` of a pivot as functions of the rotation ``dth`` from the
    current orientation (``a``, ``b`` rotate with the part)."""
    def rates(dth):
        cs, sn = jnp.cos(dth), jnp.sin(dth)
        w, u, _ = contact_rates(a0 * cs + b0 * sn, b0 * cs - a0 * sn, c2, mu)
        return w, u
    return rates


def _rk4_pivot(rates, w1, u1, h):
    """One classical RK4 step of ``(theta, q)`` over travel ``h``; returns the increments."""
    w2, u2 = rates(0.5 * h * w1)
    w3, u3 = rates(0.5 * h * w2)
    w4, u4 = rates(h * w3)
    return h / 6.0 * (w1 + 2.0 * w2 + 2.0 * w3 + w4), h / 6.0 * (u1 + 2.0 * u2 + 2.0 * u3 + u4)


def _slip_switch_table(body, c2, mu):
    """Per-vertex orientations where a pivot on that vertex switches between
    sticking and sliding (``|tau| = mu``).

    With ``a = rho cos(psi)``, ``b = rho sin(psi)`` (``psi`` the angle from the
    contact vector ``r`` to ``d``; it falls by the part's rotation),
    ``tau = -sin(2 psi) / (kappa + cos(2 psi))`` with
    ``kappa = 1 + 2 c^2 / rho^2``, and ``tau = m`` (``m = +-mu``) reads
    ``sin(x + atan m) = -m kappa / sqrt(1 + m^2)``, ``x = 2 psi``.

    Returns:
      (n, 4) values of ``psi`` (mod pi), ``nan`` where there is no switch.
    """
    rho2 = jnp.sum(body * body, axis=1)
    kap = 1.0 + 2.0 * c2 / rho2
    valid = mu * mu * (kap * kap - 1.0) <= 1.0
    mus = jnp.where(valid, mu, 0.0)
    m = jnp.stack([mus, -mus], axis=1)
    base = jnp.arcsin(jnp.clip(-m * kap[:, None] / jnp.sqrt(1.0 + m * m), -1.0, 1.0))
    phm = jnp.arctan(m)
    x = jnp.concatenate([base - phm, jnp.pi - base - phm], axis=1)
    return jnp.where(valid[:, None], 0.5 * x, jnp.nan)


def _phase(geom: PolygonGeometry, consts, st, budget):
    """Advance one contact mode by at most ``budget`` m of fence travel.

    Returns the new state and the travel left unspent (after an event)."""
    n = geom.body.shape[0]
    dtype = geom.body.dtype
    d, c2, mu, ang_u, ang_r, switch = consts
    pos, theta, cth, sth, flush, kv, rot, slip, landings = st

    d_b = jnp.stack([cth * d[0] + sth * d[1], -sth * d[0] + cth * d[1]])   # body-frame push direction
    phi = ang_u - theta           # body-frame angle of the fence side (-d)
    fl = jnp.maximum(flush, 0)
    fl1 = jnp.where(fl == n - 1, 0, fl + 1)
    is_flush = flush >= 0
    x1 = cross2(geom.body[fl], d_b)
    x2 = cross2(geom.body[fl1], d_b)
    hold = is_flush & (x1 * x2 < 0.0)     # line contact that translates (stable edge)
    k = jnp.where(is_flush, jnp.where(jnp.abs(x1) <= jnp.abs(x2), fl, fl1), kv)
    r = geom.body[k]
    a0 = jnp.dot(r, d_b)
    b0 = cross2(r, d_b)
    sigma = jnp.sign(b0)
    translate = hold | (sigma == 0)
    # rotation left before the next edge lands (phi grows when theta falls)
    target = jnp.where(sigma < 0, k, jnp.where(k == 0, n - 1, k - 1))
    nu_t = geom.nu[target]
    delta = jnp.where(sigma < 0, mod_2pi(nu_t - phi), mod_2pi(phi - nu_t))
    delta = jnp.where(delta > jnp.pi, 0.0, delta)  # already past it by rounding: land now
    # rotation left before the contact switches between sticking and sliding;
    # the switch just reached (closer than sqrt(eps)) is ignored
    psi0 = phi + jnp.pi - ang_r[k]
    dist = jnp.remainder(sigma * (psi0 - switch[k]), jnp.pi)
    tol = jnp.asarray(jnp.finfo(dtype).eps, dtype) ** 0.5
    delta_sw = jnp.min(jnp.where(dist > tol, dist, jnp.inf))   # nan (no switch) compares False
    # step-size control: no more than STEP_SCALE times the angular scale |w / (dw/dtheta)| on
    # which the rotation rate changes, in the friction regime ahead (after a stick-to-slide
    # switch that scale is ~ (c / rho)^2 rad: a boundary layer)
    tiny = jnp.asarray(jnp.finfo(dtype).tiny, dtype) ** 0.5
    pc, ps = jnp.cos(2.0 * tol), jnp.sin(2.0 * sigma * tol)
    _, _, slide_ahead = contact_rates(a0 * pc + b0 * ps, b0 * pc - a0 * ps, c2, mu)
    tc = jnp.sign(-a0 * b0) * jnp.where(jnp.isfinite(mu), mu, 0.0)
    g = b0 + tc * a0
    scale_slide = jnp.abs(g * (c2 + b0 * g)) / (jnp.abs((tc * b0 - a0) * c2 + g * g * a0) + tiny)
    scale_stick = jnp.abs(b0) / (jnp.abs(a0) + tiny)
    cap = STEP_SCALE * jnp.where(slide_ahead, scale_slide, scale_stick)
    stop = jnp.minimum(jnp.minimum(delta, delta_sw), cap)

    # travel and slip to rotate by `stop` (Simpson's rule in theta: one smooth regime)
    rates = _pivot_rates(a0, b0, c2, mu)
    w_a, u_a, _ = contact_rates(a0, b0, c2, mu)
    w_m, u_m = rates(0.5 * sigma * stop)
    w_b, u_b = rates(sigma * stop)

    def inv(w):  # 1/w, guarded (w vanishes only at the divergent equilibrium)
        return 1.0 / jnp.where(jnp.abs(w) > tiny, w, tiny)

    span = sigma * stop / 6.0
    s_ev = span * (inv(w_a) + 4.0 * inv(w_m) + inv(w_b))
    q_ev = span * (u_a * inv(w_a) + 4.0 * u_m * inv(w_m) + u_b * inv(w_b))
    event = (~translate) & (s_ev <= budget)
    land = event & (delta <= jnp.minimum(delta_sw, cap))
    s_ev = jnp.clip(s_ev, 0.0, budget)
    # otherwise one RK4 step over the whole budget (it turns by less than `stop`)
    dth, dq = _rk4_pivot(rates, w_a, u_a, budget)
    dth = sigma * jnp.minimum(jnp.abs(dth), stop)

    s_used = jnp.where(translate | ~event, budget, s_ev)
    dtheta = jnp.where(translate, 0.0, jnp.where(event, sigma * stop, dth))
    q = jnp.where(translate, 0.0, jnp.where(event, q_ev, dq))
    theta_new = theta + dtheta
    cn, sn = jnp.cos(theta_new), jnp.sin(theta_new)
    t = jnp.stack([-d[1], d[0]])
    # the contact point moves by s d + q t; rebuild the centre of mass from it
    rw0 = jnp.stack([cth * r[0] - sth * r[1], sth * r[0] + cth * r[1]])
    rw1 = jnp.stack([cn * r[0] - sn * r[1], sn * r[0] + cn * r[1]])
    pos_piv = pos + rw0 + s_used * d + q * t - rw1
    new_pos = jnp.where(translate, pos + budget * d, pos_piv)
    new_flush = jnp.where(translate, flush, jnp.where(land, target, -1))
    new_kv = jnp.where(translate, kv, k)
    st = (new_pos, theta_new, cn, sn, new_flush, new_kv, rot + dtheta, slip + jnp.abs(q),
          landings + land.astype(landings.dtype))
    return st, budget - s_used


def simulate_push(geom: PolygonGeometry, pose, direction, distance, c, mu_f, n_steps: int = 200,
                  expected_edge=-1) -> SimOutcome:
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
      n_steps: static number of integration steps of ``distance / n_steps``.
      expected_edge: hull edge the push should end flush on (for
        ``landed_other_edge``), -1 to skip.

    Returns:
      :class:`SimOutcome`.  Pure, jit- and vmap-able over every array argument.
      A start pose within ``eps**0.75`` rad of an edge lying flush starts in line
      contact on that edge.
    """
    n = geom.body.shape[0]
    dtype = geom.body.dtype
    pose = jnp.asarray(pose, dtype)
    d = jnp.asarray(direction, dtype)
    d = d / jnp.linalg.norm(d)
    distance = jnp.asarray(distance, dtype)
    c = jnp.asarray(c, dtype)
    mu = jnp.asarray(mu_f, dtype)
    c2 = c * c
    tol = _flush_tolerance(dtype)
    theta0 = pose[2]
    # initial contact: flush edge (within tol) or the support vertex
    R0 = rot2(theta0)
    h0 = jnp.min((geom.body @ R0.T + pose[:2]) @ d)
    phi0 = jnp.arctan2(-d[1], -d[0]) - theta0
    off = jnp.abs(wrap_angle(phi0 - geom.nu))
    e0 = jnp.argmin(off)
    flush0 = jnp.where(off[e0] <= tol, e0, -1).astype(jnp.int32)
    kv0 = contact_vertex(geom, wrap_angle(phi0)).astype(jnp.int32)

    ds = distance / n_steps
    budgets = jnp.full((n_steps,), ds, dtype)

    consts = (d, c2, mu, jnp.arctan2(-d[1], -d[0]), jnp.arctan2(geom.body[:, 1], geom.body[:, 0]),
              _slip_switch_table(geom.body, c2, mu))

    # travel owed to the part; a phase spends at most 2 steps' worth of it
    chunk = 2.0 * ds

    def spend(st, owed):
        st, left = _phase(geom, consts, st, jnp.minimum(owed, chunk))
        return st, owed - jnp.minimum(owed, chunk) + left

    def step(carry, b):
        st, owed = carry
        return spend(st, owed + b), None

    st0 = (pose[:2], theta0, jnp.cos(theta0), jnp.sin(theta0), flush0, kv0, jnp.zeros((), dtype),
           jnp.zeros((), dtype), jnp.zeros((), jnp.int32))
    (st, owed), _ = jax.lax.scan(step, (st0, jnp.zeros((), dtype)), budgets)
    # spend the travel still owed after the last step (a few phases, bounded)
    _, st, _ = jax.lax.while_loop(
        lambda v: (v[2] > 0) & (v[0] < MAX_EXTRA_PHASES),
        lambda v: (v[0] + 1,) + spend(v[1], v[2]),
        (jnp.zeros((), jnp.int32), st, owed))
    pos, theta, _, _, flush, _, rot, slip, landings = st
    # final line contact that translates
    fl = jnp.maximum(flush, 0)
    cth, sth = jnp.cos(theta), jnp.sin(theta)
    d_b = jnp.stack([cth * d[0] + sth * d[1], -sth * d[0] + cth * d[1]])
    hold = (flush >= 0) & (cross2(geom.body[fl], d_b) * cross2(geom.body[(fl + 1) % n], d_b) < 0.0)
    edge = jnp.where(hold, flush, -1).astype(jnp.int32)
    moved = distance > 0
    out_pose = jnp.where(moved, jnp.concatenate([pos, wrap_angle(theta)[None]]), pose)
    expected_edge = jnp.asarray(expected_edge, jnp.int32)
    return SimOutcome(pose=out_pose, edge=edge, complete=edge >= 0,
                      rotation=jnp.where(moved, rot, 0.0), slip=slip, slipped=slip > 0,
                      landed_other_edge=(expected_edge >= 0) & (edge >= 0) & (edge != expected_edge),
                      landings=jnp.where(moved, landings, 0), fence=h0 + distance)


def simulate_pushes(geom: PolygonGeometry, pose, directions, distances, c, mu_f, n_steps: int = 200,
                    expected_edges=None):
    """Simulate a push plan (a sequence of pushes) with ``lax.scan``.

    Args:
      geom: the part, body frame.
      pose: (3,) start pose, world frame (m, rad).
      directions: (P, 2) fence motion directions, world frame.
      distances: (P,) push distances, m; a zero distance is a no-op (padding).
      c: limit surface ratio (m), one per part (the same support for every push).
      mu_f: fence friction coefficient.
      n_steps: static integration steps per push.
      expected_edges: optional (P,) hull edges each push should end flush on (-1 skip).

    Returns:
      ``(final_pose, outcomes)``: the (3,) pose after the plan and a
      :class:`SimOutcome` with a leading axis of length P (after each push).
    """
    dtype = geom.body.dtype
    distances = jnp.asarray(distances, dtype)
    if expected_edges is None:
        expected_edges = jnp.full(distances.shape, -1, jnp.int32)

    def step(p, xs):
        dvec, dist, exp = xs
        out = simulate_push(geom, p, dvec, dist, c, mu_f, n_steps=n_steps, expected_edge=exp)
        return out.pose, out

    final, outs = jax.lax.scan(step, jnp.asarray(pose, dtype),
                               (jnp.asarray(directions, dtype), distances,
                                jnp.asarray(expected_edges, jnp.int32)))
    return final, outs
