"""Convex polyhedral parts for tumbling (Marigo & Bicchi).

Two layers live here:

* :func:`make_polyhedron` validates a caller's part on the host (numpy +
  scipy): vertices in any order, optional centre of mass.  It returns a
  :class:`Polyhedron` with the hull's maximal faces, the face frames, edges,
  adjacency, face / dihedral / defect angles.  Pure: no I/O, no printing; the
  only side effect is a :class:`PartWarning` when points are dropped.
* :func:`tumble_geometry` is a pure JAX function that rebuilds the per-face
  numbers the tumble kernel needs (:class:`TumbleGeometry`, a pytree) from a
  vertex array and the **fixed** nominal combinatorics
  (:class:`TumbleTopology`), so it can be ``jax.vmap``-ed over perturbed
  vertex sets.

Conventions (``DESIGN.md``): metres, radians, angles CCW positive, wrapped to
(-pi, pi].  Vertices are given in the caller's **body frame** (any origin;
the centre of mass is a point of that frame) and keep the caller's indices:

* A **face** is a maximal planar facet of the hull, named by the sorted tuple
  of its corner indices into the caller's vertex list; faces are numbered in
  lexicographic order of those tuples.
* An **edge** is a pair ``(a, b)`` of caller vertex indices with ``a < b``;
  edges are numbered in lexicographic order.
* ``face_cycles[f]`` lists face ``f``'s corners counter-clockwise seen from
  OUTSIDE the part, starting at its smallest index.  Edge slot ``k`` of face
  ``f`` is the edge from ``face_cycles[f][k]`` to ``face_cycles[f][k+1]``
  (cyclically).
* **Face frame** of face ``f``: origin at the orthogonal projection of the
  centre of mass onto the face's plane; x-axis along edge slot 0 (from the
  smallest corner to its CCW-from-outside successor); z-axis the INWARD unit
  normal; ``y = z x x``.  The rotation ``face_rotations[f]`` maps body to face
  frame, ``p_face = R_f (p_body - o_f)`` (its rows are the axes).
* A **configuration** ``(x, y, theta, face)``: ``face`` lies on the plane
  ``z = 0`` (its inward normal pointing up) and its frame sits at world
  ``(x, y)`` with its x-axis at world angle ``theta``.  Seen from above, the
  face frame is a proper right-handed planar frame, so a face-frame point
  ``q`` is at world ``R(theta) q + (x, y)``.  Because the frame is seen from
  inside the part, the corners in ``face_cycles`` order run CLOCKWISE in face
  coordinates.
"""
from __future__ import annotations

import dataclasses
import functools
import math
import warnings
from typing import Sequence

import jax
import jax.numpy as jnp
import numpy as np
from scipy.spatial import ConvexHull, QhullError

from kernels.errors import PartError, PartWarning, warn_implausible_size
from kernels.planar import TWO_PI

#: Default relative tolerance (times the part's diameter) for merging Qhull's
#: triangles into maximal planar faces and for dropping collinear corners.
DEFAULT_MERGE_TOL = 1e-9

#: Edges whose dihedral angle is within this of pi (nearly coplanar faces
#: that were not merged) raise a PartWarning.
NEARLY_FLAT_RAD = 1e-6


# --------------------------------------------------------------------------
# Host-side construction (numpy / scipy)
# --------------------------------------------------------------------------
def _as_points(vertices) -> np.ndarray:
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


def _diameter(v: np.ndarray) -> float:
    return float(np.max(np.linalg.norm(v - v.mean(axis=0), axis=1))) * 2.0


def _extent(hull_points: np.ndarray) -> float:
    """Largest distance between two hull vertices (the part's largest extent, m)."""
    best = 0.0
    for i in range(0, len(hull_points), 256):  # chunks: O(m) memory
        d = hull_points[i:i + 256, None, :] - hull_points[None, :, :]
        best = max(best, float(np.max(np.einsum("ijk,ijk->ij", d, d))))
    return math.sqrt(best)


