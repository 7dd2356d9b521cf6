"""Same hull?  Pure JAX checks that a perturbed part still has the nominal
combinatorics the plan and the kernels assume (vmap them over samples).

Polygons: :func:`polygon_hull_changed`.  Polyhedra: :func:`polyhedron_hull_verdict`
(one sample) and :func:`polyhedron_hull_verdict_batch` with the static tables of
:func:`polyhedron_hull_tables`; they decide what the host-side reference
:func:`kernels.polyhedron.combinatorics_changed` (Qhull, then
:func:`kernels.facets.merge_hull_faces`: a greedy merge of its triangles into
planar faces) decides, without building a hull.

Polyhedra: what decides "same hull"
-----------------------------------
The reference triangulates the perturbed points' hull (Qhull), then merges
triangles into faces greedily: seeds in order of decreasing area, each seed's
group absorbing neighbouring triangles whose three corners lie within
``dist_tol = merge_tol * diameter`` of the SEED's plane (and whose normal is
on the seed's side); a face's ring is the 2-D hull of its points plus those
within ``dist_tol`` of a ring edge; finally a vertex that is straight (within
``dist_tol`` of the chord of its neighbours) in every face that has it is
dropped from all of them.  For a perturbation of the nominal part, in
general position, that reproduces the nominal faces exactly when all of
these hold (each is checked here, per sample, on arrays):

1. **Triangulation.**  A slightly non-planar face is triangulated by the hull
   the one way that keeps it convex: its triangles are the corner triples
   whose plane has every other corner of the face on the inner side (the
   triples are enumerated statically, ``C(K, 3)`` per face).
2. **Supporting planes.**  Every vertex that is not a corner of the face lies
   strictly inside each of those triangles' planes, so these triangles are
   exactly the hull's facets (they close up into the nominal surface).
   A point the nominal hull dropped that pops out beyond ``dist_tol`` changes
   the hull; closer, the answer is left to the reference (below).
3. **Planarity.**  Every corner of a face lies within ``dist_tol`` of the plane
   of its largest triangle (the seed), whose normal the face's other
   triangles share in sense.
4. **No merging across an edge.**  For two faces sharing an edge, the one
   whose seed is larger is processed first; its group would absorb the
   other's triangle on that edge if that triangle's third corner lay within
   ``dist_tol`` of its seed plane (with the normal on the same side).
5. **No dropped corner.**  With ``h`` a corner's distance outside the chord of
   its two neighbours (along the face's Newell normal; negative when reflex):
   no corner has ``h < -dist_tol`` (it would fall off the face's ring), and no
   vertex has ``h <= dist_tol`` in every face that has it, all of more than
   three corners (the reference drops such a vertex from all its faces).

``diameter`` is the reference's: twice the largest distance of a (caller)
vertex from their mean.  Ties of exactly equal seed areas or distances (an
exactly planar face, as with zero perturbation) are resolved towards
"changed" only where the reference's choice could depend on Qhull's
arbitrary triangulation; away from such ties the two agree sample by sample
(``tests/test_hulls.py``, including perturbations within 1e-7 of the
flip of the reference's answer).  One case is left to the reference: a point
the nominal hull dropped (e.g. one listed on a face) that pops out of the
hull by less than ``dist_tol``, where the reference merges or splits the face
depending on how Qhull's fan of triangles around it is seeded;
:func:`polyhedron_hull_verdict` flags such samples ``undecided`` (the
evaluation asks the host reference for them only; parts without points on
their boundary never have any).
"""
from __future__ import annotations

import dataclasses
import functools
import itertools

import jax
import jax.numpy as jnp
import numpy as np


