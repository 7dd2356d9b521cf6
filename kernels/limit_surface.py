r"""The exact limit surface of a point support: how a part pushed at one
contact point moves on the support points that carry it.

:mod:`kernels.quasistatic` approximates a part's support friction by an
ellipsoidal limit surface of one ratio ``c``.  A part resting on 3-4 corners
(the ``rigid`` family of :mod:`kernels.support`) has a limit surface that is
far from an ellipsoid: it often turns about one of its loaded corners, and it
slips along the fence at friction coefficients where the ellipsoid of the
same ``c`` predicts sticking (measured in MuJoCo, ``bench/fidelity.py``).
This module solves the quasi-static motion of the exact limit surface of
``S`` support points ``p_i`` with loads ``w_i`` (fractions of the weight, one
support coefficient, which cancels out).

Frames and units: body frame, origin at the centre of mass, metres; the fence
moves along the unit direction ``d`` (body frame), ``t = perp(d) = (-d_y,
d_x)``; the contact point is ``r``.  A twist ``V = (v, w)`` (velocity of the
centre of mass, rotation rate, CCW +) moves support point ``i`` with
``v_i = v + w perp(p_i)``.

Mechanics (Mason's quasi-static pushing, Coulomb friction at every point):
the support's friction wrench is minus the gradient of the dissipation
``D(V) = sum_i w_i |v_i|`` (convex, homogeneous of degree one), and the
fence's force ``f`` at ``r`` balances it.

* **Sticking** (``v_r = d``): ``V(w) = (d - w perp(r), w)`` leaves one unknown;
  the fence does no work on a change of ``w`` (``r`` does not move), so ``w``
  minimises ``D`` on that line: ``D'(w) = sum_i w_i <q_i, v_i>/|v_i| = 0`` with
  ``q_i = perp(p_i - r)``, solved by a safeguarded Newton iteration in
  ``atan(w L)`` (``L`` the part's size; ``D'`` is increasing).  The fence's
  force is ``f = sum_i w_i v_i / |v_i|``; the contact sticks iff
  ``|<f, t>| <= mu_f <f, d>``.
* **Sliding**: the force lies on the friction cone's edge
  ``e = d + sigma mu_f t`` (``sigma = sign <f, t>`` of the sticking force), and
  the fence does no work on the twists with ``<v_r, e> = 0``: ``V`` minimises
  ``D`` on the plane ``<v_r, e> = 1`` (a frictionless pusher of normal ``e``),
  then is scaled to ``<v_r, d> = 1``.  The minimiser is either a smooth point
  (damped Newton from the sticking twist, which lies on the plane) or a
  *kink*, a twist turning the part about a loaded support point ``p_j``
  (``v_j = 0``, that point's friction anywhere in its disc): every ``j`` is
  tested exactly (the rest's gradient on the plane must be cancelled by
  ``w_j`` times a vector of the unit disc), the Newton point is used when no
  kink is optimal.  Whichever it is, the contact slips along the fence at
  ``u = <v_r, t>`` (``sigma u <= 0``: friction opposes the slip).

Every rate is per metre of fence travel (``<v_r, d> = 1``).  A rotation sense
is never reversed by friction: ``sign(w) = sign(r x d)`` (``D'(0) = -(r x d)``
because the loads' centroid is the centre of mass), as in
:func:`kernels.quasistatic.contact_rates`, whose ellipsoid this surface
replaces.  Pure JAX, one contact at a time (``jax.vmap`` at the call site),
in the dtype of the inputs; the numpy reference is
:mod:`oracles.limit_surface_numpy`.
"""
from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

#: iterations of the sticking solve (safeguarded Newton on ``D'(w) = 0``)
STICK_ITERATIONS = 40
#: damped Newton iterations of the sliding solve's smooth candidate
SLIDE_ITERATIONS = 40


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class Motion:
    """Quasi-static motion of a part pushed at one point (a JAX pytree), per
    metre of fence travel, body frame.

    Attributes:
      v: (2,) velocity of the centre of mass (m/m).
      omega: () rotation rate (rad/m, CCW +).
      slip: () velocity of the contact point along ``t = perp(d)`` (m/m; 0 when sticking).
      sliding: () bool, the contact slides along the fence.
      force: (2,) the fence's force on the part, in units of ``mu_s`` times the weight.
    """

    v: jax.Array
    omega: jax.Array
    slip: jax.Array
    sliding: jax.Array
    force: jax.Array


def _perp(a):
    return jnp.stack([-a[..., 1], a[..., 0]], -1)


def _det2(A):
    """Determinants of (..., 2, 2) matrices, in closed form."""
    return A[..., 0, 0] * A[..., 1, 1] - A[..., 0, 1] * A[..., 1, 0]


