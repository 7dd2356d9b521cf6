"""Plain-numpy oracle for tumbling a convex polyhedron (test reference only).

Written independently of ``kernels.tumble``: the part is carried as a full
3-D rigid pose (body -> world, ``p_w = Rw p_b + tw``) and each tumble is a
3-D rotation of the whole body about the world line through the shared edge,
by the angle that brings the landing face's outward normal to world -z.  The
configuration is then read off the landing face's frame.

Only the combinatorics (``face_cycles``) are taken from the polyhedron; the
face frames are recomputed here from their definition with plain loops.
"""
from __future__ import annotations

import math

import numpy as np


def _unit(a):
    return a / np.linalg.norm(a)


class Frames:
    """Face frames from the definition (Newell normal through the corners' mean;
    origin = com projected; x along the first cycle edge; z inward)."""

    def __init__(self, vertices, com, face_cycles):
        self.v = np.asarray(vertices, dtype=float)
        self.com = np.asarray(com, dtype=float)
        self.cycles = [list(c) for c in face_cycles]
        self.R = []
        self.o = []
        self.n = []
        for cyc in self.cycles:
            pts = self.v[cyc]
            nx = ny = nz = 0.0
            s = len(pts)
            for i in range(s):
                x0, y0, z0 = pts[i]
                x1, y1, z1 = pts[(i + 1) % s]
                nx += (y0 - y1) * (z0 + z1)
                ny += (z0 - z1) * (x0 + x1)
                nz += (x0 - x1) * (y0 + y1)
            n = _unit(np.array([nx, ny, nz]))
            d = float(np.mean(pts @ n))
            o = self.com - (float(self.com @ n) - d) * n
            e = pts[1] - pts[0]
            xa = _unit(e - (e @ n) * n)
            za = -n
            ya = np.cross(za, xa)
            self.R.append(np.array([xa, ya, za]))
            self.o.append(o)
            self.n.append(n)

    def shared_edge(self, f, g):
        common = set(self.cycles[f]) & set(self.cycles[g])
        if len(common) != 2 or f == g:
            raise ValueError(f"faces {f} and {g} are not adjacent")
        return sorted(common)


def _rz(t):
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _axis_angle(u, a):
    u = _unit(u)
    K = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    return np.eye(3) + math.sin(a) * K + (1 - math.cos(a)) * (K @ K)


def pose_from_config(fr: Frames, x, y, theta, face):
    """3-D body pose (Rw, tw) of configuration (x, y, theta, face)."""
    Rz = _rz(theta)
    Rw = Rz @ fr.R[face]
    tw = -Rw @ fr.o[face] + np.array([x, y, 0.0])
    return Rw, tw


def config_from_pose(fr: Frames, Rw, tw, face):
    """Read (x, y, theta) of ``face``'s frame off a 3-D pose."""
    M = Rw @ fr.R[face].T  # face frame -> world rotation, should be Rz(theta)
    theta = math.atan2(M[1, 0], M[0, 0])
    o_w = Rw @ fr.o[face] + tw
    return float(o_w[0]), float(o_w[1]), theta


def tumble_pose(fr: Frames, Rw, tw, face, next_face):
    """Rotate the body about the world edge shared with ``next_face`` until it lands."""
    a, b = fr.shared_edge(face, next_face)
    pa = Rw @ fr.v[a] + tw
    pb = Rw @ fr.v[b] + tw
    u = _unit(pb - pa)
    n_w = Rw @ fr.n[next_face]  # outward normal of the landing face, world
    target = np.array([0.0, 0.0, -1.0])
    # components perpendicular to the axis; the angle that takes n_w to target
    n_p = _unit(n_w - (n_w @ u) * u)
    t_p = _unit(target - (target @ u) * u)
    ang = math.atan2(np.cross(n_p, t_p) @ u, n_p @ t_p)
    Q = _axis_angle(u, ang)
    Rw2 = Q @ Rw
    tw2 = Q @ (tw - pa) + pa
    return Rw2, tw2


def replay(vertices, com, face_cycles, start, seq, check_landing=True):
    """Replay a face sequence; ``start = (x, y, theta, face)``; ``-1`` = no-op.

    Returns the final (x, y, theta, face) and the list of intermediate configs.
    With ``check_landing`` asserts that each landing face is on z = 0 and the
    body is above the plane.
    """
    fr = Frames(vertices, com, face_cycles)
    x, y, th, f = start
    Rw, tw = pose_from_config(fr, x, y, th, f)
    traj = []
    for g in seq:
        g = int(g)
        if g < 0:
            traj.append(config_from_pose(fr, Rw, tw, f) + (f,))
            continue
        Rw, tw = tumble_pose(fr, Rw, tw, f, g)
        f = g
        if check_landing:
            zc = (fr.v[fr.cycles[f]] @ Rw.T + tw)[:, 2]
            scale = np.ptp(fr.v, axis=0).max()
            assert np.all(np.abs(zc) < 1e-9 * scale), zc
            hv = sorted({i for c in fr.cycles for i in c})
            zall = (fr.v[hv] @ Rw.T + tw)[:, 2]
            assert np.all(zall > -1e-9 * scale), zall
        traj.append(config_from_pose(fr, Rw, tw, f) + (f,))
    final = config_from_pose(fr, Rw, tw, f) + (f,)
    return final, traj