def polygon_hull_changed(vertices, com, hull_index):
    """Whether a perturbed polygon is no longer strictly convex in the nominal
    hull order, or its centre of mass is no longer strictly inside (pure JAX,
    one sample; vmap it).

    Args:
      vertices: (m, 2) perturbed caller vertices, m.
      com: (2,) perturbed centre of mass, m.
      hull_index: (n,) nominal hull order (caller indices, CCW).

    Returns:
      () bool.  Points the nominal hull dropped (interior or collinear) are not
      checked: the part is its hull.
    """
    p = jnp.asarray(vertices)[jnp.asarray(hull_index)]
    e = jnp.roll(p, -1, axis=0) - p
    e_next = jnp.roll(e, -1, axis=0)
    turn = e[:, 0] * e_next[:, 1] - e[:, 1] * e_next[:, 0]
    rel = jnp.asarray(com)[None, :] - p
    inside = e[:, 0] * rel[:, 1] - e[:, 1] * rel[:, 0]
    return jnp.any(turn <= 0.0) | jnp.any(inside <= 0.0)


# --------------------------------------------------------------------------
# Polyhedra
# --------------------------------------------------------------------------
@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class PolyhedronHullTables:
    """Index tables of a polyhedron's nominal faces for :func:`polyhedron_hull_changed`
    (integer / bool numpy arrays; a pytree, so they can be traced: polyhedra
    with the same table shapes share one compilation).

    ``F`` faces, ``K`` the largest face size, ``T = C(K, 3)`` corner triples
    per face (slot triples ``i < j < k``, in cycle order), ``m`` caller vertices.

    Attributes:
      corners: (F, K) caller indices of each face's corners, CCW seen from
        outside (padded by repeating corner 0).
      corner_ok: (F, K) real corners.
      prev, next: (F, K) caller indices of each corner's neighbours in the cycle.
      triples: (F, T, 3) caller indices of each triple's corners.
      triple_ok: (F, T) triples of real corners.
      in_face: (F, m) caller vertex is a corner of the face.
      dropped: (m,) caller vertex is not a hull vertex.
      nbr: (F, K) face across edge slot k (0 on padded slots).
      edge_ok: (F, K) real edge slots.
      nbr_triple: (F, K, T) triple ``t`` of face ``nbr[f, k]`` holds both ends of
        the edge.
      nbr_third: (F, K, T) the third corner of that triple (caller index).
      inc_face, inc_slot: (m, D) the faces and corner slots of each caller vertex
        (D the largest vertex degree; padding repeats the first).
      inc_ok: (m, D) real incidences.
      big_face: (F,) faces of more than three corners.
    """

    corners: np.ndarray
    corner_ok: np.ndarray
    prev: np.ndarray
    next: np.ndarray
    triples: np.ndarray
    triple_ok: np.ndarray
    in_face: np.ndarray
    dropped: np.ndarray
    nbr: np.ndarray
    edge_ok: np.ndarray
    nbr_triple: np.ndarray
    nbr_third: np.ndarray
    inc_face: np.ndarray
    inc_slot: np.ndarray
    inc_ok: np.ndarray
    big_face: np.ndarray


