"""The plane development of a polyhedron and its transit paths (Marigo-Bicchi
Sec. III, steps 1-2), and face footprints on the plane.

* :func:`transit_paths`: breadth-first words ``L_f`` from the root face to
  every face (neighbours in increasing face number, so ties go to the smaller
  face), the paper's transit paths;
* :func:`development`: the effect of every ``L_f`` (numpy motion algebra,
  :class:`~planning.tumbling.motions.TumbleTable`): the pose of face ``f``'s
  copy in the development, in the root face's frame at ``(0, 0, 0)``;
* :func:`development_poses`: the same development built tumble by tumble with
  the exact JAX kernel (:func:`kernels.tumble.tumble`), neighbours in edge-slot
  order (an independent construction; the figures draw it);
* :func:`face_footprint`: world corners of a face lying on the plane at a
  planar pose.

Units: metres, radians (CCW positive).  A pose ``(x, y, theta)`` puts the
face's frame at world ``(x, y)`` with heading ``theta``; a face-frame point
``q`` is at ``R(theta) q + (x, y)``.
"""
from __future__ import annotations

from collections import deque
from typing import Mapping

import numpy as np

from kernels import rot2_np, wrap_angle_np, Polyhedron, float64
from planning.tumbling.motions import Motion, TumbleTable

__all__ = ["transit_paths", "development", "development_poses", "face_footprint", "pose3"]


def transit_paths(table: TumbleTable, root: int) -> dict[int, tuple]:
    """Breadth-first transit paths ``L_f`` (words of landing faces) from face
    ``root`` to every face; ``L_root = ()``.  Neighbours are visited in
    increasing face number, so among shortest paths the one through smaller
    face numbers wins."""
    parent = {root: None}
    order = [root]
    dq = deque([root])
    while dq:
        f = dq.popleft()
        for g in sorted(table.neighbors[f]):
            if g not in parent:
                parent[g] = f
                order.append(g)
                dq.append(g)
    paths = {}
    for f in order:
        w = []
        g = f
        while parent[g] is not None:
            w.append(g)
            g = parent[g]
        paths[f] = tuple(reversed(w))
    return paths


def development(table: TumbleTable, root: int, paths: Mapping[int, tuple]
                ) -> tuple[dict[int, Motion], dict[int, tuple[float, float, float]]]:
    """The plane development rooted at ``root``: ``(motions, poses)`` with
    ``motions[f]`` the effect of ``L_f`` (unwrapped angle) and ``poses[f] =
    (x, y, theta)`` the same pose with theta wrapped to (-pi, pi] (metres,
    radians, in the root face's frame)."""
    motions = {f: table.word_motion(root, w) for f, w in paths.items()}
    poses = {f: (m.z.real, m.z.imag, float(wrap_angle_np(m.angle))) for f, m in motions.items()}
    return motions, poses


def face_footprint(poly: Polyhedron, face: int, pose) -> np.ndarray:
    """World corners (s, 2) of ``face`` lying on the plane at planar pose
    ``(x, y, theta)`` (metres, radians), in ``face_cycles[face]`` order."""
    q = np.asarray(poly.face_corners_2d[int(face)], dtype=float)
    return q @ rot2_np(float(pose[2])).T + np.asarray(pose[:2], dtype=float)


def pose3(p) -> tuple[float, float, float]:
    """``(x, y, theta)`` from a tuple/array (3 or 4 numbers), a mapping with
    keys x, y, theta, or a kernel configuration (``.xy``, ``.theta``)."""
    if hasattr(p, "xy") and hasattr(p, "theta"):
        xy = np.asarray(p.xy, dtype=float)
        return float(xy[0]), float(xy[1]), float(np.asarray(p.theta))
    if isinstance(p, Mapping):
        return float(p["x"]), float(p["y"]), float(p["theta"])
    a = [float(v) for v in list(p)[:3]]
    return a[0], a[1], a[2]


@float64
def development_poses(poly: Polyhedron, root: int = 0) -> tuple[dict, dict]:
    """Plane development rooted at face ``root``, built with the exact kernel.

    Breadth-first over the face-adjacency graph (neighbours in edge-slot
    order); each new face is placed by one elementary tumble of
    :func:`kernels.tumble.tumble` (float64) from its parent's copy, the root
    at ``(0, 0, 0)``.

    Returns ``(poses, parent)``: ``poses[f] = (x, y, theta)`` of face ``f``'s
    copy (metres, radians, root face frame), ``parent[f]`` the face it was
    unfolded from (``None`` for the root).  ValueError for a bad root.
    """
    from kernels import make_config, tumble

    root = int(root)
    if not 0 <= root < poly.n_faces:
        raise ValueError(f"root: face {root} does not exist; faces are 0..{poly.n_faces - 1}")
    geom = poly.geometry()
    poses = {root: (0.0, 0.0, 0.0)}
    parent: dict = {root: None}
    queue = deque([root])
    while queue:
        f = queue.popleft()
        cfg = make_config(*poses[f], f, dtype=geom.dtype)
        for g in poly.neighbors(f):
            if g in poses:
                continue
            new, ok = tumble(geom, cfg, g)
            if not bool(ok):  # pragma: no cover - neighbours are adjacent
                raise RuntimeError(f"faces {f} and {g} are not adjacent")
            poses[g] = pose3(new)
            parent[g] = f
            queue.append(g)
    return poses, parent