def _check_not_flat(v: np.ndarray) -> None:
    centred = v - v.mean(axis=0)
    s = np.linalg.svd(centred, compute_uv=False)
    if s[0] == 0.0 or s[2] <= 1e-10 * s[0]:
        raise PartError(
            "vertices: all points are coplanar (or collinear / coincident), so "
            "they span no volume; a polyhedron needs at least 4 non-coplanar "
            "points (for a flat part use kind: polygon)"
        )


def _merge_hull_faces(v: np.ndarray, tol: float):
    """Merge Qhull's triangles into maximal planar faces.

    Returns a list of face cycles (caller indices, CCW seen from outside,
    starting at the smallest index).  ``tol`` is relative to the diameter.
    """
    try:
        hull = ConvexHull(v)
    except QhullError as exc:  # pragma: no cover - _check_not_flat catches most
        raise PartError(
            f"vertices: Qhull could not build the convex hull ({str(exc).splitlines()[0]}); "
            "check that the points span a volume"
        ) from None
    dist_tol = tol * _diameter(v)
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


def _validate_topology(cycles):
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


def _volume_centroid(v: np.ndarray, cycles) -> tuple[float, np.ndarray]:
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


def _newell(pts: np.ndarray) -> np.ndarray:
    n = np.zeros(3)
    s = len(pts)
    for k in range(s):
        n += np.cross(pts[k], pts[(k + 1) % s])
    return n / np.linalg.norm(n)


def _angle(u: np.ndarray, w: np.ndarray) -> float:
    return float(math.atan2(np.linalg.norm(np.cross(u, w)), np.dot(u, w)))


@dataclasses.dataclass(frozen=True)
class TumbleTopology:
    """Static (hashable) combinatorics of a polyhedron for the JAX kernel.

    All indices are plain Python ints in tuples so the object can be a static
    pytree field (jit cache key).  ``K = max_face_size``; per-face tables are
    padded to ``K`` with ``-1`` (or, for ``padded_cycles``, by repeating the
    face's first corner, which leaves Newell's sum unchanged).

    Attributes:
      n_vertices: length ``m`` of the caller's vertex list (the vertex array
        given to :func:`tumble_geometry` must have shape ``(m, 3)``).
      face_cycles: per face, corner indices CCW seen from outside, starting at
        the smallest index (unpadded).
      next_face: (F, K) face across edge slot ``k`` of face ``f`` (-1 pad).
      next_slot: (F, K) slot of the same edge in ``next_face[f][k]``'s cycle
        (it is traversed in the opposite direction there), -1 pad.
      edge_index: (F, K) index into ``Polyhedron.edges`` (-1 pad).
    """

    n_vertices: int
    face_cycles: tuple[tuple[int, ...], ...]
    next_face: tuple[tuple[int, ...], ...]
    next_slot: tuple[tuple[int, ...], ...]
    edge_index: tuple[tuple[int, ...], ...]

    @property
    def n_faces(self) -> int:
        return len(self.face_cycles)

    @property
    def max_face_size(self) -> int:
        return max(len(c) for c in self.face_cycles)

    @property
    def face_sizes(self) -> np.ndarray:
        return np.array([len(c) for c in self.face_cycles], dtype=np.int32)

    @property
    def padded_cycles(self) -> np.ndarray:
        """(F, K) int32 corner indices, padded by repeating the first corner."""
        K = self.max_face_size
        return np.array(
            [list(c) + [c[0]] * (K - len(c)) for c in self.face_cycles], dtype=np.int32
        )

    @property
    def corner_mask(self) -> np.ndarray:
        """(F, K) bool, True on real corners."""
        K = self.max_face_size
        return np.array(
            [[k < len(c) for k in range(K)] for c in self.face_cycles], dtype=bool
        )

    @property
    def next_face_array(self) -> np.ndarray:
        return np.array(self.next_face, dtype=np.int32)

    @property
    def next_slot_array(self) -> np.ndarray:
        return np.array(self.next_slot, dtype=np.int32)


