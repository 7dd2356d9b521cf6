"""Convex polyhedral parts for tumbling (Marigo & Bicchi).

(About 490 lines: the :class:`Polyhedron` record and the construction of every
table it holds - frames, adjacency, angles - are one unit that is read
together; the hull's faces are in :mod:`kernels.facets`, the kernel's JAX
geometry in :mod:`kernels.tumble_geometry`.)

Two layers meet here:

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
import math
import warnings
from typing import Sequence

import jax.numpy as jnp
import numpy as np

from kernels.errors import PartError, PartWarning, warn_implausible_size
from kernels.facets import (TOLERANCE_MERGE_FACTOR, angle_between, as_points, check_not_flat,
                            diameter, extent, merge_hull_faces, newell, validate_topology,
                            volume_centroid)
from kernels.planar import TWO_PI
from kernels.tumble_geometry import TumbleGeometry, tumble_geometry

#: Default relative tolerance (times the part's diameter) for merging Qhull's
#: triangles into maximal planar faces and for dropping collinear corners.
DEFAULT_MERGE_TOL = 1e-9

#: Edges whose dihedral angle is within this of pi (nearly coplanar faces
#: that were not merged) raise a PartWarning.
NEARLY_FLAT_RAD = 1e-6


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


def _face_cycles(v: np.ndarray, tol: float, tau_v: float = 0.0) -> list[tuple[int, ...]]:
    cycles = merge_hull_faces(v, tol, tau_v)
    cycles.sort(key=lambda c: tuple(sorted(c)))
    return cycles


def _closed_hull(cycles) -> dict:
    """:func:`kernels.facets.validate_topology` of the face cycles, and at
    least four faces (a closed hull; PartError naming ``vertices``)."""
    if len(cycles) < 4:
        raise PartError(f"vertices: the hull has only {len(cycles)} faces (it is numerically "
                        "flat); a polyhedron needs at least 4 faces")
    return validate_topology(cycles)


def _closes(v: np.ndarray, tol: float) -> bool:
    """Whether the hull's faces as given (no tolerance) close up."""
    try:
        _closed_hull(_face_cycles(v, tol, 0.0))
    except PartError:
        return False
    return True


def make_polyhedron(vertices, com=None, *, tol: float = DEFAULT_MERGE_TOL,
                    tau_v: float = 0.0) -> Polyhedron:
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
      tau_v: the precision to which the vertices are known (metres, >= 0;
        each coordinate within +-tau_v): the faces are those at that
        tolerance, triangles whose corners lie within
        ``TOLERANCE_MERGE_FACTOR * tau_v`` of a common plane being one face
        (:func:`kernels.facets.merge_distance`), so that a part known to
        tau_v gets the same faces (numbers, frames) whatever its noise below
        it.  0: the faces of the coordinates as given (to ``tol``).

    Warns:
      :class:`PartWarning` when points are dropped, when faces are coplanar
      to within ``NEARLY_FLAT_RAD``, and when the part's largest extent is
      implausible for metres (:func:`kernels.errors.warn_implausible_size`,
      e.g. coordinates in millimetres).  All tolerances here are relative to
      the part's size, so a part is accepted the same way at any scale.

    Raises:
      ValueError naming ``vertices``, ``com`` or ``tau_v`` (a tolerance at
      which the merged faces do not close up) and saying how to fix it.
    """
    v = as_points(vertices)
    check_not_flat(v)
    if isinstance(tau_v, bool) or not isinstance(tau_v, (int, float, np.floating, np.integer)) \
            or not math.isfinite(float(tau_v)) or float(tau_v) < 0:
        raise PartError(f"tau_v: must be a finite number >= 0 (metres), got {tau_v!r}")
    m = v.shape[0]
    cycles = _face_cycles(v, tol, float(tau_v))
    try:
        directed = _closed_hull(cycles)
    except PartError:
        if tau_v > 0 and _closes(v, tol):  # the tolerance merged faces that are not one
            raise PartError(
                f"tau_v: at {float(tau_v):g} m the part's faces are not determined: merging "
                f"the faces within {TOLERANCE_MERGE_FACTOR:g} tau_v of a common plane leaves no "
                f"closed hull; give a smaller tau_v (the part is {extent(v):.3g} m across)"
            ) from None
        raise

    hull_vertices = tuple(sorted({i for c in cycles for i in c}))
    warn_implausible_size(extent(v[list(hull_vertices)]))
    on_hull = set(hull_vertices)
    dropped = tuple(i for i in range(m) if i not in on_hull)
    if dropped:
        warnings.warn(
            f"vertices: points {list(dropped)} are not vertices of the convex hull "
            "(interior, on a face or edge, or duplicates) and were dropped; "
            "indices still refer to your list",
            PartWarning,
            stacklevel=2,
        )

    volume, centroid = volume_centroid(v, cycles)
    normals = np.array([newell(v[list(c)]) for c in cycles])
    offsets = np.array([np.mean(v[list(c)] @ n) for c, n in zip(cycles, normals)])
    c = centroid if com is None else _read_com(com)
    _check_com_inside(c, normals, offsets, cycles, diameter(v))
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
            ang[k] = angle_between(p - q, r - q)
            vertex_sum[cyc[k]] += ang[k]
        face_angles.append(ang)
    dihedral = np.array([math.pi - angle_between(normals[f], normals[g]) for (f, g) in edge_faces])
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
    v = as_points(vertices)
    if v.shape[0] != polyhedron.vertices.shape[0]:
        raise PartError(
            f"vertices: expected {polyhedron.vertices.shape[0]} points (a perturbed "
            f"copy of the part), got {v.shape[0]}"
        )
    try:
        check_not_flat(v)
        cycles = _face_cycles(v, tol)
    except ValueError:
        return True
    return tuple(sorted(tuple(sorted(c)) for c in cycles)) != polyhedron.faces
