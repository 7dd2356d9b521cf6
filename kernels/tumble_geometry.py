"""Per-face numbers for the tumble kernel as a JAX pytree: :func:`tumble_geometry`
rebuilds them from a vertex array and the FIXED nominal combinatorics
(:class:`~kernels.polyhedron.TumbleTopology`), so that it can be ``jax.vmap``-ed
over perturbed vertex sets.  Frames and units as in :mod:`kernels.polyhedron`.
"""
from __future__ import annotations

import dataclasses
import functools
from typing import TYPE_CHECKING

import jax
import jax.numpy as jnp
import numpy as np

if TYPE_CHECKING:  # only for annotations: kernels.polyhedron imports this module
    from kernels.polyhedron import TumbleTopology

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

