"""Exact kinematics of tumbling a convex polyhedron on a plane (pure JAX).

An *elementary tumble* (Marigo & Bicchi) rotates the part about an edge of the
face that lies on the plane until the adjacent face across that edge lands.
The edge does not move in the world, so the landing face's planar pose is the
plane development: the proper rigid 2-D motion that maps the edge's two
corners, in the landing face's frame, onto their world positions computed
from the current pose.

Frames and units (see :mod:`kernels.polyhedron` for the face frames): metres,
radians, angles CCW positive seen from above, wrapped to (-pi, pi].  A
configuration :class:`TumbleConfig` ``(xy, theta, face)`` says that ``face``
lies on the plane and a point ``q`` given in that face's frame (2-D, the face
frame's x and y) is at world ``R(theta) q + xy``.

Everything here is pure JAX, unbatched, jit- and vmap-able; the float dtype is
that of the :class:`~kernels.polyhedron.TumbleGeometry` arrays (float32 or
float64).  To run one plan over many perturbed parts::

    geoms = jax.vmap(tumble_geometry, in_axes=(0, None, None))(V, com, topo)
    final, ok = jax.vmap(replay, in_axes=(0, None, None))(geoms, start, seq)
"""
from __future__ import annotations

import functools
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from kernels.planar import rot2, wrap_angle
from kernels.polyhedron import TumbleTopology
from kernels.tumble_geometry import TumbleGeometry

__all__ = [
    "TumbleConfig",
    "RigidMotion2D",
    "make_config",
    "edge_motion",
    "tumble",
    "replay",
    "replay_trajectory",
    "tumble_sequence_effect",
    "apply_effect",
    "compose_effects",
    "invert_effect",
]


class TumbleConfig(NamedTuple):
    """Configuration ``(x, y, theta, face)`` of a polyhedron on the plane.

    Attributes:
      xy: (2,) float, world position (metres) of the face frame's origin.
      theta: () float, world angle (rad, CCW, in (-pi, pi]) of the face
        frame's x-axis.
      face: () int32, the face on the plane (face number of the polyhedron).
    """

    xy: jax.Array
    theta: jax.Array
    face: jax.Array


class RigidMotion2D(NamedTuple):
    """A proper planar rigid motion ``q -> R(angle) q + translation``.

    Attributes:
      angle: () rad, CCW, in (-pi, pi].
      translation: (2,) metres.
      fixed_point: (2,) metres, the point the motion leaves fixed
        (``R c + t = c``); NaN when ``angle`` is (numerically) zero, i.e. for
        a pure translation.
    """

    angle: jax.Array
    translation: jax.Array
    fixed_point: jax.Array


def make_config(x, y, theta, face, dtype=None) -> TumbleConfig:
    """Build a :class:`TumbleConfig` (world ``x, y`` in metres, ``theta`` in rad,
    wrapped to (-pi, pi]); ``dtype`` defaults to JAX's default float (kernels
    cast the configuration to the geometry's dtype anyway)."""
    if dtype is None:
        dtype = jnp.result_type(float)
    return TumbleConfig(
        xy=jnp.asarray([x, y], dtype=dtype),
        theta=wrap_angle(jnp.asarray(theta, dtype=dtype)),
        face=jnp.asarray(face, dtype=jnp.int32),
    )


def _cast_config(geom: TumbleGeometry, config: TumbleConfig) -> TumbleConfig:
    dt = geom.corners_2d.dtype
    return TumbleConfig(
        xy=jnp.asarray(config.xy, dtype=dt),
        theta=jnp.asarray(config.theta, dtype=dt),
        face=jnp.asarray(config.face, dtype=jnp.int32),
    )


