"""Exact rigid replay of normal fence pushes on a convex polygon.

The model is the paper's: quasi-static motion, a fence of unlimited length
moving in a constant direction ``d`` (the push is normal to the fence), no
slip between fence and part.  The fence starts touching the part (the
approach travel before contact is not part of the push distance).  While a
single vertex touches the fence the part rotates about it as it advances with
the fence; when an edge lands flush the push either becomes a pure
translation (stable edge) or the part goes on rotating about the edge's end
towards the foot of the centre of mass (unstable edge).  A *marginal* edge
(foot at one of its ends, :data:`kernels.polygon.MARGINAL_FOOT`) that lands
leaves the part balanced on that end with the centre of mass straight above
it, an unstable equilibrium without torque: the push translates on and ends
there, on a vertex, and the outcome names the edge (``marginal``).  The
rotation rate is the slowest one that quasi-static support friction allows
(see :func:`kernels.polygon.peshkin_distance`), so a push of at least the
Peshkin distance always completes and a shorter one may stop part-way.  The
final pose of a completed push does not depend on the rate: the contact vertex
advances exactly ``distance`` along ``d``.

The slowest rate is Peshkin's ``d beta / ds = rho sin(beta) / (a^2 + rho^2)``
(``a`` the part's radius about the centre of mass: any support pressure).  A
caller that knows more about the support passes ``rate_c``: the largest
limit-surface ratio ``c`` of the support (m), and the rate becomes the
quasi-static sticking rate at that ratio, ``rho sin(beta) / (c^2 + rho^2)``,
the slowest one for every ratio up to ``c`` and every fence friction
(:mod:`kernels.reorient` proves it).

This kernel runs on parts the plan was not made for: a perturbed part may land
on another edge, roll over an unstable edge, or stop mid-rotation; the outcome
says which.  All functions are pure and unbatched; lift them with ``jax.vmap``.
"""
from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

from kernels.planar import TWO_PI, cross2, mod_2pi, rot2, wrap_angle
from kernels.polygon import PolygonGeometry, peshkin_gain, peshkin_length


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class PushOutcome:
    """Result of replaying one push (a JAX pytree).

    Attributes:
      pose: (3,) final pose ``(x, y, theta)``: world position of the centre of
        mass (m) and body orientation (rad, wrapped to (-pi, pi]).
      edge: () hull edge index lying flush and stable on the fence at the end,
        -1 when the push ended on a vertex (incomplete rotation or divergence).
      complete: () bool, the push ended with a stable edge flush.
      rotation: () signed rotation of the part during the push (rad, CCW +).
      landings: () number of edges that landed flush during the push (an edge
        flush at the start does not land).
      marginal: () hull index of the marginal edge lying flush at the end (the
        push ended at its unstable equilibrium, ``edge`` -1), -1 otherwise.
      finished: () bool, the replay spent the whole distance.  False only
        when its pass limit ran out first (it cannot for a valid convex part
        and the default limit): then ``pose`` is where the replay stopped,
        not the push's end, and ``complete`` is False.
    """

    pose: jax.Array
    edge: jax.Array
    complete: jax.Array
    rotation: jax.Array
    landings: jax.Array
    marginal: jax.Array
    finished: jax.Array


def contact_vertex(geom: PolygonGeometry, phi):
    """Index of the vertex whose normal cone holds body-frame direction ``phi``
    (rad): the vertex that touches a fence lying on that side of the part.
    On an exact boundary the vertex after the edge is returned; near-ties left
    by rounding go to the nearest cone."""
    prev = jnp.roll(geom.nu, 1)
    a = mod_2pi(phi - prev)
    inside = a < geom.exterior
    score = jnp.where(inside, -1.0, jnp.minimum(a - geom.exterior, TWO_PI - a))
    return jnp.argmin(score)