def _solve2(A, b):
    """``A^-1 b`` for (..., 2, 2) ``A`` and (..., 2) ``b`` by Cramer's rule.

    Closed form, not ``jnp.linalg.solve``: LAPACK's batched custom calls on the
    CPU deadlock in XLA's thread pool when nested in the push's loops over
    large batches (seen at 1024 samples under ``lax.map``), and for 2 x 2 the
    algebra is cheaper anyway."""
    det = _det2(A)
    x0 = A[..., 1, 1] * b[..., 0] - A[..., 0, 1] * b[..., 1]
    x1 = A[..., 0, 0] * b[..., 1] - A[..., 1, 0] * b[..., 0]
    return jnp.stack([x0, x1], -1) / det[..., None]


def _velocities(points, V):
    """(S, 2) support point velocities of the twist ``V = (vx, vy, w)``."""
    return V[:2] + V[2] * _perp(points)


def dissipation(points, weights, V):
    """``D(V) = sum_i w_i |v_i|``: the support's frictional power for the twist
    ``V`` (units of ``mu_s`` weight times m/m)."""
    return jnp.sum(weights * jnp.linalg.norm(_velocities(points, V), axis=-1))


def _stick(points, weights, r, d, size):
    """``w`` minimising ``D`` on the sticking line (module docstring)."""
    dtype = points.dtype
    q = _perp(points - r)                                     # (S, 2)
    tiny = jnp.finfo(dtype).tiny

    def deriv(om):
        a = d + om * q
        n = jnp.maximum(jnp.linalg.norm(a, axis=-1), tiny)
        g = jnp.sum(weights * jnp.einsum("si,si->s", q, a) / n)
        h = jnp.sum(weights * (jnp.sum(q * q, -1) * n * n - jnp.einsum("si,si->s", q, a) ** 2)
                    / (n * n * n))
        return g, h

    # phi = atan(w L) in (-pi/2, pi/2): D' is increasing in phi; bisect or step
    half = jnp.asarray(0.5 * jnp.pi, dtype) * (1.0 - 64 * jnp.finfo(dtype).eps)

    def it(_, x):
        phi, lo, hi = x
        om = jnp.tan(phi) / size
        g, h = deriv(om)
        lo = jnp.where(g < 0, phi, lo)
        hi = jnp.where(g < 0, hi, phi)
        dphi = -g / jnp.maximum(h * (1.0 + om * om * size * size) / size, tiny)
        nxt = phi + dphi
        ok = (nxt > lo) & (nxt < hi) & jnp.isfinite(nxt)
        return jnp.where(ok, nxt, 0.5 * (lo + hi)), lo, hi

    phi, _, _ = jax.lax.fori_loop(0, STICK_ITERATIONS, it,
                                  (jnp.zeros((), dtype), -half, half))
    return jnp.tan(phi) / size


def _slide(points, weights, r, e, V_start):
    """The twist minimising ``D`` on the plane ``<v_r, e> = 1`` (module docstring)."""
    dtype = points.dtype
    S = points.shape[0]
    tiny = jnp.finfo(dtype).tiny
    pr = _perp(r)
    # V = V0 + B z on the plane; B's columns keep <v_r, e> = 0
    V0 = jnp.concatenate([e / jnp.dot(e, e), jnp.zeros(1, dtype)])
    B = jnp.stack([jnp.concatenate([_perp(e), jnp.zeros(1, dtype)]),
                   jnp.concatenate([-pr, jnp.ones(1, dtype)])], axis=1)        # (3, 2)
    Pp = _perp(points)
    A = jnp.concatenate([jnp.broadcast_to(jnp.eye(2, dtype=dtype), (S, 2, 2)),
                         Pp[:, :, None]], axis=2)                              # (S, 2, 3)
    a0 = A @ V0                                                                # (S, 2)
    Ab = A @ B                                                                 # (S, 2, 2)

    def value(z, delta=0.0):
        a = a0 + Ab @ z
        return jnp.sum(weights * jnp.sqrt(jnp.sum(a * a, -1) + delta * delta))

    def grad_hess(z, delta=0.0, drop=None):
        a = a0 + Ab @ z
        n = jnp.maximum(jnp.sqrt(jnp.sum(a * a, -1) + delta * delta), tiny)
        u = a / n[:, None]
        wt = weights if drop is None else jnp.where(jnp.arange(S) == drop, 0.0, weights)
        g = jnp.einsum("s,sik,si->k", wt, Ab, u)
        proj = jnp.eye(2, dtype=dtype)[None] - u[:, :, None] * u[:, None, :]
        H = jnp.einsum("s,sik,sij,sjl->kl", wt / n, Ab, proj, Ab)
        return g, H

    # the smooth candidate: damped Newton from the sticking twist (on the plane) on
    # the smoothed dissipation sum w_i sqrt(|v_i|^2 + delta^2), delta halved each step
    # (near a kink the unsmoothed Newton crawls); the last steps are at delta ~ 1e-9
    z0 = _solve2(B.T @ B, B.T @ (V_start - V0))             # B has full column rank
    ts = 2.0 ** -jnp.arange(12, dtype=dtype)
    floor = jnp.sqrt(jnp.finfo(dtype).eps) * 1e-1

    def newton(i, z):
        delta = jnp.maximum(0.5 ** i.astype(dtype), floor)
        g, H = grad_hess(z, delta)
        scale = jnp.maximum(jnp.trace(H), tiny)
        step = -_solve2(H + 1e-12 * scale * jnp.eye(2, dtype=dtype), g)
        f0 = value(z, delta)
        fs = jax.vmap(lambda t: value(z + t * step, delta))(ts)
        ok = fs <= f0 + 1e-4 * ts * jnp.dot(g, step)
        return z + ts[jnp.argmax(ok)] * jnp.any(ok) * step

    z_s = jax.lax.fori_loop(0, SLIDE_ITERATIONS, newton, z0)

    # the kinks: a turn about support point j; optimal iff the others' gradient
    # on the plane is w_j times a vector of the unit disc mapped by Ab_j^T
    det = _det2(Ab)                                                            # (S,)
    ok_det = jnp.abs(det) > 1e-12 * jnp.maximum(jnp.max(jnp.abs(det)), tiny)
    Abs = jnp.where(ok_det[:, None, None], Ab, jnp.eye(2, dtype=dtype))
    zk = _solve2(Abs, -a0)                                                     # (S, 2)

    def kink_ok(j, z):
        g, _ = grad_hess(z, drop=j)
        y = _solve2(Abs[j].T, -g) / jnp.maximum(weights[j], tiny)
        return (jnp.dot(y, y) <= 1.0) & ok_det[j] & (weights[j] > 0)

    oks = jax.vmap(kink_ok)(jnp.arange(S), zk)
    vk = jax.vmap(value)(zk)
    j = jnp.argmin(jnp.where(oks, vk, jnp.inf))
    z = jnp.where(jnp.any(oks), zk[j], z_s)
    return V0 + B @ z


