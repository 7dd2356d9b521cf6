"""Did a perturbation change a part's combinatorics?  The nominal plan and the
kernels assume the nominal hull (polygon: vertex order; polyhedron: faces); a
sample whose hull changed is reported as such, never counted as a success.

Polygons: :func:`kernels.hulls.polygon_hull_changed` (pure JAX, vmapped inside
the evaluation).  Polyhedra: :func:`kernels.hulls.polyhedron_hull_verdict_batch`
(pure JAX, inside the evaluation's compiled call), which decides what the
host-side reference :func:`polyhedron_combinatorics_changed` (Qhull and a
greedy face merge, one sample at a time) decides; :func:`polyhedra_changed`
runs it on a batch here, asking the reference only for the rare samples the
JAX check leaves undecided.
"""
from __future__ import annotations

import functools

import numpy as np

from kernels import TOLERANCE_MERGE_FACTOR


def polyhedron_combinatorics_changed(vertices, polyhedron, merge_tol: float) -> np.ndarray:
    """Per-sample :func:`kernels.polyhedron.combinatorics_changed` (host-side
    numpy loop: the reference, ~300-1000 samples/s).

    Args:
      vertices: (n, m, 3) perturbed vertex sets.
      polyhedron: the nominal :class:`kernels.polyhedron.Polyhedron`.
      merge_tol: relative face-merging tolerance (times the diameter).

    Returns:
      (n,) bool numpy array.
    """
    from kernels import combinatorics_changed

    v = np.asarray(vertices, dtype=np.float64)
    return np.array([combinatorics_changed(v[i], polyhedron, tol=merge_tol) for i in range(len(v))],
                    dtype=bool)


def polyhedra_changed(vertices, polyhedron, merge_tol: float, chunk: int = 4096) -> np.ndarray:
    """Whether each perturbed vertex set's hull has other faces than ``polyhedron``:
    the JAX check (:func:`kernels.hulls.polyhedron_hull_verdict_batch`, float64,
    ``chunk`` samples per compiled call), the host reference for the samples it
    leaves undecided (a point the nominal hull dropped popping out by less than
    the merge distance).

    Args:
      vertices: (n, m, 3) perturbed vertex sets (body frame, m).
      polyhedron: the nominal :class:`kernels.polyhedron.Polyhedron`.
      merge_tol: relative face-merging tolerance (times the diameter).

    Returns:
      (n,) bool numpy array, equal to :func:`polyhedron_combinatorics_changed`.
    """
    import jax
    import jax.numpy as jnp

    from kernels import float64

    v = np.asarray(vertices, dtype=np.float64)
    check = _compiled(polyhedron.topology)

    @float64
    def run(x):
        return jax.device_get(check(jnp.asarray(x), jnp.asarray(merge_tol, jnp.float64)))

    changed = np.zeros(len(v), bool)
    undecided = np.zeros(len(v), bool)
    for lo in range(0, len(v), chunk):
        c, u = run(v[lo:lo + chunk])
        changed[lo:lo + chunk], undecided[lo:lo + chunk] = c, u
    if undecided.any():
        changed[undecided] = polyhedron_combinatorics_changed(v[undecided], polyhedron, merge_tol)
    return changed


@functools.lru_cache(maxsize=64)
def _compiled(topology):
    """The batch check of one nominal topology, compiled with its tables as constants."""
    import jax

    from kernels import polyhedron_hull_tables, polyhedron_hull_verdict_batch

    tables = polyhedron_hull_tables(topology)
    return jax.jit(lambda v, tol: polyhedron_hull_verdict_batch(v, tables, tol))


def face_merge_tol(tau_v: float, diameter: float, factor: float = TOLERANCE_MERGE_FACTOR,
                   floor: float = 1e-6) -> float:
    """Relative face-merging tolerance for perturbed polyhedra.

    A face whose corners each move by at most ``sqrt(3) tau_v`` stays within
    about ``(1 + 3) sqrt(3) tau_v`` of the plane of any three of its corners
    (the fourth corner of a quadrilateral is an affine combination with
    coefficients summing in absolute value to 3), so faces that were planar
    nominally are still merged when their corners lie within
    ``factor * tau_v`` (default ``kernels.facets.TOLERANCE_MERGE_FACTOR`` = 8 > 4 sqrt(3), the
    factor the planner merges a part's faces at) of a common plane; a perturbed
    face that is bent more than that, or an edge flip, counts as a change of
    combinatorics.  Returned relative to the diameter, floored at ``floor``.
    """
    if diameter <= 0:
        return floor
    return max(floor, factor * float(tau_v) / float(diameter))
