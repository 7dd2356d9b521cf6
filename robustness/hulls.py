"""Did a perturbation change a part's combinatorics?  The nominal plan and the
kernels assume the nominal hull (polygon: vertex order; polyhedron: faces); a
sample whose hull changed is reported as such, never counted as a success.

Polygons: :func:`kernels.polygon.hull_changed` (pure JAX, vmapped inside the
evaluation).  Polyhedra: below (host side).
"""
from __future__ import annotations

import numpy as np


def polyhedron_combinatorics_changed(vertices, polyhedron, merge_tol: float) -> np.ndarray:
    """Per-sample :func:`kernels.polyhedron.combinatorics_changed` (host-side
    numpy loop).

    Args:
      vertices: (n, m, 3) perturbed vertex sets.
      polyhedron: the nominal :class:`kernels.polyhedron.Polyhedron`.
      merge_tol: relative face-merging tolerance (times the diameter).

    Returns:
      (n,) bool numpy array.
    """
    from kernels.polyhedron import combinatorics_changed

    v = np.asarray(vertices, dtype=np.float64)
    return np.array([combinatorics_changed(v[i], polyhedron, tol=merge_tol) for i in range(len(v))],
                    dtype=bool)


def face_merge_tol(tau_v: float, diameter: float, factor: float = 8.0, floor: float = 1e-6) -> float:
    """Relative face-merging tolerance for perturbed polyhedra.

    A face whose corners each move by at most ``sqrt(3) tau_v`` stays within
    about ``(1 + 3) sqrt(3) tau_v`` of the plane of any three of its corners
    (the fourth corner of a quadrilateral is an affine combination with
    coefficients summing in absolute value to 3), so faces that were planar
    nominally are still merged when their corners lie within
    ``factor * tau_v`` (default 8 > 4 sqrt(3)) of a common plane; a perturbed
    face that is bent more than that, or an edge flip, counts as a change of
    combinatorics.  Returned relative to the diameter, floored at ``floor``.
    """
    if diameter <= 0:
        return floor
    return max(floor, factor * float(tau_v) / float(diameter))