def replay_push(geom: PolygonGeometry, pose, direction, distance, rate_c=None,
                max_passes: int | None = None) -> PushOutcome:
    """Replay one normal push exactly.

    Args:
      geom: the part (body frame).
      pose: (3,) start pose ``(x, y, theta)``, world frame (m, rad).
      direction: (2,) direction of the fence's motion, world frame (normalised here).
      distance: fence travel in contact with the part, m (>= 0).
      rate_c: optional largest limit-surface ratio of the support (m, > 0): the
        rotation runs at the sticking rate for that ratio instead of Peshkin's
        bound (module docstring); default the part's radius (Peshkin).
      max_passes: static bound on the loop's passes (each rotates to the next
        landing); default ``n + 2``, which always suffices for a convex part.
        A push that needs more is returned with ``finished = False``.

    Returns:
      :class:`PushOutcome`.

    Long (~90 lines): the loop body is one event-to-event pass (contact vertex,
    next landing, Peshkin distance, partial or full rotation) whose carried
    state must stay in one ``lax.while_loop`` scope.
    """
    n = geom.body.shape[0]
    dtype = geom.body.dtype
    pose = jnp.asarray(pose, dtype)
    d = jnp.asarray(direction, dtype)
    d = d / jnp.linalg.norm(d)
    ang_u = jnp.arctan2(-d[1], -d[0])  # world angle of the direction from the part to the fence
    rate_a = geom.radius if rate_c is None else jnp.asarray(rate_c, dtype)
    flush_tol = 1024.0 * jnp.finfo(dtype).eps   # rad: a landing this close is rounding of a flush start
    passes = n + 2 if max_passes is None else int(max_passes)

    def body(st):
        it, pos, theta, s_rem, flush, done, rot_tot, landings, final_edge = st
        flush_ok = flush >= 0
        fl = jnp.maximum(flush, 0)
        stable_now = flush_ok & geom.stable[fl]
        # a marginal edge flush: the centre of mass is above its end, no torque (equilibrium)
        marginal_now = flush_ok & geom.marginal[fl]
        # pivot: after an unstable edge landed, its endpoint towards the foot of the
        # centre of mass; otherwise the vertex whose normal cone holds the fence side.
        toward = jnp.where(geom.foot[fl] < 0.5, fl, (fl + 1) % n)
        phi_free = wrap_angle(ang_u - theta)
        k = jnp.where(flush_ok, toward, contact_vertex(geom, phi_free))
        phi0 = jnp.where(flush_ok, geom.nu[fl], phi_free)
        u = jnp.stack([jnp.cos(phi0), jnp.sin(phi0)])
        v = geom.body[k]
        cr = cross2(u, v)
        sigma = jnp.sign(cr)  # rotation sense of the part (CCW +)
        divergent = (sigma == 0) | marginal_now
        target = jnp.where(sigma < 0, k, (k - 1) % n)
        delta = jnp.where(sigma < 0, mod_2pi(geom.nu[target] - phi0), mod_2pi(phi0 - geom.nu[target]))
        # a normal cone is narrower than pi: a wrap past 2 pi is the target a rounding error behind
        delta = jnp.where(delta > jnp.pi, 0.0, delta)
        beta_a = jnp.arctan2(jnp.abs(cr), jnp.dot(u, v))
        beta_b = beta_a + delta
        c = jnp.linalg.norm(v)
        kk = peshkin_gain(rate_a, c)
        safe_a = jnp.where(divergent, 1.0, beta_a)
        s_need = peshkin_length(kk, safe_a, beta_b)
        s_need = jnp.where(divergent, jnp.inf, s_need)
        # a push of exactly the needed distance completes (relative rounding slack)
        full = s_rem >= s_need * (1.0 - 64.0 * jnp.finfo(dtype).eps)
        partial_rot = 2.0 * jnp.arctan(jnp.tan(0.5 * safe_a) * jnp.exp(s_rem / kk)) - safe_a
        rot = jnp.where(full, delta, jnp.where(divergent, 0.0, partial_rot))
        s_used = jnp.where(full, s_need, s_rem)
        theta_new = theta + sigma * rot
        vw = pos + rot2(theta) @ v
        pos_rot = vw + s_used * d - rot2(theta_new) @ v
        # landing on a stable edge: the rest of the push translates, in the same pass
        settles = full & geom.stable[target]
        pos_rot = pos_rot + jnp.where(settles, s_rem - s_used, 0.0) * d
        # translating branch (stable edge flush, or divergent equilibrium)
        translate = stable_now | divergent
        pos_tr = pos + s_rem * d
        active = ~done
        new_pos = jnp.where(active, jnp.where(translate, pos_tr, pos_rot), pos)
        new_theta = jnp.where(active & ~translate, theta_new, theta)
        new_s = jnp.where(active, jnp.where(translate | settles, 0.0, s_rem - s_used), s_rem)
        new_flush = jnp.where(active & ~translate, jnp.where(full, target, -1), flush)
        new_done = done | translate | ~full | settles
        new_rot = rot_tot + jnp.where(active & ~translate, sigma * rot, 0.0)
        # an edge already flush (no rotation left to it) was in contact from the start: no landing
        new_land = landings + jnp.where(active & ~translate & full & (delta > flush_tol), 1, 0)
        new_final = jnp.where(active, jnp.where(stable_now, fl, jnp.where(~translate & settles, target, -1)),
                              final_edge)
        return (it + 1, new_pos, new_theta, new_s, new_flush, new_done, new_rot, new_land, new_final)

    # Each pass rotates to the next landing (and translates on if it is a stable edge) or
    # finishes; a convex polygon lands at most n edges before a stable one, so n + 2 passes
    # always suffice.
    init = (jnp.asarray(0), pose[:2], pose[2], jnp.asarray(distance, dtype), jnp.asarray(-1),
            jnp.asarray(False), jnp.asarray(0.0, dtype), jnp.asarray(0), jnp.asarray(-1))
    _, pos, theta, _, flush, done, rot_tot, landings, final_edge = jax.lax.while_loop(
        lambda st: (~st[5]) & (st[0] < passes), body, init)
    out_pose = jnp.concatenate([pos, wrap_angle(theta)[None]])
    final_edge = jnp.where(done, final_edge, -1)
    # the last edge that lay flush is still flush when the push ended translating on it
    marginal = jnp.where(done & (final_edge < 0) & (flush >= 0) & geom.marginal[jnp.maximum(flush, 0)],
                         flush, -1)
    return PushOutcome(pose=out_pose, edge=final_edge, complete=final_edge >= 0,
                       rotation=rot_tot, landings=landings, marginal=marginal, finished=done)


def replay_pushes(geom: PolygonGeometry, pose, directions, distances, rate_c=None):
    """Replay a sequence of pushes with ``lax.scan``.

    Args:
      geom: the part.
      pose: (3,) start pose, world frame.
      directions: (P, 2) fence motion directions, world frame.
      distances: (P,) push distances, m; a zero distance is a no-op (padding).
      rate_c: as :func:`replay_push` (one value for the whole sequence).

    Returns:
      ``(final_pose, outcomes)`` where ``outcomes`` is a :class:`PushOutcome`
      with a leading axis of length P (the pose after each push).
    """
    def step(p, xs):
        dvec, dist = xs
        out = replay_push(geom, p, dvec, dist, rate_c)
        return out.pose, out

    final, outs = jax.lax.scan(step, jnp.asarray(pose, geom.body.dtype), (directions, distances))
    return final, outs