@functools.lru_cache(maxsize=256)
def _tables(topology: TumbleTopology):
    """Static index tables of a topology (cached), all (F, K) int32.

    ``nf[f, k]`` face across slot k of f (-1 pad); ``slot_b`` slot in f of the
    edge's second corner b (the first corner a is at slot k); in the landing
    face g the edge runs b -> a: ``g_slot_b`` / ``g_slot_a`` their slots in g.
    """
    nf = topology.next_face_array
    ns = topology.next_slot_array
    sizes = topology.face_sizes
    K = nf.shape[1]
    k = np.arange(K)[None, :]
    valid = nf >= 0
    slot_b = np.where(valid, (k + 1) % sizes[:, None], 0)
    g = np.where(valid, nf, 0)
    g_slot_b = np.where(valid, ns, 0)
    g_slot_a = np.where(valid, (ns + 1) % sizes[g], 0)
    return tuple(a.astype(np.int32) for a in (nf, slot_b, g_slot_a, g_slot_b))


def edge_motion(ca, cb, qa, qb):
    """The planar rigid motion of one elementary tumble, in the frame of the face
    on the plane: it maps the landing face's frame coordinates into the current
    face's, taking the shared edge's corners ``qa``, ``qb`` (landing face's
    frame) onto ``ca``, ``cb`` (current face's frame): the rotation from
    ``qb - qa`` to ``cb - ca``, the translation that matches the edge's
    midpoints (the plane development; exact for planar faces).  The one home of
    the tumble's kinematics: :func:`tumble` applies it to the edge's corners in
    the world (the landing face's new pose), the Monte-Carlo replay
    (:mod:`robustness.replay`) composes it with the slips.

    Args:
      ca, cb, qa, qb: (..., 2) corners, metres (any common leading shape).

    Returns:
      ``(c, s, tx, ty)``, each (...): ``q -> [[c, -s], [s, c]] q + (tx, ty)``.
    """
    dc, dq = cb - ca, qb - qa
    rc = dq[..., 0] * dc[..., 0] + dq[..., 1] * dc[..., 1]
    rs = dq[..., 0] * dc[..., 1] - dq[..., 1] * dc[..., 0]
    rn = jnp.sqrt(rc * rc + rs * rs)
    rn = jnp.where(rn > 0, rn, 1.0)       # a degenerate edge (an invalid step's gather): no NaN
    rc, rs = rc / rn, rs / rn
    mq = 0.5 * (qa + qb)
    mc = 0.5 * (ca + cb)
    tx = mc[..., 0] - (rc * mq[..., 0] - rs * mq[..., 1])
    ty = mc[..., 1] - (rs * mq[..., 0] + rc * mq[..., 1])
    return rc, rs, tx, ty


def _step(C, xy, theta, face, g, nf, slot_b, g_slot_a, g_slot_b):
    """One tumble on raw arrays; returns (xy, theta, face, ok)."""
    F = nf.shape[0]
    f = jnp.clip(face, 0, F - 1)
    row = nf[f]
    match = (row == g) & (g >= 0)
    found = jnp.any(match) & (face >= 0) & (face < F)
    k = jnp.argmax(match)
    gg = jnp.clip(g, 0, F - 1)
    ca = C[f, k]
    cb = C[f, slot_b[f, k]]
    qa = C[gg, g_slot_a[f, k]]
    qb = C[gg, g_slot_b[f, k]]
    Rt = rot2(theta)
    # the edge's corners in the world: the motion is then the landing face's new pose
    c, s, tx, ty = edge_motion(Rt @ ca + xy, Rt @ cb + xy, qa, qb)
    xy_new = jnp.stack([tx, ty])
    phi = jnp.arctan2(s, c)
    noop = g < 0
    keep = noop | ~found
    xy_out = jnp.where(keep, xy, xy_new)
    theta_out = jnp.where(keep, theta, wrap_angle(phi))
    face_out = jnp.where(keep, face, gg)
    return xy_out, theta_out, face_out, noop | found


_step_jit = jax.jit(_step)