@dataclasses.dataclass(frozen=True, eq=False)
class Polyhedron:
    """A validated convex polyhedral part (host-side, numpy).

    Attributes (indices are into the caller's vertex list; units metres/radians):
      vertices: (m, 3) the caller's vertices as given (body frame).
      com: (3,) centre of mass, body frame.
      volume: hull volume, m^3.
      hull_vertices: sorted caller indices of the hull's vertices.
      dropped: caller indices that are not hull vertices (interior, on a face
        or an edge, duplicates); they appear in no face.
      faces: per face the sorted tuple of its corner indices; faces numbered in
        lexicographic order of these tuples.
      face_cycles: per face the corners CCW seen from outside, starting at the
        smallest index.
      normals: (F, 3) outward unit normals (Newell), body frame.
      face_origins: (F, 3) face-frame origins (com projected on the face plane).
      face_rotations: (F, 3, 3) body -> face-frame rotation (rows x, y, z axes;
        z the inward normal).
      face_corners_2d: per face an (s_f, 2) array, the corners' face-frame
        coordinates in ``face_cycles`` order (clockwise in face coordinates).
      edges: sorted tuple of ``(a, b)``, ``a < b``.
      edge_faces: per edge ``(f, g)``, ``f < g``, the two faces sharing it.
      face_angles: per face an (s_f,) array, the interior angle alpha at each
        corner of ``face_cycles[f]``.
      dihedral_angles: (E,) interior dihedral angle at each edge, in (0, pi).
      defect_angles: (len(hull_vertices),) beta_i = 2 pi - sum of face angles
        at ``hull_vertices[i]``; they sum to 4 pi (Descartes).
      topology: the :class:`TumbleTopology` for :func:`tumble_geometry`.
    """

    vertices: np.ndarray
    com: np.ndarray
    volume: float
    hull_vertices: tuple[int, ...]
    dropped: tuple[int, ...]
    faces: tuple[tuple[int, ...], ...]
    face_cycles: tuple[tuple[int, ...], ...]
    normals: np.ndarray
    face_origins: np.ndarray
    face_rotations: np.ndarray
    face_corners_2d: tuple[np.ndarray, ...]
    edges: tuple[tuple[int, int], ...]
    edge_faces: tuple[tuple[int, int], ...]
    face_angles: tuple[np.ndarray, ...]
    dihedral_angles: np.ndarray
    defect_angles: np.ndarray
    topology: TumbleTopology

    @property
    def n_faces(self) -> int:
        return len(self.faces)

    @property
    def n_edges(self) -> int:
        return len(self.edges)

    @property
    def n_vertices(self) -> int:
        """Number of hull vertices (not the length of the caller's list)."""
        return len(self.hull_vertices)

    def face_index(self, face: Sequence[int]) -> int:
        """Face number of a face given by its corner indices (any order)."""
        key = tuple(sorted(int(i) for i in face))
        try:
            return self.faces.index(key)
        except ValueError:
            raise PartError(f"face: {list(face)} is not a face of this polyhedron; "
                             f"faces are {list(self.faces)}") from None

    def edge_index(self, a: int, b: int) -> int:
        """Edge number of the edge joining caller vertices ``a`` and ``b``."""
        key = (min(a, b), max(a, b))
        try:
            return self.edges.index(key)
        except ValueError:
            raise PartError(f"edge: ({a}, {b}) is not an edge of this polyhedron") from None

    def neighbors(self, face: int) -> tuple[int, ...]:
        """Faces adjacent to ``face``, in edge-slot order (across the edge from
        ``face_cycles[face][k]`` to ``face_cycles[face][k+1]`` for k = 0, 1, ...)."""
        return self.topology.next_face[face][: len(self.face_cycles[face])]

    def shared_edge(self, f: int, g: int) -> tuple[int, int]:
        """The edge ``(a, b)``, ``a < b``, shared by faces ``f`` and ``g``."""
        row = self.neighbors(f)
        if g not in row:
            raise PartError(f"faces {f} and {g} are not adjacent")
        return self.edges[self.topology.edge_index[f][row.index(g)]]

    def defect_angle(self, vertex: int) -> float:
        """Defect angle beta (rad) of caller vertex ``vertex``."""
        return float(self.defect_angles[self.hull_vertices.index(vertex)])

    def vertex_faces(self, vertex: int) -> tuple[int, ...]:
        """Faces around caller vertex ``vertex``, CCW seen from outside, starting
        at the smallest face number; consecutive faces (cyclically) share an
        edge through the vertex.  Tumbling through them and back to the first
        (``S_j`` in Marigo-Bicchi) rotates the part by ``+defect_angle(vertex)``
        (CCW) about the vertex's position on the plane."""
        if vertex not in self.hull_vertices:
            raise PartError(f"vertex: {vertex} is not a hull vertex")
        incident = [f for f, c in enumerate(self.face_cycles) if vertex in c]
        start = min(incident)
        order = [start]
        f = start
        while True:
            c = self.face_cycles[f]
            k = c.index(vertex)
            # edge slot k-1 runs p -> v: the face across it is the next one CCW
            # around v seen from outside.
            g = self.topology.next_face[f][(k - 1) % len(c)]
            if g == start:
                break
            order.append(g)
            f = g
            if len(order) > len(incident):  # pragma: no cover
                raise RuntimeError("inconsistent face cycles")
        return tuple(order)

    def geometry(self, dtype=None) -> "TumbleGeometry":
        """Nominal :class:`TumbleGeometry` (``dtype`` float32 or float64;
        default JAX's default float, float64 only with ``jax_enable_x64``)."""
        if dtype is None:
            dtype = jnp.result_type(float)
        return tumble_geometry(
            jnp.asarray(self.vertices, dtype=dtype),
            jnp.asarray(self.com, dtype=dtype),
            self.topology,
        )