def push_motion(points, weights, r, d, mu_f) -> Motion:
    """Quasi-static motion of a part on the point support ``(points,
    weights)`` pushed at ``r`` by a fence moving along ``d`` (module docstring).

    Args:
      points: (S, 2) support points, body frame, origin at the centre of mass, m.
      weights: (S,) their loads (fractions of the weight; >= 0, summing to 1,
        centroid at the origin: a part at rest).  Zero-weight points are padding.
      r: (2,) the contact point, body frame, m (ahead of the fence: the part lies
        on the side ``<p - r, d> >= 0``).
      d: (2,) unit direction of the fence's motion, body frame.
      mu_f: () fence friction coefficient (>= 0; ``inf``: never slips).

    Returns:
      :class:`Motion`, normalised so that the contact point advances with the
      fence (``<v_r, d> = 1``).
    """
    points = jnp.asarray(points)
    dtype = points.dtype
    weights = jnp.asarray(weights, dtype)
    r = jnp.asarray(r, dtype)
    d = jnp.asarray(d, dtype)
    mu = jnp.asarray(mu_f, dtype)
    tiny = jnp.finfo(dtype).tiny
    size = jnp.maximum(jnp.max(jnp.linalg.norm(points - r, axis=-1)), tiny)
    t = _perp(d)
    om = _stick(points, weights, r, d, size)
    V_st = jnp.concatenate([d - om * _perp(r), om[None]])
    a = _velocities(points, V_st)
    f = jnp.sum(weights[:, None] * a / jnp.maximum(jnp.linalg.norm(a, axis=-1), tiny)[:, None], 0)
    fn, ft = jnp.dot(f, d), jnp.dot(f, t)
    sliding = jnp.isfinite(mu) & (jnp.abs(ft) > mu * fn)
    sigma = jnp.where(ft >= 0, 1.0, -1.0).astype(dtype)
    m = jnp.where(jnp.isfinite(mu), mu, 0.0)
    e = d + sigma * m * t
    V_sl = _slide(points, weights, r, e, V_st)
    vr = V_sl[:2] + V_sl[2] * _perp(r)
    V_sl = V_sl / jnp.dot(vr, d)
    V = jnp.where(sliding, V_sl, V_st)
    vr = V[:2] + V[2] * _perp(r)
    # sliding: the force is lambda e, lambda from the power balance D(V) = <f, v_r>
    # (exact also at a kink, where the resting point's friction is indeterminate)
    f_sl = e * dissipation(points, weights, V_sl) / jnp.dot(e, V_sl[:2] + V_sl[2] * _perp(r))
    f = jnp.where(sliding, f_sl, f)
    return Motion(v=V[:2], omega=V[2], slip=jnp.where(sliding, jnp.dot(vr, t), 0.0),
                  sliding=sliding, force=f)