@jax.jit
def _scan_core(C, xy, theta, face, seq, nf, slot_b, g_slot_a, g_slot_b):
    def body(carry, g):
        xy, theta, face, ok = carry
        xy, theta, face, ok1 = _step(C, xy, theta, face, g, nf, slot_b, g_slot_a, g_slot_b)
        return (xy, theta, face, ok & ok1), (xy, theta, face)

    (xy, theta, face, ok), (txy, tth, tf) = jax.lax.scan(
        body, (xy, theta, face, jnp.asarray(True)), seq
    )
    return TumbleConfig(xy, theta, face), ok, TumbleConfig(txy, tth, tf)


def tumble(geom: TumbleGeometry, config: TumbleConfig, next_face):
    """One elementary tumble from ``config`` onto face ``next_face``.

    The part rotates about the edge shared by ``config.face`` (on the plane)
    and ``next_face`` until ``next_face`` lands.  The new pose is the proper
    planar rigid motion taking that edge's two corners, in ``next_face``'s
    frame coordinates, onto their world positions under the current pose
    (least-squares: the edge midpoint is matched exactly and the edge
    direction aligned; for a part with planar faces both corners match
    exactly; for a perturbed part with slightly non-planar faces the two
    projected edge lengths can differ by a second-order amount).

    Args:
      geom: :class:`TumbleGeometry` (unbatched).
      config: current :class:`TumbleConfig` (world frame).
      next_face: () int, the face that lands.

    Returns:
      ``(new_config, ok)``.  ``ok`` is a bool scalar: False when
      ``next_face`` is not adjacent to ``config.face`` (this includes
      ``next_face == config.face`` and out-of-range face numbers); the
      configuration is then returned unchanged.  ``next_face < 0`` is a
      no-op with ``ok = True`` (padding).  Never raises under jit.
    """
    config = _cast_config(geom, config)
    xy, theta, face, ok = _step_jit(
        geom.corners_2d, config.xy, config.theta, config.face,
        jnp.asarray(next_face, dtype=jnp.int32), *_tables(geom.topology),
    )
    return TumbleConfig(xy, theta, face), ok


def _scan(geom, start_config, face_seq):
    start = _cast_config(geom, start_config)
    seq = jnp.asarray(face_seq, dtype=jnp.int32).reshape(-1)
    return _scan_core(
        geom.corners_2d, start.xy, start.theta, start.face, seq, *_tables(geom.topology)
    )


def replay(geom: TumbleGeometry, start_config: TumbleConfig, face_seq):
    """Replay a tumble plan (``lax.scan``), unbatched.

    Args:
      geom: :class:`TumbleGeometry` (unbatched; ``jax.vmap(replay,
        in_axes=(0, None, None))`` runs one plan over a batch of geometries).
      start_config: :class:`TumbleConfig`, world frame.
      face_seq: (L,) int, the faces that land, in order; ``-1`` entries are
        no-ops (padding, allowed anywhere).

    Returns:
      ``(final_config, ok)``; ``ok`` is False if any step was not a valid
      tumble (a face not adjacent to the one on the plane); such a step leaves
      the configuration unchanged and the replay goes on from there, so the
      final configuration is then meaningless.  Float dtype = that of
      ``geom``.  Compiled once per (shape, dtype), not per polyhedron.
    """
    final, ok, _ = _scan(geom, start_config, face_seq)
    return final, ok


def replay_trajectory(geom: TumbleGeometry, start_config: TumbleConfig, face_seq):
    """Like :func:`replay` but also returns the trajectory.

    Returns:
      ``(final_config, ok, trajectory)`` where ``trajectory`` is a
      :class:`TumbleConfig` of stacked arrays (``xy`` (L, 2), ``theta`` (L,),
      ``face`` (L,)), the configuration after each step (padding steps repeat
      the previous configuration).
    """
    return _scan(geom, start_config, face_seq)


