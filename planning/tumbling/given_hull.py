"""A plan on a part's faces at its tolerance, replayed on its hull as given.

With ``tau_v > 0`` the planner takes the part's faces at that tolerance
(:func:`kernels.polyhedron.make_polyhedron` with ``tau_v``): triangles of the
hull that are coplanar within it are one face, so that noise below the
tolerance neither splits nor renumbers faces.  The part as given may still
have those faces split along creases (bent by at most the merge distance).
:class:`GivenHull` replays a plan on that hull: each tumble about a face's
edge first rocks the part over the creases inside the face on the plane
(shortest path among its pieces) onto the piece that holds the edge, then
tumbles across it onto the piece of the next face; the reached configuration
is read in the goal face's frame at the tolerance.  A plan is only ``solved``
when both replays land within eps (:mod:`planning.tumbling.planner`).

Configurations ``(x, y, theta, face)``: the face on the plane, its frame at
world ``(x, y)`` (metres) with heading ``theta`` (radians).
"""
from __future__ import annotations

import cmath
import math
from collections import deque
from typing import Optional, Sequence

import numpy as np

from kernels import Polyhedron

__all__ = ["GivenHull"]

#: A piece of the hull as given belongs to the face at tolerance whose plane
#: its corners are nearest to; farther than this many times the merge
#: distance, the hulls do not correspond and the replay is refused.
OWNER_SLACK = 4.0


def _frame_in(Pa: Polyhedron, fa: int, Pb: Polyhedron, fb: int) -> tuple[float, complex]:
    """Planar pose ``(angle, origin)`` of face ``fb``'s frame (of ``Pb``) in face
    ``fa``'s frame (of ``Pa``), the two faces nearly coplanar (same body frame)."""
    Ra = Pa.face_rotations[fa]
    q = Ra @ (Pb.face_origins[fb] - Pa.face_origins[fa])
    x = Ra @ Pb.face_rotations[fb][0]
    return math.atan2(x[1], x[0]), complex(q[0], q[1])


def _convert(cfg, pose: tuple[float, complex]) -> tuple[float, float, float]:
    """World ``(x, y, theta)`` of a frame at ``pose`` in the frame placed at ``cfg``."""
    ang, q = pose
    z = complex(cfg[0], cfg[1]) + cmath.exp(1j * cfg[2]) * q
    return z.real, z.imag, float(cfg[2]) + ang


class GivenHull:
    """The correspondence between a part's faces at its tolerance (``P``) and
    its hull as given (``P0``, the same vertices and centre of mass).

    Args:
      P: the part with faces at the tolerance; P0: the part as given;
      merge_distance: the distance (m) within which ``P`` merged faces.

    Attributes: ``owner`` (per face of ``P0`` the face of ``P`` it is a piece
    of, or None when some piece has no face near enough), ``pieces`` (per face
    of ``P`` its pieces).
    """

    def __init__(self, P: Polyhedron, P0: Polyhedron, merge_distance: float):
        self.P, self.P0 = P, P0
        v = P0.vertices
        offsets = np.array([float(np.mean(v[list(c)] @ n)) for c, n in zip(P.face_cycles, P.normals)])
        owner = []
        for s, cyc in enumerate(P0.face_cycles):
            pts = v[list(cyc)]
            dist = np.max(np.abs(pts @ P.normals.T - offsets[None, :]), axis=0)
            dist[P.normals @ P0.normals[s] <= 0.0] = np.inf
            f = int(np.argmin(dist))
            owner.append(f if dist[f] <= OWNER_SLACK * merge_distance + 1e-12 else None)
        self.owner = None if any(o is None for o in owner) else tuple(owner)
        self.pieces = {f: [] for f in range(P.n_faces)}
        for s, f in enumerate(owner):
            if f is not None:
                self.pieces[f].append(s)

    def _rock(self, f: int, cur: int, targets: set) -> Optional[list]:
        """Shortest path of pieces of face ``f`` from piece ``cur`` to one in
        ``targets`` (excluding ``cur``), over creases inside ``f``."""
        if cur in targets:
            return []
        nbr = self.P0.neighbors
        prev = {cur: None}
        queue = deque([cur])
        while queue:
            s = queue.popleft()
            for t in nbr(s):
                if t in prev or self.owner[t] != f:
                    continue
                prev[t] = s
                if t in targets:
                    path = [t]
                    while prev[path[-1]] != cur:
                        path.append(prev[path[-1]])
                    return path[::-1]
                queue.append(t)
        return None

    def word(self, start_face: int, word: Sequence[int]) -> Optional[tuple[int, tuple]]:
        """``(start piece, faces of P0)``: the plan ``word`` (faces of ``P``
        from ``start_face``) on the hull as given, rocks included; None when
        the hulls do not correspond."""
        if self.owner is None:
            return None
        nbr = self.P0.neighbors
        f, cur, out = int(start_face), None, []
        for g in word:
            g = int(g)
            across = {s: [t for t in nbr(s) if self.owner[t] == g] for s in self.pieces[f]}
            holders = {s for s, ts in across.items() if ts}
            if not holders:
                return None
            if cur is None:  # the part starts on the piece that holds the first edge
                cur = min(holders)
                start = cur
            path = self._rock(f, cur, holders)
            if path is None:
                return None
            out.extend(path)
            s = path[-1] if path else cur
            cur = min(across[s])
            out.append(cur)
            f = g
        if cur is None:
            start = cur = min(self.pieces[f]) if self.pieces[f] else None
            if cur is None:
                return None
        return start, tuple(out)

    def to_given(self, cfg, piece: int) -> tuple:
        """Configuration ``cfg`` (a face of ``P``) as the same pose of ``piece``."""
        x, y, th = _convert(cfg, _frame_in(self.P, int(cfg[3]), self.P0, piece))
        return (x, y, th, piece)

    def from_given(self, cfg, face: int) -> tuple:
        """Configuration ``cfg`` (a piece of ``P0`` on the plane) read in the
        frame of ``face`` of ``P``."""
        x, y, th = _convert(cfg, _frame_in(self.P0, int(cfg[3]), self.P, face))
        return (x, y, th, face)