@functools.lru_cache(maxsize=256)
def polyhedron_hull_tables(topology) -> PolyhedronHullTables:
    """Static tables of :func:`polyhedron_hull_changed` for a nominal
    :class:`kernels.polyhedron.TumbleTopology` (cached; host-side numpy)."""
    cycles = topology.face_cycles
    F, m = len(cycles), int(topology.n_vertices)
    K = max(len(c) for c in cycles)
    slot_triples = np.array(list(itertools.combinations(range(K), 3)), np.int32).reshape(-1, 3)
    T = len(slot_triples)
    corners = np.array([list(c) + [c[0]] * (K - len(c)) for c in cycles], np.int32)
    corner_ok = np.array([[k < len(c) for k in range(K)] for c in cycles])
    prev = np.array([[c[(k - 1) % len(c)] if k < len(c) else c[0] for k in range(K)]
                     for c in cycles], np.int32)
    nxt = np.array([[c[(k + 1) % len(c)] if k < len(c) else c[0] for k in range(K)]
                    for c in cycles], np.int32)
    triples = corners[:, slot_triples]                                   # (F, T, 3)
    triple_ok = np.all(slot_triples[None, :, :] < np.array([len(c) for c in cycles])[:, None, None],
                       axis=2)
    in_face = np.zeros((F, m), bool)
    for f, c in enumerate(cycles):
        in_face[f, list(c)] = True
    dropped = ~in_face.any(axis=0)
    nbr = np.zeros((F, K), np.int32)
    edge_ok = np.zeros((F, K), bool)
    nbr_triple = np.zeros((F, K, T), bool)
    nbr_third = np.zeros((F, K, T), np.int32)
    for f, c in enumerate(cycles):
        for k in range(len(c)):
            g = int(topology.next_face[f][k])
            a, b = c[k], c[(k + 1) % len(c)]
            nbr[f, k], edge_ok[f, k] = g, True
            for t in range(T):
                tri = [int(x) for x in triples[g, t]]
                if triple_ok[g, t] and a in tri and b in tri:
                    nbr_triple[f, k, t] = True
                    nbr_third[f, k, t] = [x for x in tri if x not in (a, b)][0]
    inc = [[(f, k) for f, c in enumerate(cycles) for k, x in enumerate(c) if x == i]
           for i in range(m)]
    D = max(1, max(len(r) for r in inc))
    inc_face = np.array([[r[j][0] if j < len(r) else (r[0][0] if r else 0) for j in range(D)]
                         for r in inc], np.int32)
    inc_slot = np.array([[r[j][1] if j < len(r) else (r[0][1] if r else 0) for j in range(D)]
                         for r in inc], np.int32)
    inc_ok = np.array([[j < len(r) for j in range(D)] for r in inc])
    return PolyhedronHullTables(corners=corners, corner_ok=corner_ok, prev=prev, next=nxt,
                                triples=triples.astype(np.int32), triple_ok=triple_ok,
                                in_face=in_face, dropped=dropped, nbr=nbr, edge_ok=edge_ok,
                                nbr_triple=nbr_triple, nbr_third=nbr_third, inc_face=inc_face,
                                inc_slot=inc_slot, inc_ok=inc_ok,
                                big_face=np.array([len(c) > 3 for c in cycles]))


def polyhedron_hull_changed(vertices, tables: PolyhedronHullTables, merge_tol):
    """Whether the hull of a perturbed vertex set has other merged faces than
    the nominal part (pure JAX, one sample; vmap it): :func:`polyhedron_hull_verdict`
    with an undecided sample counted as changed (the conservative answer).

    Args:
      vertices: (m, 3) perturbed caller vertices (body frame, m).
      tables: :func:`polyhedron_hull_tables` of the nominal topology.
      merge_tol: face-merging tolerance relative to the diameter.

    Returns:
      () bool.
    """
    changed, undecided = polyhedron_hull_verdict(vertices, tables, merge_tol)
    return changed | undecided


def polyhedron_hull_verdict(vertices, tables: PolyhedronHullTables, merge_tol):
    """Whether the hull of a perturbed vertex set has other merged faces than
    the nominal part, as :func:`kernels.polyhedron.combinatorics_changed` decides
    it with ``tol = merge_tol`` (pure JAX, one sample; vmap it).  Conditions
    in the module docstring.

    Args:
      vertices: (m, 3) perturbed caller vertices (body frame, m), the caller's
        whole list (points the nominal hull dropped included).
      tables: :func:`polyhedron_hull_tables` of the nominal topology.
      merge_tol: face-merging tolerance relative to the diameter (as the
        reference's ``tol``; :func:`robustness.hulls.face_merge_tol`).

    Returns:
      ``(changed, undecided)``, () bools.  ``undecided``: a point the nominal
      hull dropped now lies outside a face, but by less than the merge
      distance, where the reference's answer depends on how Qhull's fan of
      triangles around it is seeded; ask the host reference for those samples
      (only parts that list points on their boundary have them).  The dtype of
      ``vertices`` is the computation's.
    """
    changed, undecided = polyhedron_hull_verdict_batch(jnp.asarray(vertices)[None], tables, merge_tol)
    return changed[0], undecided[0]


HULL_BLOCK = 512   # samples per block: the intermediates of a block stay in cache


