"""Configurations along tumble plans and random tumble walks, replayed with the
exact JAX kernel in float64 (:func:`kernels.tumble.replay_trajectory`).

Configurations are ``(x, y, theta, face)``: ``face`` on the plane, its frame
at world ``(x, y)`` (metres) with heading ``theta`` (radians, CCW positive).
"""
from __future__ import annotations

import warnings

import numpy as np

from kernels import PartWarning, Polyhedron, make_polyhedron, float64

__all__ = ["plan_trajectory", "sample_reached_positions", "quiet_polyhedron"]


def quiet_polyhedron(vertices, com=None, tau_v: float = 0.0) -> Polyhedron:
    """:func:`kernels.polyhedron.make_polyhedron` with its :class:`PartWarning`
    silenced (for a part the caller has already been warned about); ``tau_v``
    (m): its faces at that tolerance, as the planner takes them."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PartWarning)
        return make_polyhedron(np.asarray(vertices, dtype=float),
                               None if com is None else np.asarray(com, dtype=float),
                               tau_v=float(tau_v))


@float64
def plan_trajectory(plan):
    """Replay a plan's tumbles from ``plan.start`` with the exact kernel.

    ``plan`` is a :class:`~planning.tumbling.plan.TumblePlan` (or anything
    with ``vertices``, ``com``, ``start`` and ``tumbles`` whose items have a
    ``face``; its ``tau_v``, if any, takes the faces at that tolerance).
    Returns ``(poly, configs, ok)``: the part, an (L+1, 4) float array of
    ``(x, y, theta, face)`` from the start through every tumble, and whether
    every tumble was valid.
    """
    import jax.numpy as jnp

    from kernels import make_config, replay_trajectory

    poly = quiet_polyhedron(plan.vertices, plan.com, getattr(plan, "tau_v", 0.0))
    geom = poly.geometry()
    start = tuple(plan.start)
    seq = [int(t.face) for t in plan.tumbles]
    rows = [(float(start[0]), float(start[1]), float(start[2]), int(start[3]))]
    ok = True
    if seq:
        cfg = make_config(*start[:3], int(start[3]), dtype=geom.dtype)
        _, okj, traj = replay_trajectory(geom, cfg, jnp.asarray(seq, dtype=jnp.int32))
        ok = bool(okj)
        xy = np.asarray(traj.xy, dtype=float)
        th = np.asarray(traj.theta, dtype=float)
        fc = np.asarray(traj.face)
        rows += [(xy[i, 0], xy[i, 1], th[i], int(fc[i])) for i in range(len(seq))]
    return poly, np.array(rows, dtype=float), ok


@float64
def sample_reached_positions(poly: Polyhedron, root: int, radius: float, n_walks: int = 1000,
                             seed: int = 0) -> np.ndarray:
    """Positions of face ``root``'s frame, any heading, reached by random tumble walks.

    ``n_walks`` seeded random walks from ``(0, 0, 0, root)`` (each step lands
    a uniformly chosen neighbour), replayed with the exact kernel
    (``jax.vmap(replay_trajectory)``, float64); every configuration with
    ``root`` on the plane and within ``radius`` (metres) of the start
    contributes its ``(x, y)``.  Walk length grows with ``radius`` (about
    ``4 (radius / face size)^2``, 20..400 tumbles).  Returns an (n, 2) array
    in the root face's frame (the start included).
    """
    import jax
    import jax.numpy as jnp

    from kernels import make_config, replay_trajectory

    F = poly.n_faces
    sizes = [len(poly.neighbors(f)) for f in range(F)]
    K = max(sizes)
    table = np.array([list(poly.neighbors(f)) + [-1] * (K - len(poly.neighbors(f)))
                      for f in range(F)], dtype=np.int32)
    deg = np.array(sizes)
    step = max(float(np.max(np.linalg.norm(q, axis=1))) for q in poly.face_corners_2d)
    L = int(np.clip(4.0 * (radius / step) ** 2, 20, 400)) if step > 0 else 20
    rng = np.random.default_rng(seed)
    seqs = np.empty((n_walks, L), dtype=np.int32)
    cur = np.full(n_walks, int(root))
    for t in range(L):
        pick = np.minimum((rng.uniform(size=n_walks) * deg[cur]).astype(int), deg[cur] - 1)
        cur = table[cur, pick]
        seqs[:, t] = cur
    geom = poly.geometry()
    start = make_config(0.0, 0.0, 0.0, int(root), dtype=geom.dtype)
    _, _, traj = jax.vmap(replay_trajectory, in_axes=(None, None, 0))(geom, start, jnp.asarray(seqs))
    xy = np.asarray(traj.xy, dtype=float).reshape(-1, 2)
    face = np.asarray(traj.face).reshape(-1)
    keep = (face == int(root)) & (np.linalg.norm(xy, axis=1) <= radius)
    return np.concatenate([np.zeros((1, 2)), xy[keep]])