def _face_cycles(v: np.ndarray, tol: float) -> list[tuple[int, ...]]:
    cycles = _merge_hull_faces(v, tol)
    cycles.sort(key=lambda c: tuple(sorted(c)))
    return cycles


def make_polyhedron(vertices, com=None, *, tol: float = DEFAULT_MERGE_TOL) -> Polyhedron:
    """Validate a convex polyhedral part and compute its geometry (host side).

    Args:
      vertices: (m, 3) points in metres, body frame, any order, m >= 4, not
        all coplanar.  Points that are not hull vertices are dropped with a
        :class:`PartWarning` naming their indices (indices keep referring to
        the caller's list).
      com: optional (3,) centre of mass, body frame, metres; default the
        volume centroid of the hull.  It must lie strictly inside the hull.
      tol: relative tolerance (times the diameter) under which Qhull's
        triangles are merged into one planar face and collinear corners
        dropped.

    Warns:
      :class:`PartWarning` when points are dropped, when faces are coplanar
      to within ``NEARLY_FLAT_RAD``, and when the part's largest extent is
      implausible for metres (:func:`kernels.errors.warn_implausible_size`,
      e.g. coordinates in millimetres).  All tolerances here are relative to
      the part's size, so a part is accepted the same way at any scale.

    Raises:
      ValueError naming ``vertices`` or ``com`` and saying how to fix it.
    """
    v = _as_points(vertices)
    _check_not_flat(v)
    m = v.shape[0]
    cycles = _face_cycles(v, tol)
    directed = _validate_topology(cycles)

    hull_vertices = tuple(sorted({i for c in cycles for i in c}))
    warn_implausible_size(_extent(v[list(hull_vertices)]))
    dropped = tuple(i for i in range(m) if i not in set(hull_vertices))
    if dropped:
        warnings.warn(
            f"vertices: points {list(dropped)} are not vertices of the convex hull "
            "(interior, on a face or edge, or duplicates) and were dropped; "
            "indices still refer to your list",
            PartWarning,
            stacklevel=2,
        )

    volume, centroid = _volume_centroid(v, cycles)
    normals = np.array([_newell(v[list(c)]) for c in cycles])
    offsets = np.array([np.mean(v[list(c)] @ n) for c, n in zip(cycles, normals)])
    c = centroid if com is None else _read_com(com)
    _check_com_inside(c, normals, offsets, cycles, _diameter(v))
    origins, rots, corners2d = _face_frames(v, cycles, normals, offsets, c)
    edges, edge_faces, topo = _adjacency(cycles, directed, m)
    face_angles, dihedral, defects = _angles(v, cycles, hull_vertices, normals, edge_faces)
    flat = [edges[i] for i in np.flatnonzero(dihedral > math.pi - NEARLY_FLAT_RAD)]
    if flat:
        warnings.warn(
            f"vertices: edges {flat} join faces that are coplanar to within "
            f"{NEARLY_FLAT_RAD:g} rad; if they should be one face (rounded "
            "coordinates), pass a larger tol to make_polyhedron or fix the points",
            PartWarning,
            stacklevel=2,
        )
    normals, origins, rots, dihedral, defects = map(_ro, (normals, origins, rots, dihedral, defects))
    return Polyhedron(
        vertices=_ro(v),
        com=_ro(c),
        volume=float(volume),
        hull_vertices=hull_vertices,
        dropped=dropped,
        faces=tuple(tuple(sorted(cc)) for cc in topo.face_cycles),
        face_cycles=topo.face_cycles,
        normals=normals,
        face_origins=origins,
        face_rotations=rots,
        face_corners_2d=tuple(_ro(a) for a in corners2d),
        edges=tuple(edges),
        edge_faces=tuple(edge_faces),
        face_angles=tuple(_ro(a) for a in face_angles),
        dihedral_angles=dihedral,
        defect_angles=defects,
        topology=topo,
    )