def _fixed_point(angle, t):
    """Fixed point of q -> R(angle) q + t: c = (t + cot(angle/2) perp(t)) / 2."""
    half = 0.5 * angle
    s, c = jnp.sin(half), jnp.cos(half)
    eps = jnp.finfo(t.dtype).eps
    tiny = jnp.abs(s) <= 64.0 * eps
    cot = c / jnp.where(tiny, 1.0, s)
    perp = jnp.stack([-t[1], t[0]])
    fp = 0.5 * (t + cot * perp)
    return jnp.where(tiny, jnp.full_like(fp, jnp.nan), fp)


def _motion(angle, t) -> RigidMotion2D:
    angle = wrap_angle(angle)
    return RigidMotion2D(angle=angle, translation=t, fixed_point=_fixed_point(angle, t))


def tumble_sequence_effect(geom: TumbleGeometry, start_face, word):
    """The planar rigid motion produced by a closed word of tumbles.

    Args:
      geom: :class:`TumbleGeometry` (unbatched).
      start_face: () int, the face ``F`` on the plane before the word.
      word: (L,) int, the faces that land, in order (the convention of
        :func:`replay` and :mod:`planning.tumbling.words`: ``F`` itself is not part of
        the word), ending on ``F`` again, e.g. the paper's ``S_j`` without its
        leading ``j_1``; ``-1`` entries are no-op padding.

    Returns:
      ``(effect, ok)``.  ``effect`` is a :class:`RigidMotion2D` ``E``
      expressed in the frame of face ``F`` at the start of the word: starting
      from ``F``'s frame at the world origin with heading 0, the word ends with
      ``F``'s frame at ``E.translation`` with heading ``E.angle``.  For a
      start configuration with pose ``T_P`` (face frame -> world), the final
      pose is ``T_P o E`` (see :func:`apply_effect`); in world coordinates
      the part is rotated by ``E.angle`` about ``T_P(E.fixed_point)``.  ``ok``
      is False if a step is not a valid tumble or the word does not end on
      ``F``.
    """
    word = jnp.asarray(word, dtype=jnp.int32).reshape(-1)
    C = geom.corners_2d
    dt = C.dtype
    F = jnp.asarray(start_face, dtype=jnp.int32)
    final, ok, _ = _scan_core(
        C, jnp.zeros(2, dt), jnp.zeros((), dt), F, word, *_tables(geom.topology)
    )
    return _close_word(final.xy, final.theta, final.face, ok, F, geom.topology.n_faces)


@functools.partial(jax.jit, static_argnums=5)
def _close_word(xy, theta, face, ok, F, n_faces):
    ok = ok & (face == F) & (F >= 0) & (F < n_faces)
    return _motion(theta, xy), ok


@jax.jit
def apply_effect(effect: RigidMotion2D, config: TumbleConfig) -> TumbleConfig:
    """Configuration after executing a word with effect ``effect`` from ``config``.

    ``config.face`` must be the word's face ``F`` (unchecked); returns the pose
    ``T_P o E``: ``theta + angle`` and ``xy + R(theta) translation``.
    """
    dt = jnp.result_type(config.xy)
    t = jnp.asarray(effect.translation, dtype=dt)
    xy = config.xy + rot2(config.theta) @ t
    theta = wrap_angle(config.theta + jnp.asarray(effect.angle, dtype=dt))
    return TumbleConfig(xy=xy, theta=theta, face=config.face)


@jax.jit
def compose_effects(first: RigidMotion2D, second: RigidMotion2D) -> RigidMotion2D:
    """Effect of word ``first`` followed by word ``second`` (same face ``F``):
    ``E = E_first o E_second``, in ``F``'s frame at the start of ``first``."""
    t = first.translation + rot2(first.angle) @ second.translation
    return _motion(first.angle + second.angle, t)


@jax.jit
def invert_effect(effect: RigidMotion2D) -> RigidMotion2D:
    """Effect of the reversed word (the inverse motion ``E^-1``)."""
    t = -(rot2(-effect.angle) @ effect.translation)
    return _motion(-effect.angle, t)
