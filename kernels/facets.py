"""Maximal planar faces of a convex hull (host side, numpy + scipy): Qhull's
triangles merged into faces within a tolerance relative to the part's size,
collinear corners dropped, the face cycles checked to close up, and the
volume centroid.  Used by :func:`kernels.polyhedron.make_polyhedron`.

A face cycle lists caller vertex indices counter-clockwise seen from outside
the part, starting at its smallest index.  Units: metres.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from kernels.errors import PartError

def as_points(vertices) -> np.ndarray:
    try:
        v = np.asarray(vertices, dtype=float)
    except (TypeError, ValueError) as exc:
        raise PartError(
            f"vertices: could not be read as an (m, 3) array of floats ({exc}); "
            "give a list of [x, y, z] triples in metres"
        ) from None
    if v.ndim != 2 or v.shape[1] != 3:
        raise PartError(
            f"vertices: expected an (m, 3) array of [x, y, z] points in metres, "
            f"got shape {v.shape}; give one [x, y, z] triple per vertex"
        )
    bad = np.flatnonzero(~np.all(np.isfinite(v), axis=1))
    if bad.size:
        raise PartError(
            f"vertices: rows {bad.tolist()} are not finite (NaN or inf); "
            "replace them by finite coordinates in metres"
        )
    if v.shape[0] < 4:
        raise PartError(
            f"vertices: a polyhedron needs at least 4 non-coplanar points, got "
            f"{v.shape[0]}; add points (or use a polygon part, kind: polygon)"
        )
    return v


def diameter(v: np.ndarray) -> float:
    return float(np.max(np.linalg.norm(v - v.mean(axis=0), axis=1))) * 2.0


def extent(hull_points: np.ndarray) -> float:
    """Largest distance between two hull vertices (the part's largest extent, m)."""
    best = 0.0
    for i in range(0, len(hull_points), 256):  # chunks: O(m) memory
        d = hull_points[i:i + 256, None, :] - hull_points[None, :, :]
        best = max(best, float(np.max(np.einsum("ijk,ijk->ij", d, d))))
    return math.sqrt(best)


def check_not_flat(v: np.ndarray) -> None:
    centred = v - v.mean(axis=0)
    s = np.linalg.svd(centred, compute_uv=False)
    if s[0] == 0.0 or s[2] <= 1e-10 * s[0]:
        raise PartError(
            "vertices: all points are coplanar (or collinear / coincident), so "
            "they span no volume; a polyhedron needs at least 4 non-coplanar "
            "points (for a flat part use kind: polygon)"
        )


#: Faces at a part's tolerance: with every vertex coordinate known to
#: +-tau_v (metres), each corner of a planar face may move by sqrt(3) tau_v,
#: and a quadrilateral's fourth corner then lies within about
#: (1 + 3) sqrt(3) tau_v ~ 6.9 tau_v of the plane of its other three (an
#: affine combination with coefficients summing to 3 in absolute value); so
#: triangles whose corners lie within ``TOLERANCE_MERGE_FACTOR * tau_v`` of a
#: common plane are one face at that tolerance (the same argument as
#: :func:`robustness.hulls.face_merge_tol`).
TOLERANCE_MERGE_FACTOR = 8.0


def merge_distance(v: np.ndarray, tol: float, tau_v: float = 0.0) -> float:
    """The face-merging distance (metres) of points ``v``: ``tol`` times
    their diameter, or ``TOLERANCE_MERGE_FACTOR * tau_v`` when larger (the
    faces at the part's tolerance ``tau_v``, metres)."""
    return max(tol * diameter(v), TOLERANCE_MERGE_FACTOR * float(tau_v))


def merge_hull_faces(v: np.ndarray, tol: float, tau_v: float = 0.0):
    """Merge Qhull's triangles into maximal planar faces.

    Returns a list of face cycles (caller indices, CCW seen from outside,
    starting at the smallest index).  ``tol`` is relative to the diameter;
    ``tau_v`` (metres, >= 0) widens the merging distance to the part's
    tolerance (:func:`merge_distance`).
    """
    try:
        hull = ConvexHull(v)
    except QhullError as exc:  # pragma: no cover - _check_not_flat catches most
        raise PartError(
            f"vertices: Qhull could not build the convex hull ({str(exc).splitlines()[0]}); "
            "check that the points span a volume"
        ) from None
    dist_tol = merge_distance(v, tol, tau_v)
    rings = [_face_ring(v, hull, members, dist_tol) for members in _coplanar_groups(v, hull, dist_tol)]
    cycles = []
    for ring in _drop_collinear(rings, v, dist_tol):
        k0 = int(np.argmin(ring))
        cycles.append(tuple(ring[k0:] + ring[:k0]))
    return cycles


def _coplanar_groups(v: np.ndarray, hull, dist_tol: float) -> list:
    """Qhull's triangles grouped into faces: from the largest unassigned
    triangle, grow over neighbours whose corners lie within ``dist_tol``
    (metres) of its plane."""
    simp, eqs, nbrs = hull.simplices, hull.equations, hull.neighbors
    p0 = v[simp[:, 0]]
    areas = 0.5 * np.linalg.norm(np.cross(v[simp[:, 1]] - p0, v[simp[:, 2]] - p0), axis=1)
    group = -np.ones(len(simp), dtype=int)
    groups: list[list[int]] = []
    for seed in np.argsort(-areas, kind="stable"):
        if group[seed] >= 0:
            continue
        gid = len(groups)
        n_seed, d_seed = eqs[seed, :3], eqs[seed, 3]
        members = [seed]
        group[seed] = gid
        stack = [seed]
        while stack:
            t = stack.pop()
            for u in nbrs[t]:
                if group[u] >= 0 or np.dot(eqs[u, :3], n_seed) <= 0.0:
                    continue
                if np.all(np.abs(v[simp[u]] @ n_seed + d_seed) <= dist_tol):
                    group[u] = gid
                    members.append(u)
                    stack.append(u)
        groups.append(members)
    return groups


def _face_ring(v: np.ndarray, hull, members: list, dist_tol: float):
    """``(ring, normal)`` of a group of triangles: its corners CCW seen from
    outside (the 2-D hull in the fitted plane, plus points within ``dist_tol``
    of its edges) and the area-weighted outward normal."""
    simp, eqs = hull.simplices, hull.equations
    idx = np.unique(simp[members].ravel())
    pts = v[idx]
    n = np.zeros(3)
    for t in members:
        a, b, c = v[simp[t]]
        cr = np.cross(b - a, c - a)
        n += -cr if np.dot(cr, eqs[t, :3]) < 0 else cr
    nn = np.linalg.norm(n)
    n = n / nn if nn > 0 else eqs[members[0], :3]
    # 2-D basis (u, w) with u x w = n (outward): CCW in (u, w) = CCW from outside.
    u = np.cross(n, [1.0, 0.0, 0.0])
    if np.linalg.norm(u) < 0.5:
        u = np.cross(n, [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    w = np.cross(n, u)
    c = pts.mean(axis=0)
    xy = np.stack([(pts - c) @ u, (pts - c) @ w], axis=1)
    if len(idx) == 3:
        d1, d2 = xy[1] - xy[0], xy[2] - xy[0]
        ring = [0, 1, 2] if d1[0] * d2[1] - d1[1] * d2[0] >= 0 else [0, 2, 1]
    else:
        try:
            h2 = ConvexHull(xy)
        except QhullError:  # pragma: no cover
            raise PartError(
                "vertices: a face of the hull is degenerate; remove "
                "near-duplicate or near-collinear points"
            ) from None
        ring = _insert_on_edges(list(h2.vertices), xy, dist_tol)  # CCW in 2-D for scipy
    return [int(idx[r]) for r in ring], n


def _insert_on_edges(ring: list, xy: np.ndarray, tol: float) -> list:
    """Insert into a face's 2-D hull ring (CCW indices into ``xy``) the face's
    other points that lie within ``tol`` of one of its edges, in order along
    the edge: they may be corners of a neighbouring face, and whether they are
    corners is decided for all faces at once (:func:`_drop_collinear`)."""
    on = set(ring)
    extra = [i for i in range(len(xy)) if i not in on]
    if not extra:
        return ring
    out = []
    for k in range(len(ring)):
        a, b = xy[ring[k]], xy[ring[(k + 1) % len(ring)]]
        ab = b - a
        L2 = float(ab @ ab)
        out.append(ring[k])
        if L2 == 0.0:
            continue
        found = []
        for i in extra:
            t = float((xy[i] - a) @ ab) / L2
            if 0.0 < t < 1.0 and abs(float(ab[0] * (xy[i] - a)[1] - ab[1] * (xy[i] - a)[0])) \
                    <= tol * math.sqrt(L2):
                found.append((t, i))
        out.extend(i for _, i in sorted(found))
    return out


def _drop_collinear(rings: list, v: np.ndarray, dist_tol: float) -> list:
    """Drop corners that are collinear within ``dist_tol`` (metres) -- from
    every face at once: a vertex is dropped only when it is a straight corner
    in every face that has it (a point on an edge, or in a face), so that the
    faces still close up when nearly coplanar faces were kept apart."""
    faces = [list(r) for r, _ in rings]
    normals = [n for _, n in rings]
    where: dict = {}
    for f, ring in enumerate(faces):
        for x in ring:
            where.setdefault(x, set()).add(f)

    def straight(f: int, x: int) -> bool:
        ring = faces[f]
        if len(ring) <= 3:
            return False
        k = ring.index(x)
        a, b, c = v[ring[k - 1]], v[x], v[ring[(k + 1) % len(ring)]]
        base = np.linalg.norm(c - a)
        return bool(base > 0 and np.dot(np.cross(b - a, c - b), normals[f]) / base <= dist_tol)

    changed = True
    while changed:
        changed = False
        for x in sorted(where):
            fs = where[x]
            if fs and all(straight(f, x) for f in fs):
                for f in fs:
                    faces[f].remove(x)
                where[x] = set()
                changed = True
    return faces


def validate_topology(cycles):
    directed = {}
    for f, cyc in enumerate(cycles):
        s = len(cyc)
        for k in range(s):
            e = (cyc[k], cyc[(k + 1) % s])
            if e in directed:
                raise PartError(
                    "vertices: the hull is numerically degenerate (an edge is "
                    "used twice in the same direction); remove near-duplicate "
                    "or nearly coplanar points"
                )
            directed[e] = f
    for (a, b) in directed:
        if (b, a) not in directed:
            raise PartError(
                "vertices: the hull is numerically degenerate (faces do not "
                "close up); remove near-duplicate or nearly coplanar points"
            )
    verts = {i for cyc in cycles for i in cyc}
    n_edges = len(directed) // 2
    if len(verts) - n_edges + len(cycles) != 2:
        raise PartError(
            "vertices: the hull is numerically degenerate (Euler characteristic "
            "is not 2); remove near-duplicate or nearly coplanar points"
        )
    return directed


def volume_centroid(v: np.ndarray, cycles) -> tuple[float, np.ndarray]:
    ref = v[sorted({i for c in cycles for i in c})].mean(axis=0)
    vol = 0.0
    mom = np.zeros(3)
    for cyc in cycles:
        a = v[cyc[0]]
        for k in range(1, len(cyc) - 1):
            b, c = v[cyc[k]], v[cyc[k + 1]]
            # cycle CCW from outside -> positive volume
            dv = np.dot(np.cross(a - ref, b - ref), c - ref) / 6.0
            vol += dv
            mom += dv * (ref + a + b + c) / 4.0
    return vol, mom / vol


def newell(pts: np.ndarray) -> np.ndarray:
    n = np.zeros(3)
    s = len(pts)
    for k in range(s):
        n += np.cross(pts[k], pts[(k + 1) % s])
    return n / np.linalg.norm(n)


def angle_between(u: np.ndarray, w: np.ndarray) -> float:
    return float(math.atan2(np.linalg.norm(np.cross(u, w)), np.dot(u, w)))