def _ro(a) -> np.ndarray:
    """A read-only float copy."""
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


def _read_com(com) -> np.ndarray:
    try:
        c = np.asarray(com, dtype=float)
    except (TypeError, ValueError):
        raise PartError("com: could not be read as [x, y, z] floats; give "
                        "the centre of mass in metres or omit it") from None
    if c.shape != (3,):
        raise PartError(f"com: expected [x, y, z] (shape (3,)), got shape "
                        f"{c.shape}; give the centre of mass in metres or omit it")
    if not np.all(np.isfinite(c)):
        raise PartError("com: is not finite (NaN or inf); give the centre "
                        "of mass in metres or omit it for the volume centroid")
    return c


def _check_com_inside(c, normals, offsets, cycles, diam: float) -> None:
    """PartError unless ``c`` lies strictly inside every face plane (to 1e-9 x
    the part's size)."""
    margin = normals @ c - offsets  # > 0 outside
    worst = int(np.argmax(margin))
    if margin[worst] >= -1e-9 * diam:
        where = "outside" if margin[worst] > 1e-9 * diam else "on the boundary of"
        raise PartError(
            f"com: {c.tolist()} lies {where} the convex hull (face "
            f"{list(sorted(cycles[worst]))}, distance {margin[worst]:.3g} m beyond "
            "its plane); give a centre of mass strictly inside the part, or omit "
            "com for the volume centroid"
        )


def _face_frames(v, cycles, normals, offsets, c):
    """Face frames (origin: ``c`` projected on the face plane; x along edge
    slot 0; z the inward normal) and the corners in them (see the module doc)."""
    F = len(cycles)
    origins = np.empty((F, 3))
    rots = np.empty((F, 3, 3))
    corners2d = []
    for f, cyc in enumerate(cycles):
        n = normals[f]
        o = c - (np.dot(n, c) - offsets[f]) * n
        e = v[cyc[1]] - v[cyc[0]]
        x = e - np.dot(e, n) * n
        x /= np.linalg.norm(x)
        z = -n
        R = np.stack([x, np.cross(z, x), z])
        origins[f] = o
        rots[f] = R
        corners2d.append(((v[list(cyc)] - o) @ R.T)[:, :2].copy())
    return origins, rots, corners2d


def _adjacency(cycles, directed: dict, m: int):
    """Edges (sorted ``(a, b)``, ``a < b``), the two faces of each, and the
    :class:`TumbleTopology` (face across each edge slot, its slot there, the
    edge's number; padded with -1)."""
    edges = sorted({(min(a, b), max(a, b)) for (a, b) in directed})
    edge_id = {e: i for i, e in enumerate(edges)}
    edge_faces = []
    for (a, b) in edges:
        f1, f2 = directed[(a, b)], directed[(b, a)]
        edge_faces.append((min(f1, f2), max(f1, f2)))
    K = max(len(c) for c in cycles)
    next_face, next_slot, edge_index = [], [], []
    for cyc in cycles:
        s = len(cyc)
        nf, ns, ei = [], [], []
        for k in range(s):
            a, b = cyc[k], cyc[(k + 1) % s]
            g = directed[(b, a)]
            nf.append(g)
            ns.append(cycles[g].index(b))
            ei.append(edge_id[(min(a, b), max(a, b))])
        pad = [-1] * (K - s)
        next_face.append(tuple(nf + pad))
        next_slot.append(tuple(ns + pad))
        edge_index.append(tuple(ei + pad))
    topo = TumbleTopology(
        n_vertices=m,
        face_cycles=tuple(tuple(int(i) for i in c) for c in cycles),
        next_face=tuple(next_face),
        next_slot=tuple(next_slot),
        edge_index=tuple(edge_index),
    )
    return edges, edge_faces, topo