def polyhedron_hull_verdict_batch(vertices, tables: PolyhedronHullTables, merge_tol,
                                  block: int = HULL_BLOCK):
    """:func:`polyhedron_hull_verdict` of a batch of perturbed vertex sets.

    The same decisions, computed with the batch on the LAST axis of every
    intermediate array (coordinates split into components), so that each
    operation is one vectorised loop over the samples; this layout is several
    times faster on a CPU than ``jax.vmap`` of the single-sample function,
    whose small trailing axes (3 coordinates, a few corners) do not vectorise.
    Batches larger than ``block`` run block by block (``lax.map``): the
    ``(faces x triples x vertices)`` intermediates of a block fit in cache,
    those of 10^4 samples do not (3-5x slower).

    Args:
      vertices: (B, m, 3) perturbed caller vertices, m.
      tables: :func:`polyhedron_hull_tables` (numpy arrays: baked into the
        compiled function; or traced arrays).
      merge_tol: () face-merging tolerance relative to the diameter.
      block: static block size.

    Returns:
      ``(changed, undecided)``, (B,) bools.
    """
    vertices = jnp.asarray(vertices)
    B = vertices.shape[0]
    if B <= block:
        return _verdict_block(vertices, tables, merge_tol)
    nb = -(-B // block)
    pad = jnp.concatenate([vertices, jnp.broadcast_to(vertices[:1], (nb * block - B,)
                                                      + vertices.shape[1:])])
    ch, un = jax.lax.map(lambda x: _verdict_block(x, tables, merge_tol),
                         pad.reshape((nb, block) + vertices.shape[1:]))
    return ch.reshape(-1)[:B], un.reshape(-1)[:B]


def _verdict_block(vertices, tables: PolyhedronHullTables, merge_tol):
    v = jnp.moveaxis(jnp.asarray(vertices), 0, -1)               # (m, 3, B)
    dtype = v.dtype
    tb = tables
    X = (v[:, 0], v[:, 1], v[:, 2])                              # (m, B) each

    def dot(a, b):
        return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]

    def cross(a, b):
        return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])

    def sub(a, b):
        return (a[0] - b[0], a[1] - b[1], a[2] - b[2])

    def take(idx):
        return tuple(x[idx] for x in X)

    mean = tuple(jnp.mean(x, axis=0) for x in X)
    r2 = sum((x - c[None]) ** 2 for x, c in zip(X, mean))
    diam = 2.0 * jnp.sqrt(jnp.max(r2, axis=0))                   # (B,)
    dist_tol = jnp.asarray(merge_tol, dtype) * diam
    tie = 64.0 * jnp.finfo(dtype).eps * diam

    # triangles of every corner triple: outward unit normal, plane offset, |cross| (2 x area)
    p0, p1, p2 = take(tb.triples[..., 0]), take(tb.triples[..., 1]), take(tb.triples[..., 2])
    cr = cross(sub(p1, p0), sub(p2, p0))                         # (F, T, B)
    nrm = jnp.sqrt(dot(cr, cr))
    ok = jnp.asarray(tb.triple_ok)[..., None] & (nrm > 0.0)
    inv = 1.0 / jnp.where(nrm > 0.0, nrm, 1.0)
    nh = tuple(c * inv for c in cr)
    off = dot(nh, p0)
    # 1. the face's own triangulation: every other corner on the inner side
    pc = take(tb.corners)                                        # (F, K, B)
    dc = dot(tuple(a[:, :, None] for a in nh), tuple(a[:, None] for a in pc)) - off[:, :, None]
    member = ok & jnp.all((dc <= tie) | ~jnp.asarray(tb.corner_ok)[:, None, :, None], axis=2)
    # 2. every vertex off the face strictly inside its triangles' planes
    dv = dot(tuple(a[:, :, None] for a in nh), tuple(a[None, None] for a in X)) - off[:, :, None]
    off_face = member[:, :, None] & ~jnp.asarray(tb.in_face)[:, None, :, None]   # (F, T, m, B)
    dropped = jnp.asarray(tb.dropped)[None, None, :, None]
    bad_support = jnp.any(off_face & ~dropped & (dv >= 0.0), axis=(0, 1, 2))
    # a dropped point beyond the merge distance splits a face; closer, the reference may merge it
    far = jnp.any(off_face & dropped & (dv >= dist_tol), axis=(0, 1, 2))
    near = jnp.any(off_face & dropped & (dv >= 0.0), axis=(0, 1, 2))
    # 3. planarity: every corner within dist_tol of the seed (largest triangle) plane
    area = jnp.where(member, nrm, -1.0)
    seed_area = jnp.max(area, axis=1)                            # (F, B)
    is_seed = (area == seed_area[:, None]) & member
    first_t = jnp.cumsum(is_seed.astype(jnp.int32), axis=1) == 1
    sel = (is_seed & first_t).astype(dtype)                      # one-hot of the seed triple
    n_s = tuple(jnp.sum(sel * a, axis=1) for a in nh)            # (F, B)
    o_s = jnp.sum(sel * off, axis=1)
    d_seed = jnp.abs(dot(tuple(a[:, None] for a in n_s), pc) - o_s[:, None])
    not_planar = jnp.any(jnp.asarray(tb.corner_ok)[..., None] & (d_seed > dist_tol), axis=(0, 1))
    same_side = dot(tuple(a[:, None] for a in n_s), nh) > 0.0
    split = jnp.any(member & ~same_side, axis=(0, 1))
    no_face = jnp.any(seed_area < 0.0, axis=0)                   # no triangle fits: not convex
    # 4. merging across an edge into the face whose seed is larger (processed first)
    g = tb.nbr                                                   # (F, K)
    w = take(tb.nbr_third)                                       # (F, K, T, B)
    ns4 = tuple(a[:, None, None] for a in n_s)
    dw = jnp.abs(dot(ns4, w) - o_s[:, None, None])
    side = dot(ns4, tuple(a[g] for a in nh)) > 0.0
    cand = jnp.asarray(tb.nbr_triple)[..., None] & member[g]
    absorbs = jnp.any(cand & (dw <= dist_tol) & side, axis=2)    # (F, K, B)
    sa_g = seed_area[g]
    fidx = jnp.arange(g.shape[0])[:, None, None]
    first = (seed_area[:, None] > sa_g) | ((seed_area[:, None] == sa_g) & (fidx < jnp.asarray(g)[..., None]))
    merged = jnp.any(jnp.asarray(tb.edge_ok)[..., None] & first & absorbs, axis=(0, 1))
    # 5. corners the reference would drop (within dist_tol of their chord, or reflex)
    q = sub(pc, tuple(a[:, :1] for a in pc))
    qn = tuple(jnp.roll(a, -1, axis=1) for a in q)
    newell = tuple(jnp.sum(a, axis=1) for a in cross(q, qn))     # padding repeats corner 0: adds 0
    nn = jnp.sqrt(dot(newell, newell))
    n_f = tuple((a / nn)[:, None] for a in newell)
    a_, c_ = take(tb.prev), take(tb.next)
    area2 = dot(cross(sub(pc, a_), sub(c_, pc)), n_f)
    base = jnp.sqrt(dot(sub(c_, a_), sub(c_, a_)))
    h = area2 / jnp.where(base > 0.0, base, 1.0)                  # (F, K, B), < 0: reflex
    ok = jnp.asarray(tb.corner_ok)[..., None]
    # a corner reflex by more than dist_tol is not on the face's ring
    excluded = jnp.any(ok & (h < -dist_tol), axis=(0, 1))
    # a vertex is dropped when it is straight in every face that has it (faces of > 3 corners)
    straight = jnp.asarray(tb.big_face)[:, None, None] & (base > 0.0) & (h <= dist_tol)
    at = straight[tb.inc_face, tb.inc_slot]                        # (m, D, B)
    inc_ok = jnp.asarray(tb.inc_ok)[..., None]
    dropped_corner = excluded | jnp.any(jnp.any(inc_ok, axis=1) & jnp.all(at | ~inc_ok, axis=1),
                                        axis=0)
    changed = bad_support | far | not_planar | split | no_face | merged | dropped_corner
    return changed, near & ~changed
