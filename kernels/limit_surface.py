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
  ``q_i = perp(p_i - r)`` (``D'`` is increasing).  The fence's force is
  ``f = sum_i w_i v_i / |v_i|``; the contact sticks iff ``|<f, t>| <= mu_f <f, d>``.
* **Sliding**: the force lies on the friction cone's edge
  ``e = d + sigma mu_f t`` (``sigma = sign <f, t>`` of the sticking force), and
  ``V`` minimises ``D`` on the plane ``<v_r, e> = 1`` (a frictionless pusher of
  normal ``e``), then is scaled to ``<v_r, d> = 1``.  The minimiser is either a
  *kink*, a twist turning the part about a loaded support point ``p_j``
  (``v_j = 0``, that point's friction anywhere in its disc: every ``j`` is
  tested exactly, in closed form), or a smooth point.  The contact slips along
  the fence at ``u = <v_r, t>`` (``sigma u <= 0``: friction opposes the slip).

How the smooth sliding point is found: write ``v_r = cos(g) d + sin(g) t``.
For each direction ``g`` the rotation rate is the one-dimensional minimiser of
the sticking problem along ``v_r`` (the *line solve*), and the contact force
``f(g)`` is the support point of the contact's limit curve in direction
``v_r``; its angle from ``e`` is increasing in ``g`` (jumping over an interval
at each kink direction), so ``g`` is bracketed in ``[0, -sigma pi/2)`` and
found by Newton's method on that angle, safeguarded by bisection (the angle is
measured from ``v_r``, within ``pi/2`` of it, so it has no branch cut).  Each
direction's line solve continues from the last one (a first-order predictor
of ``w``); a line solve that has not converged does not move the bracket and
goes on at the same ``g``.  Then two-dimensional Newton steps on both
conditions at once (``D'(w) = 0`` along ``v_r``, the force's angle) polish the
point: they resolve the steep ramps next to a kink's jump, where the
bracketing converges slowly.  Of the smooth point and the best kink on the
plane, the one of lower ``D`` is the twist (a smooth optimum within a hair of
a kink, unresolved, is then that kink's twist, within the hair).

The line solve (sticking, and sliding's inner problem) is Newton's method in
``atan(w L)`` (``L`` the part's size), bracketed, with an accepted step at
most half the previous one (else bisection), started at one Weiszfeld step from
``w = 0``.  Where the line passes close to a support point's rest (``D'`` a
smoothed step of that point's term, where Newton crawls), the step is Newton's
on the equivalent regularised equation ``|q_j| (w - w_j) sqrt(1 - y^2) = delta_j y``
(``y`` the other terms' share of ``D'``, ``delta_j`` the line's distance from the
rest), which is smooth through the step.  Measured against the cvxpy oracle
on 20,000 random supports of 3, 4, 6 and 25 points at fence friction 0.3, 0.8,
1.5: the previous solver (smoothed Newton with a 12-point line search, 40
iterations each) was wrong by 0.4-0.65 (relative) on 1-4 of them, where its
safeguard threw away a converged iterate (a strict bracket test) and the
iteration ran out before converging again; this one on 0-2 (by at most 1e-2,
a smooth optimum within ~1e-3 of a kink), in a third to a fifth of the time
(S = 4: 19 -> 9 us a motion; S = 25: 200 -> 50 us; 2 CPU cores).

Many nearby motions (a pivot's quadrature nodes): :func:`warm_motion` starts
both solves from a prediction (:class:`Warm`): a few safeguarded line-solve
steps for the sticking rate and a few two-dimensional Newton steps on the
sliding conditions, and says whether they converged (the sticking step at
rounding, the sliding conditions at ``sqrt(eps)``, or an optimal kink); where
they did, the motion is the cold solve's to convergence, where they did not the
caller solves cold (:func:`kernels.quasistatic_points.node_motions`).  The
contact-independent half of the kink test (:func:`kink_base`) is computed once
per support.

Every iteration stops once it is settled (a Newton step of ``0.1 sqrt(eps)``,
after which the next is at rounding; a ``while`` loop, capped at the counts
below), not after a fixed count: under ``vmap`` a batch then takes as many
steps as its slowest member, not the cap.  And the warm sliding steps are
wanted only where the contact slides with no optimal kink (a tenth of a
pivot's nodes on rigid corners, nice-stable pentagon): under ``vmap`` those
are gathered and polished alone (:func:`_warm_polish`, a ``custom_vmap``
rule), so the others do not take every step too.  The pentagon's 7-push plan
in one compiled call of 1,024 draws on rigid corners, old and new kernel in
one process: 3,500 -> 6,400 samples/s, final poses equal to 2e-17 m (the
replay's figures: :mod:`kernels.quasistatic_points`).

Every rate is per metre of fence travel (``<v_r, d> = 1``).  A rotation sense
is never reversed by friction: ``sign(w) = sign(r x d)`` (``D'(0) = -(r x d)``
because the loads' centroid is the centre of mass), as in
:func:`kernels.quasistatic.contact_rates`, whose ellipsoid this surface
replaces.  Pure JAX, one contact at a time (``jax.vmap`` at the call site),
in the dtype of the inputs; the reference is the cvxpy oracle
:mod:`oracles.limit_surface_numpy`.
"""
from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

from kernels.linsolve import solve2

#: iterations of the sticking line solve (from one Weiszfeld step; converged to
#: rounding in 10-12 on random supports, near-kink lines included)
STICK_ITERATIONS = 12
#: bracketed Newton iterations over the sliding direction ``g``
SLIDE_ITERATIONS = 16
#: line-solve iterations per sliding direction (continued while not converged)
INNER_ITERATIONS = 6
#: two-dimensional Newton steps polishing the sliding point
POLISH_ITERATIONS = 6


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


def _velocities(points, V):
    """(S, 2) support point velocities of the twist ``V = (vx, vy, w)``."""
    return V[:2] + V[2] * _perp(points)


def dissipation(points, weights, V):
    """``D(V) = sum_i w_i |v_i|``: the support's frictional power for the twist
    ``V`` (units of ``mu_s`` weight times m/m)."""
    return jnp.sum(weights * jnp.linalg.norm(_velocities(points, V), axis=-1))



def _settled(dtype):
    """A Newton step this short (``0.1 sqrt(eps)``, in ``atan(w L)`` or in
    ``g``) leaves the next one at rounding: where the solves stop."""
    return 0.1 * jnp.sqrt(jnp.finfo(dtype).eps)


def _line_solve(q, weights, c, size, phi, lo, hi, iters, step, until=None):
    """The rotation rate minimising ``D`` on the line ``v_r = c`` (module
    docstring): ``iters`` safeguarded Newton steps in ``phi = atan(w size)``
    from ``phi`` within the bracket ``[lo, hi]`` (``step``: the previous step's
    length, bounding the next), stopping early once a step is at most ``until``
    (None: never; a ``while`` loop, which under ``vmap`` runs until the whole
    batch has stopped).  Returns ``(phi, lo, hi, last step)``."""
    dtype = q.dtype
    tiny, eps = jnp.finfo(dtype).tiny, jnp.finfo(dtype).eps
    qq = jnp.sum(q * q, -1)
    qn = jnp.sqrt(qq)
    moving = qq > 0                  # q_j = 0: the contact point itself, |v_j| = |c|
    # each term's rest on the line (w_j) and the line's distance from it (delta_j):
    # |c + w q_j|^2 = |q_j|^2 (w - w_j)^2 + delta_j^2, free of the cancellation of
    # the expanded square next to a rest (where |v_j| is tiny)
    om_rest = jnp.where(moving, -(q @ c) / jnp.where(moving, qq, 1.0), 0.0)
    delta = jnp.where(moving, jnp.abs(c[0] * q[:, 1] - c[1] * q[:, 0]) / jnp.where(moving, qn, 1.0),
                      jnp.sqrt(jnp.dot(c, c)))
    # each step's place and width in phi (a term without a rest: never a step)
    real = (weights > 0) & moving
    phi_rest = jnp.where(real, jnp.arctan(om_rest * size), jnp.inf)
    phi_width = jnp.where(real, delta / jnp.maximum(qn, tiny) * size
                          / (1.0 + (om_rest * size) ** 2), jnp.inf)

    def trip(_, state):
        phi, lo, hi, last = state
        om = jnp.tan(phi) / size
        x = om - om_rest                                    # (S,) from each rest
        n2 = qq * x * x + delta * delta
        n = jnp.sqrt(jnp.maximum(n2, tiny))
        num = qq * x                                        # <q_j, v_j>
        g_terms = weights * num / n                         # each term's D'
        h_terms = weights * qq * delta * delta / (n2 * n)   # and D'' (= w_j |q_j|^2 delta_j^2 / |v_j|^3)
        g, h = jnp.sum(g_terms), jnp.sum(h_terms)
        lo = jnp.where(g < 0, phi, lo)
        hi = jnp.where(g < 0, hi, phi)
        dx = -g / jnp.maximum(h * (1.0 + om * om * size * size) / size, tiny)
        # near support point j's rest D' is a smoothed step of j's term: Newton on
        # H(w) = |q_j| (w - w_j) sqrt(1 - y^2) - delta_j y = 0, y = -(D' - D'_j) / (w_j |q_j|).
        # j: the sharpest step (narrowest, delta_j / |q_j|) whose rest is in the bracket,
        # else the term of largest D'' here
        width = jnp.where((phi_rest > lo) & (phi_rest < hi), phi_width, jnp.inf)
        j_in = jnp.argmin(width)
        sharp = width[j_in] < 0.1 * (hi - lo)
        j = jnp.where(sharp, j_in, jnp.argmax(h_terms))
        wq = jnp.maximum(weights[j] * qn[j], tiny)
        y, yp = -(g - g_terms[j]) / wq, -(h - h_terms[j]) / wq
        sq = jnp.sqrt(jnp.maximum(1.0 - y * y, tiny))
        H = qn[j] * x[j] * sq - delta[j] * y
        Hp = qn[j] * sq - qn[j] * x[j] * y * yp / sq - delta[j] * yp
        om_k = om - H / jnp.where(jnp.abs(Hp) > tiny, Hp, tiny)
        near = (jnp.abs(y) < 0.99) & (sharp | (h_terms[j] > 0.5 * h)) & jnp.isfinite(om_k)
        dx = jnp.where(near, jnp.arctan(om_k * size) - phi, dx)
        nxt = phi + dx
        done = jnp.abs(dx) <= 64 * eps                     # converged: a step at rounding
        ok = done | ((nxt >= lo) & (nxt <= hi) & jnp.isfinite(nxt) & (2.0 * jnp.abs(dx) <= last))
        nxt = jnp.where(ok, jnp.clip(nxt, lo, hi), 0.5 * (lo + hi))
        return nxt, lo, hi, jnp.abs(nxt - phi)

    start = (phi, lo, hi, jnp.asarray(step, dtype))
    if until is None:
        return jax.lax.fori_loop(0, iters, trip, start)
    return jax.lax.while_loop(lambda x: (x[0] < iters) & (x[1][3] > until),
                              lambda x: (x[0] + 1, trip(x[0], x[1])),
                              (jnp.zeros((), jnp.int32), start))[1]


def _bracket(q, weights, c, half):
    """The half of ``(-pi/2, pi/2)`` holding the line solve's root (the sign of
    ``D'(0) = sum_i w_i <q_i, c>``), as ``(lo, hi)``."""
    g0 = jnp.sum(weights * (q @ c))
    zero = jnp.zeros((), q.dtype)
    return jnp.where(g0 < 0, zero, -half), jnp.where(g0 < 0, half, zero)


def _weiszfeld(q, weights, d):
    """One Weiszfeld step from ``w = 0`` for the sticking rate (rad/m): the
    line solve's start."""
    tiny = jnp.finfo(q.dtype).tiny
    return -jnp.sum(weights * (q @ d)) / jnp.maximum(jnp.sum(weights * jnp.sum(q * q, -1)), tiny)


def _stick(q, weights, d, size, half):
    """The sticking rotation rate (module docstring), rad/m."""
    lo, hi = _bracket(q, weights, d, half)
    phi = jnp.clip(jnp.arctan(_weiszfeld(q, weights, d) * size), lo, hi)
    phi, _, _, _ = _line_solve(q, weights, d, size, phi, lo, hi, STICK_ITERATIONS, 4.0,
                               _settled(q.dtype))
    return jnp.tan(phi) / size


def kink_base(points, weights):
    """The contact-independent half of :func:`_kinks`: for each support point
    ``p_j``, the unit sum ``F0_j = sum_{i != j} w_i perp(p_i - p_j) / |p_i - p_j|``
    and the moment ``M_j = sum_{i != j} w_i |p_i - p_j|`` of the others' friction
    when the part turns about ``p_j`` (body frame, m).  Computed once per support,
    not once per contact, by callers that solve many motions on one support."""
    dtype = points.dtype
    tiny = jnp.finfo(dtype).tiny
    S = points.shape[0]
    dp = points[None, :, :] - points[:, None, :]            # (j, i, 2): p_i - p_j
    dist = jnp.linalg.norm(dp, axis=-1)
    others = jnp.where(jnp.eye(S, dtype=bool), 0.0, weights[None, :])
    F0 = jnp.sum(others[..., None] * _perp(dp) / jnp.maximum(dist, tiny)[..., None], 1)
    return F0, jnp.sum(others * dist, 1)


def _kinks(points, weights, r, d, e, size, base):
    """The turns about each support point ``p_j`` on the plane ``<v_r, e> = 1``
    (closed form): ``(optimal (S,), feasible (S,), D (S,), twists (S, 3))``.

    Turning about ``p_j`` at ``w_j = 1 / ((r - p_j) x e)``, the others' friction
    is ``F_j`` with moment ``M_j = sum_i w_i |p_i - p_j|`` about ``p_j``; the
    fence's force ``lambda e`` balances the moment (``lambda = M_j / |(r - p_j) x e|``)
    and ``p_j``'s own friction ``lambda e - F_j`` must lie in its disc of radius
    ``w_j``: then the turn is optimal.  Feasible: a loaded point, a turn that
    advances the contact (``<v_r, d> > 0``).  ``base``: :func:`kink_base`."""
    dtype = points.dtype
    tiny = jnp.finfo(dtype).tiny
    F0, M = base
    rj = r[None] - points                                   # (j, 2): r - p_j
    cr = rj[:, 0] * e[1] - rj[:, 1] * e[0]                  # (r - p_j) x e
    sense = jnp.where(cr >= 0, 1.0, -1.0).astype(dtype)
    F = sense[:, None] * F0
    lam = M / jnp.maximum(jnp.abs(cr), tiny)
    own = lam[:, None] * e - F
    w = 1.0 / jnp.where(jnp.abs(cr) > 0, cr, 1.0)
    vr = w[:, None] * _perp(rj)
    feasible = (weights > 0) & (jnp.abs(cr) > 64 * jnp.finfo(dtype).eps * size) & (vr @ d > 0)
    optimal = feasible & (jnp.sum(own * own, -1) <= weights ** 2)
    V = jnp.concatenate([vr - w[:, None] * _perp(r)[None], w[:, None]], 1)
    return optimal, feasible, jnp.abs(w) * M, V


def _conditions(q, weights, d, scale, sigma, m, g, w):
    """The smooth sliding point's two conditions at ``(g, w)`` (module
    docstring): ``(D'(w) along v_r(g) / scale, the force's angle from e)``, their
    Jacobian in ``(g, w)``, and ``dw/dg`` along the line solves."""
    tiny = jnp.finfo(q.dtype).tiny
    c = jnp.cos(g) * d + jnp.sin(g) * _perp(d)
    a = c + w * q
    n = jnp.sqrt(jnp.maximum(jnp.sum(a * a, -1), tiny))
    u = a / n[:, None]
    f = jnp.sum(weights[:, None] * u, 0)
    cp = _perp(c)
    Pq = q - u * jnp.sum(u * q, -1, keepdims=True)        # (I - u u^T) q_i
    Pc = cp[None] - u * (u @ cp)[:, None]                 # (I - u u^T) dc/dg
    Dw = jnp.sum(weights * jnp.sum(q * u, -1)) / scale
    Dww = jnp.sum(weights * jnp.sum(q * Pq, -1) / n) / scale
    Dwg = jnp.sum(weights * jnp.sum(q * Pc, -1) / n) / scale
    fw = jnp.sum((weights / n)[:, None] * Pq, 0)
    fg = jnp.sum((weights / n)[:, None] * Pc, 0)
    ff = jnp.maximum(jnp.dot(f, f), tiny)
    # f lies within pi/2 of c (its power <f, c> = D > 0): no branch cut
    ang = jnp.arctan2(c[0] * f[1] - c[1] * f[0], jnp.dot(c, f)) + g - sigma * jnp.arctan(m)
    Aw = (f[0] * fw[1] - f[1] * fw[0]) / ff
    Ag = (f[0] * fg[1] - f[1] * fg[0]) / ff
    J = jnp.stack([jnp.stack([Dwg, Dww]), jnp.stack([Ag, Aw])])
    return jnp.stack([Dw, ang]), J, -Dwg / jnp.maximum(Dww, tiny)


def _polish(need, q, weights, d, scale, sigma, m, g, w, size, iters=None):
    """Two-dimensional Newton steps on the sliding conditions from ``(g, w)``
    (``size``: the part's, m), each accepted only where it lowers their
    residual, a rejected step halved for the next trip (down to
    :data:`BACKTRACK_MIN` of the Newton step, then stop): at most ``iters``
    (default ``WARM_SLIDE_ITERATIONS``), stopping once settled (the next step
    would be at rounding).  ``need``: the point is wanted (else ``(g, w, 0)``
    at once).  Returns ``(g, w, residual (2,))``."""
    tol = _settled(q.dtype)

    def conditions(g, w):
        return _conditions(q, weights, d, scale, sigma, m, g, w)

    def trip(x):
        k, g, w, F, J, done, lam = x
        dg, dw = solve2(J, F)
        small = (jnp.abs(dg) <= tol) & (jnp.abs(dw) * size <= tol * (1.0 + jnp.abs(w) * size))
        g2, w2 = g - lam * dg, w - lam * dw
        F2, J2, _ = conditions(g2, w2)
        ok = (jnp.sum(F2 * F2) < jnp.sum(F * F)) & jnp.isfinite(g2) & jnp.isfinite(w2)
        stop = small | (~ok & (lam <= BACKTRACK_MIN))
        return (k + 1, jnp.where(ok, g2, g), jnp.where(ok, w2, w), jnp.where(ok, F2, F),
                jnp.where(ok, J2, J), stop, jnp.where(ok, 1.0, 0.5 * lam))

    F, J, _ = conditions(g, w)
    x = (jnp.zeros((), jnp.int32), g, w, F, J, ~need, jnp.ones((), q.dtype))
    _, g, w, F, _, _, _ = jax.lax.while_loop(
        lambda x: (x[0] < (WARM_SLIDE_ITERATIONS if iters is None else iters)) & ~x[5], trip, x)
    return g, w, jnp.where(need, F, 0.0)


#: the smallest fraction of a Newton step :func:`_polish` tries before it stops
#: (a step that does not lower the residual is halved: next to a foot the
#: sliding point nears, the full step overshoots; without halving, 10 % of a
#: uniform pad's warm nodes stopped there, residual 0.05, and were solved cold)
BACKTRACK_MIN = 0.5 ** 4


@jax.custom_batching.custom_vmap
def _warm_polish(need, q, weights, d, scale, sigma, m, g, w, size):
    """:func:`_polish` from a warm start.  Under ``vmap`` only the points wanted are
    polished, gathered ``len // POLISH_SHARE`` at a time (a tenth of a pivot's
    nodes slide with no optimal kink on rigid corners; under ``vmap`` the
    others would take every step too)."""
    return _polish(need, q, weights, d, scale, sigma, m, g, w, size)


def _full(axis_size, args, in_batched):
    return tuple(x if b else jnp.broadcast_to(x, (axis_size,) + jnp.shape(x))
                 for x, b in zip(args, in_batched))


def gathered(fn, pending, take, outs, chunk: int):
    """``outs`` (a pytree of arrays over a flat leading axis) with ``fn``'s
    results put in where ``pending``, ``chunk`` entries a loop trip:
    ``jax.vmap(fn)(*take(idx))`` for the entries ``idx`` gathered, so that a
    few entries of a large batch cost their own work, not the batch's (the
    batch rules of :func:`_warm_polish` and
    :func:`kernels.quasistatic_points.node_motions`' cold fallback)."""
    def more(x):
        pend, outs = x
        idx = jnp.nonzero(pend, size=chunk, fill_value=0)[0]
        sel = pend[idx]
        new = jax.vmap(fn)(*take(idx))
        outs = jax.tree_util.tree_map(lambda a, b: a.at[idx].set(jnp.where(
            sel.reshape(sel.shape + (1,) * (b.ndim - 1)), b, a[idx])), outs, new)
        return pend.at[idx].set(False), outs

    return jax.lax.while_loop(lambda x: jnp.any(x[0]), more, (pending, outs))[1]


@_warm_polish.def_vmap
def _warm_polish_batched(axis_size, in_batched, *args):
    args = _full(axis_size, args, in_batched)
    need, g, w = args[0], args[7], args[8]
    out = gathered(_polish, need, lambda idx: tuple(a[idx] for a in args),
                   (g, w, jnp.zeros(g.shape + (2,), g.dtype)),
                   max(POLISH_MIN, axis_size // POLISH_SHARE))
    return out, (True, True, True)


#: under ``vmap``, the sliding points polished a loop trip: the batch over this
#: (at least ``POLISH_MIN``)
POLISH_SHARE = 4
POLISH_MIN = 8


def _slide(points, weights, r, d, q, e, sigma, m, size, half, w_stick):
    """The smooth point minimising ``D`` on the plane ``<v_r, e> = 1`` (module
    docstring): ``(V with |v_r| = 1, its D on the plane)``."""
    dtype = points.dtype
    tiny, eps = jnp.finfo(dtype).tiny, jnp.finfo(dtype).eps
    t = _perp(d)
    pr = _perp(r)
    scale = jnp.maximum(jnp.sum(weights * jnp.sqrt(jnp.sum(q * q, -1))), tiny)

    def direction(g):
        return jnp.cos(g) * d + jnp.sin(g) * t

    def conditions(g, w):
        return _conditions(q, weights, d, scale, sigma, m, g, w)

    def trip(_, x):
        g, phi, lo, hi, last, more, ilo, ihi, istep = x
        c = direction(g)
        blo, bhi = _bracket(q, weights, c, half)
        blo, bhi = jnp.where(more, ilo, blo), jnp.where(more, ihi, bhi)
        phi = jnp.clip(phi, blo, bhi)
        phi, ilo, ihi, istep = _line_solve(q, weights, c, size, phi, blo, bhi, INNER_ITERATIONS,
                                           jnp.where(more, istep, 4.0),
                                           _settled(dtype))
        w = jnp.tan(phi) / size
        conv = istep <= _settled(dtype)                 # the line solve converged
        F, J, dw = conditions(g, w)
        ang, slope = F[1], J[1, 0] + J[1, 1] * dw             # d ang / dg along the solves
        beyond = ang * sigma > 0                              # the force still past e
        lo = jnp.where(beyond & conv, g, lo)
        hi = jnp.where(beyond | ~conv, hi, g)
        dx = -ang / jnp.where(jnp.abs(slope) > tiny, slope, tiny)
        nxt = g + dx
        a, b = jnp.minimum(lo, hi), jnp.maximum(lo, hi)
        done = jnp.abs(dx) <= 64 * eps
        ok = done | ((nxt >= a) & (nxt <= b) & jnp.isfinite(nxt) & (2.0 * jnp.abs(dx) <= last))
        nxt = jnp.where(ok, jnp.clip(nxt, a, b), 0.5 * (lo + hi))
        nxt = jnp.where(conv, nxt, g)
        phi = jnp.where(conv, jnp.arctan((w + dw * (nxt - g)) * size), phi)
        return (nxt, phi, lo, hi, jnp.where(conv, jnp.abs(nxt - g), last), ~conv, ilo, ihi, istep)

    zero = jnp.zeros((), dtype)
    start = (zero, jnp.arctan(w_stick * size), zero, -sigma * half, jnp.asarray(4.0, dtype),
             jnp.asarray(False), zero, zero, zero)
    # until the direction's step is settled on a converged line solve
    g, phi, *_ = jax.lax.while_loop(
        lambda x: (x[0] < SLIDE_ITERATIONS) & (x[1][5] | (x[1][4] > _settled(dtype))),
        lambda x: (x[0] + 1, trip(x[0], x[1])), (jnp.zeros((), jnp.int32), start))[1]
    c = direction(g)                                          # the last direction's line solve
    blo, bhi = _bracket(q, weights, c, half)
    phi, _, _, _ = _line_solve(q, weights, c, size, jnp.clip(phi, blo, bhi), blo, bhi,
                               INNER_ITERATIONS, 4.0, _settled(dtype))

    g, w, _ = _polish(jnp.asarray(True), q, weights, d, scale, sigma, m, g, jnp.tan(phi) / size,
                      size, POLISH_ITERATIONS)
    return _smooth_twist(points, weights, d, e, pr, g, w)


def _smooth_twist(points, weights, d, e, pr, g, w):
    """The twist of the sliding point ``(g, w)`` (``|v_r| = 1``) and its ``D``
    on the plane ``<v_r, e> = 1`` (``inf`` where ``v_r`` does not advance along ``e``)."""
    c = jnp.cos(g) * d + jnp.sin(g) * _perp(d)
    V = jnp.concatenate([c - w * pr, w[None]])
    ce = jnp.dot(c, e)
    D = jnp.where(ce > 0, dissipation(points, weights, V) / jnp.where(ce > 0, ce, 1.0), jnp.inf)
    return V, D


def _setup(points, weights, r, d, mu_f):
    points = jnp.asarray(points)
    dtype = points.dtype
    weights = jnp.asarray(weights, dtype)
    r = jnp.asarray(r, dtype)
    d = jnp.asarray(d, dtype)
    mu = jnp.asarray(mu_f, dtype)
    half = jnp.asarray(0.5 * jnp.pi, dtype) * (1.0 - 64 * jnp.finfo(dtype).eps)
    size = jnp.maximum(jnp.max(jnp.linalg.norm(points - r, axis=-1)), jnp.finfo(dtype).tiny)
    return points, weights, r, d, mu, half, size, _perp(points - r)


def _mode(points, weights, r, d, mu, om):
    """From the sticking rate ``om``: the sticking twist, its force, whether the
    contact slides, and the friction cone's edge ``(sigma, m, e)``."""
    tiny = jnp.finfo(points.dtype).tiny
    t = _perp(d)
    V_st = jnp.concatenate([d - om * _perp(r), om[None]])
    a = _velocities(points, V_st)
    f = jnp.sum(weights[:, None] * a / jnp.maximum(jnp.linalg.norm(a, axis=-1), tiny)[:, None], 0)
    fn, ft = jnp.dot(f, d), jnp.dot(f, t)
    sliding = jnp.isfinite(mu) & (jnp.abs(ft) > mu * fn)
    sigma = jnp.where(ft >= 0, 1.0, -1.0).astype(points.dtype)
    m = jnp.where(jnp.isfinite(mu), mu, 0.0)
    return V_st, f, sliding, sigma, m, d + sigma * m * t


def _motion(points, weights, r, d, V_st, f, sliding, e, kinks, V_s, D_s):
    """The motion from the sticking twist, the kinks and the smooth sliding
    point: of the smooth point and the kinks, the lowest ``D`` on the plane
    (an optimal kink is the minimum; a smooth optimum within a hair of a kink
    that the solve did not resolve loses to that kink's twist).  Returns
    ``(Motion, the sliding twist with |v_r| = 1)``."""
    optimal, feasible, Dk, Vk = kinks
    pr = _perp(r)
    Dk = jnp.where(optimal, -jnp.inf, jnp.where(feasible, Dk, jnp.inf))
    j = jnp.argmin(Dk)
    V_u = jnp.where(Dk[j] < D_s, Vk[j], V_s)
    vr_u = V_u[:2] + V_u[2] * pr
    V_sl = V_u / jnp.dot(vr_u, d)
    V = jnp.where(sliding, V_sl, V_st)
    vr = V[:2] + V[2] * pr
    # sliding: the force is lambda e, lambda from the power balance D(V) = <f, v_r>
    # (exact also at a kink, where the resting point's friction is indeterminate)
    f_sl = e * dissipation(points, weights, V_sl) / jnp.dot(e, V_sl[:2] + V_sl[2] * pr)
    f = jnp.where(sliding, f_sl, f)
    motion = Motion(v=V[:2], omega=V[2], slip=jnp.where(sliding, jnp.dot(vr, _perp(d)), 0.0),
                    sliding=sliding, force=f)
    return motion, V_u / jnp.linalg.norm(vr_u)


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
    points, weights, r, d, mu, half, size, q = _setup(points, weights, r, d, mu_f)
    om = _stick(q, weights, d, size, half)
    V_st, f, sliding, sigma, m, e = _mode(points, weights, r, d, mu, om)
    kinks = _kinks(points, weights, r, d, e, size, kink_base(points, weights))
    V_s, D_s = _slide(points, weights, r, d, q, e, sigma, m, size, half, om)
    return _motion(points, weights, r, d, V_st, f, sliding, e, kinks, V_s, D_s)[0]


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class Warm:
    """Where :func:`warm_motion` starts: the previous motion's solution (a JAX
    pytree).  ``omega``: its sticking rate (rad/m); ``g``, ``w``: its sliding
    twist as the direction of ``v_r`` from ``d`` (rad) and the rotation rate at
    ``|v_r| = 1`` (rad/m); ``sigma``: the side of the cone it slid on (+-1, 0: none)."""

    omega: jax.Array
    g: jax.Array
    w: jax.Array
    sigma: jax.Array


def _warm_of(V_u, d, r, om, sigma, sliding):
    vr = V_u[:2] + V_u[2] * _perp(r)
    g = jnp.arctan2(jnp.dot(vr, _perp(d)), jnp.dot(vr, d))
    return Warm(omega=om, g=g, w=V_u[2], sigma=jnp.where(sliding, sigma, 0.0))


#: sticking line-solve iterations from a warm start: ``(few, many)`` for a
#: support of at most / more than ``MANY_POINTS`` points (a line that passes many
#: points' rests takes more).  Share of a pivot's nodes not converged warm, the
#: nice-stable pentagon's random pushes: rigid corners 0.17 % at 6 (10 costs 15 %
#: more time for nothing); a ring of 29 points 4.5 % at 6, 0.03 % at 10; a
#: uniform pad of 30, 1.6 % -> 0.9 %
WARM_STICK_ITERATIONS = (6, 10)
MANY_POINTS = 8
#: two-dimensional Newton steps on the sliding conditions from a warm start
#: (with :func:`_polish`'s halving): share of the nodes not converged warm, the
#: nice-stable pentagon's 7-push plan, 1,024 draws (December 2026): a uniform pad
#: of 25 feet 10 % without halving at 4, 2.3 % at 4, 0.46 % at 8, 0.12 % at 12;
#: rigid corners 0.44 % -> 0.10 % at 12 (``bench/robustness.py``'s figures in
#: :mod:`kernels.quasistatic_points`)
WARM_SLIDE_ITERATIONS = 12


def first_start(points, weights, r, d) -> "Warm":
    """A :class:`Warm` start with no motion solved before: the sticking rate's
    one Weiszfeld step, no sliding (arguments as :func:`push_motion`)."""
    points = jnp.asarray(points)
    dtype = points.dtype
    q = _perp(points - jnp.asarray(r, dtype))
    om = _weiszfeld(q, jnp.asarray(weights, dtype), jnp.asarray(d, dtype))
    zero = jnp.zeros((), dtype)
    return Warm(omega=om, g=zero, w=zero, sigma=zero)


def warm_motion(points, weights, r, d, mu_f, start: Warm, base=None):
    """:func:`push_motion` started from a nearby motion's solution: for a
    sequence of contacts ``(r, d)`` that changes little from one to the next
    (a pivot's quadrature nodes), Newton's method converges in a few steps where
    the cold solve brackets from scratch.

    The sticking rate takes ``WARM_STICK_ITERATIONS`` safeguarded line-solve
    steps from ``start.omega``; the smooth sliding point ``WARM_SLIDE_ITERATIONS``
    two-dimensional Newton steps from ``(start.g, start.w)`` (from the sticking
    twist when the start did not slide on the same side).  The result is the
    cold solve's wherever it says ``converged``: the line solve's last step at
    ``0.1 sqrt(eps)`` in ``atan(w L)``, and, sliding with no optimal kink, both
    sliding conditions at ``sqrt(eps)`` (the point is then the convex problem's
    unique stationary point on the plane); elsewhere the caller solves cold.

    Returns ``(Motion, Warm, converged)``; arguments as :func:`push_motion`,
    ``base``: :func:`kink_base` of the support, if the caller has it.
    """
    points, weights, r, d, mu, half, size, q = _setup(points, weights, r, d, mu_f)
    dtype = points.dtype
    tiny, eps = jnp.finfo(dtype).tiny, jnp.finfo(dtype).eps
    if base is None:
        base = kink_base(points, weights)
    lo, hi = _bracket(q, weights, d, half)
    phi0 = jnp.clip(jnp.arctan(start.omega * size), lo, hi)
    iters = WARM_STICK_ITERATIONS[int(points.shape[0] > MANY_POINTS)]
    phi, _, _, last = _line_solve(q, weights, d, size, phi0, lo, hi, iters, 4.0,
                                  _settled(dtype))
    om = jnp.tan(phi) / size
    stuck = last <= _settled(dtype)
    V_st, f, sliding, sigma, m, e = _mode(points, weights, r, d, mu, om)
    kinks = _kinks(points, weights, r, d, e, size, base)
    same = start.sigma == sigma
    g0 = jnp.where(same, start.g, 0.0)
    w0 = jnp.where(same, start.w, om)
    scale = jnp.maximum(jnp.sum(weights * jnp.sqrt(jnp.sum(q * q, -1))), tiny)
    g, w, F = _warm_polish(sliding & ~jnp.any(kinks[0]), q, weights, d, scale, sigma, m,
                           g0, w0, size)
    V_s, D_s = _smooth_twist(points, weights, d, e, _perp(r), g, w)
    inside = (g * sigma <= 0) & (jnp.abs(g) < half) & jnp.isfinite(D_s)
    smooth = inside & (jnp.max(jnp.abs(F)) <= jnp.sqrt(eps))
    converged = stuck & (~sliding | jnp.any(kinks[0]) | smooth)
    motion, V_u = _motion(points, weights, r, d, V_st, f, sliding, e, kinks, V_s, D_s)
    return motion, _warm_of(V_u, d, r, om, sigma, sliding), converged