def _angles(v, cycles, hull_vertices, normals, edge_faces):
    """Face angles (per face, at each corner), dihedral angles (per edge) and
    defect angles (per hull vertex: 2 pi minus its face angles), radians."""
    face_angles = []
    vertex_sum = {i: 0.0 for i in hull_vertices}
    for cyc in cycles:
        s = len(cyc)
        ang = np.empty(s)
        for k in range(s):
            p, q, r = v[cyc[k - 1]], v[cyc[k]], v[cyc[(k + 1) % s]]
            ang[k] = _angle(p - q, r - q)
            vertex_sum[cyc[k]] += ang[k]
        face_angles.append(ang)
    dihedral = np.array([math.pi - _angle(normals[f], normals[g]) for (f, g) in edge_faces])
    defects = np.array([TWO_PI - vertex_sum[i] for i in hull_vertices])
    return face_angles, dihedral, defects


def combinatorics_changed(vertices, polyhedron: Polyhedron, tol: float = 1e-6) -> bool:
    """Whether the hull of ``vertices`` has different merged faces than ``polyhedron``.

    ``vertices`` is a perturbed copy (same length and indexing) of
    ``polyhedron.vertices``.  Its hull's triangles are merged into planar faces
    with relative tolerance ``tol`` (times the diameter: a perturbed
    quadrilateral whose corners are within ``tol * diameter`` of a common plane
    counts as one face), and the resulting set of faces (sorted corner tuples)
    is compared with ``polyhedron.faces``.  Host-side numpy; returns a bool.
    The tumble kernel always uses the NOMINAL combinatorics; when this returns
    True the kernel's model of the perturbed part (faces fitted by Newell's
    method to the nominal corner cycles) is no longer the part's true hull.
    """
    v = _as_points(vertices)
    if v.shape[0] != polyhedron.vertices.shape[0]:
        raise PartError(
            f"vertices: expected {polyhedron.vertices.shape[0]} points (a perturbed "
            f"copy of the part), got {v.shape[0]}"
        )
    try:
        _check_not_flat(v)
        cycles = _face_cycles(v, tol)
    except ValueError:
        return True
    return tuple(sorted(tuple(sorted(c)) for c in cycles)) != polyhedron.faces


# --------------------------------------------------------------------------
# JAX geometry for the kernel
# --------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class TumbleGeometry:
    """Per-face numbers for the tumble kernel (a JAX pytree).

    Array fields are traced (a leading batch axis under ``jax.vmap``); the
    :class:`TumbleTopology` is static.  ``F`` faces, ``K`` = max face size.
    All arrays share one float dtype (float32 or float64).

    Attributes:
      vertices: (m, 3) body-frame vertices used (metres).
      com: (3,) centre of mass, body frame.
      normals: (F, 3) outward unit normals (Newell), body frame.
      offsets: (F,) plane offsets, ``normals[f] . p = offsets[f]`` on face f's
        fitted plane (through the mean of its corners).
      origins: (F, 3) face-frame origins (com projected on the fitted plane).
      rotations: (F, 3, 3) body -> face frame (rows: x, y, z = inward normal).
      corners_2d: (F, K, 2) face-frame coordinates of the corners in
        ``face_cycles`` order (projected on the fitted plane); padded slots
        repeat corner 0.
      topology: static :class:`TumbleTopology`.
    """

    vertices: jax.Array
    com: jax.Array
    normals: jax.Array
    offsets: jax.Array
    origins: jax.Array
    rotations: jax.Array
    corners_2d: jax.Array
    topology: TumbleTopology

    @property
    def dtype(self):
        return self.corners_2d.dtype

    @property
    def next_face(self) -> np.ndarray:
        """(F, K) int32 face across edge slot k of face f (-1 pad); static."""
        return self.topology.next_face_array

    @property
    def next_slot(self) -> np.ndarray:
        """(F, K) int32 slot of the shared edge in the next face (-1 pad); static."""
        return self.topology.next_slot_array


