"""Same hull?  Pure JAX checks that a perturbed part still has the nominal
combinatorics the plan and the kernels assume (vmap them over samples).

Polygons: :func:`polygon_hull_changed`.  Polyhedra: the host-side reference is
:func:`robustness.hulls.polyhedron_combinatorics_changed`.
"""
from __future__ import annotations

import jax.numpy as jnp


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