jax.tree_util.register_dataclass(
    TumbleGeometry,
    data_fields=["vertices", "com", "normals", "offsets", "origins", "rotations", "corners_2d"],
    meta_fields=["topology"],
)


@functools.lru_cache(maxsize=256)
def _topology_tables(topology: TumbleTopology):
    """Index tables of a topology (cached): padded cycles, corner mask, sizes."""
    return (topology.padded_cycles, topology.corner_mask, topology.face_sizes)


@jax.jit
def _geometry_arrays(vertices, com, cyc, mask, sizes):
    # Jitted on shapes only (the index tables are traced arguments), so
    # polyhedra with the same (m, F, K) share one compilation.
    dtype = vertices.dtype
    sizes = sizes.astype(dtype)
    P = vertices[cyc]  # (F, K, 3)
    # Newell's normal: sum_k p_k x p_{k+1} over the closed cycle (translated by
    # the first corner for conditioning).  Padded slots repeat corner 0, so
    # the (last real -> pad) and (pad -> pad) terms close the polygon exactly.
    P0 = P - P[:, :1, :]
    newell = jnp.sum(jnp.cross(P0, jnp.roll(P0, -1, axis=1)), axis=1)
    n = newell / jnp.linalg.norm(newell, axis=1, keepdims=True)
    centroid = jnp.sum(jnp.where(mask[..., None], P, 0.0), axis=1) / sizes[:, None]
    offsets = jnp.sum(n * centroid, axis=1)
    origins = com[None, :] - (n @ com - offsets)[:, None] * n
    e = P[:, 1, :] - P[:, 0, :]
    x = e - jnp.sum(e * n, axis=1, keepdims=True) * n
    x = x / jnp.linalg.norm(x, axis=1, keepdims=True)
    z = -n
    y = jnp.cross(z, x)
    R = jnp.stack([x, y, z], axis=1)  # (F, 3, 3) rows = axes
    rel = P - origins[:, None, :]
    corners_2d = jnp.einsum("fij,fkj->fki", R[:, :2, :], rel)
    return n, offsets, origins, R, corners_2d


def tumble_geometry(vertices, com, topology: TumbleTopology) -> TumbleGeometry:
    """Build the kernel's :class:`TumbleGeometry` from a vertex array (pure JAX).

    Args:
      vertices: (m, 3) body-frame vertices, metres (``m = topology.n_vertices``;
        the caller's full list, dropped points included and ignored).
      com: (3,) centre of mass, body frame, metres.
      topology: the nominal :class:`TumbleTopology` (``Polyhedron.topology``).

    The faces are the NOMINAL combinatorics: for a perturbed vertex set each
    face keeps its nominal corner cycle, its plane is fitted with Newell's
    normal through the mean of its corners (robust for slightly non-planar
    faces) and its corners are projected onto that plane.  Whether the
    perturbed points' hull has different faces is not checked here (see
    :func:`combinatorics_changed`; the robustness layer decides).

    Jit- and vmap-able over ``vertices`` / ``com``; dtype follows
    ``vertices``.
    """
    vertices = jnp.asarray(vertices)
    if not jnp.issubdtype(vertices.dtype, jnp.floating):
        vertices = vertices.astype(jnp.result_type(float))
    com = jnp.asarray(com, dtype=vertices.dtype)
    n, offsets, origins, R, corners_2d = _geometry_arrays(
        vertices, com, *_topology_tables(topology)
    )
    return TumbleGeometry(
        vertices=vertices,
        com=com,
        normals=n,
        offsets=offsets,
        origins=origins,
        rotations=R,
        corners_2d=corners_2d,
        topology=topology,
    )
