"""Per-sample physical parts for the MuJoCo scenes (host side, numpy float64).

A sampled part (:mod:`robustness.samplers`) is turned into what a scene
needs: the solid (a polygon extruded to a prism, or the polyhedron's hull),
its mass and inertia about its centre of mass, and for a pushed part the
*feet* that realise the sampled support friction distribution.

Support (pushed parts)
----------------------
The part stands on the support its sample's family says
(:mod:`kernels.support`, the definition the quasi-static sampler draws from):
``rigid`` on its own underside, the prism mesh with corner ``i`` lowered
``PhysicsSettings.flatness * lift_i`` (MuJoCo's mesh-plane contact, at most 4
points, picks the corners it rests on); ``uniform``, ``ring`` and ``tripod``
on small spherical feet at the family's points of the PERTURBED part, all
inside its outline.  Every contact has the one support coefficient ``mu_s``:
the loads, hence the friction distribution, are what MuJoCo's statics make
of them (nothing is tuned per foot).  :func:`support_of` gives a sample's
feet and the loads its family predicts; the rollout measures the loads
MuJoCo puts on the contacts after settling and reports the limit-surface
ratio they realise (``c_physical``) beside the sampled one.

Units: metres, kilograms; inertia in kg m^2 about the centre of mass, in the
part's body frame (``[ixx, iyy, izz, ixy, ixz, iyz]``, MuJoCo's
``fullinertia``).
"""
from __future__ import annotations

import numpy as np

from kernels import REALISABLE_SUPPORTS

#: why a ``points`` support cannot be stood in MuJoCo (one line, naming the field)
POINTS_NOT_REALISABLE = ("support: the 'points' family's sampled loads cannot be realised by "
                         f"feet in MuJoCo (statics sets the loads); use "
                         f"{', '.join(REALISABLE_SUPPORTS[:-1])} or {REALISABLE_SUPPORTS[-1]} "
                         "with model: mujoco")


def support_of(code: int, body: np.ndarray, c: float, lift: np.ndarray):
    """A sample's support on its (perturbed) part.

    Args:
      code: the family's code (:data:`kernels.support.CODES`).
      body: (h, 2) hull, CCW, relative to the centre of mass, m.
      c: the sampled limit-surface ratio (the tripod's circumradius), m.
      lift: (h,) the corners' flatness ranks (rigid).

    Returns:
      ``(feet (F, 2), weights)``: the feet (none for ``rigid``) and the loads
      (fractions of the weight) the family predicts, on the feet or, for
      ``rigid``, on the corners (h,).
    """
    import jax
    import jax.numpy as jnp

    from kernels import corner_weights, equilibrium_weights, FAMILIES, FAMILY, family_points

    family = FAMILIES[int(code)]
    with jax.enable_x64(True):
        b = jnp.asarray(body, jnp.float64)
        if family == "rigid":
            return np.zeros((0, 2)), np.asarray(corner_weights(b, jnp.asarray(lift)))
        if not FAMILY[family].feet:
            raise ValueError(POINTS_NOT_REALISABLE)
        pts = family_points(family, b, c)
        return np.asarray(pts), np.asarray(equilibrium_weights(pts))


def polygon_moments(body: np.ndarray):
    """Area (m^2) and second moments ``(Sxx, Syy, Sxy) = int (x^2, y^2, xy) dA``
    (m^4) of a CCW polygon about the origin of its coordinates."""
    x, y = body[:, 0], body[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cr = x * yn - xn * y
    area = 0.5 * cr.sum()
    sxx = (cr * (x * x + x * xn + xn * xn)).sum() / 12.0
    syy = (cr * (y * y + y * yn + yn * yn)).sum() / 12.0
    sxy = (cr * (x * yn + 2 * x * y + 2 * xn * yn + xn * y)).sum() / 24.0
    return float(area), float(sxx), float(syy), float(sxy)


def prism_mass_properties(body: np.ndarray, thickness: float, density: float):
    """Mass (kg) and ``fullinertia`` (kg m^2) of a uniform prism: the CCW
    polygon ``body`` (m, body frame, the centre of mass at the origin)
    extruded by ``thickness``, inertia about the origin at mid-height (the
    centre of mass; a centre of mass away from the centroid is treated as the
    reference point of the uniform prism's tensor, a valid tensor)."""
    area, sxx, syy, sxy = polygon_moments(np.asarray(body, np.float64))
    if not area > 0:
        raise ValueError(f"body: the polygon's area must be > 0 (CCW order), got {area}")
    rho_h = density * thickness
    mass = rho_h * area
    hz = mass * thickness ** 2 / 12.0
    return mass, np.array([rho_h * syy + hz, rho_h * sxx + hz, rho_h * (sxx + syy),
                           -rho_h * sxy, 0.0, 0.0])


def polyhedron_mass_properties(points: np.ndarray, com: np.ndarray, density: float):
    """Mass (kg) and ``fullinertia`` about ``com`` (kg m^2) of the uniform
    convex hull of ``points`` (m, body frame): tetrahedra fanned from ``com``
    over the hull's triangles, ``int r r^T dV = V/20 (sum v v^T + s s^T)``."""
    from scipy.spatial import ConvexHull

    p = np.asarray(points, np.float64) - np.asarray(com, np.float64)
    hull = ConvexHull(p)
    tri = p[hull.simplices]                              # (T, 3, 3), corners
    vol6 = np.abs(np.einsum("ti,ti->t", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])))
    s = tri.sum(axis=1)
    cov = (vol6 / 120.0)[:, None, None] * (np.einsum("tki,tkj->tij", tri, tri)
                                           + np.einsum("ti,tj->tij", s, s))
    C = density * cov.sum(axis=0)
    mass = density * vol6.sum() / 6.0
    I = np.trace(C) * np.eye(3) - C
    return float(mass), np.array([I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]])


def realised_c(points: np.ndarray, capacity: np.ndarray) -> float:
    """Limit-surface ratio (m) of friction capacities (or normal loads, with
    one coefficient) at ``points`` (body frame, relative to the centre of
    mass)."""
    cap = np.asarray(capacity, np.float64)
    tot = cap.sum()
    if not tot > 0:
        return float("nan")
    return float((cap * np.linalg.norm(np.asarray(points, np.float64), axis=1)).sum() / tot)


def com_inside_feet(points: np.ndarray, margin: float = 0.0) -> bool:
    """Whether the centre of mass (the origin) lies inside the convex hull of
    the feet (the part stands on them), by at least ``margin`` m."""
    from scipy.spatial import ConvexHull, QhullError

    p = np.asarray(points, np.float64)
    if len(p) < 3:
        return False
    try:
        h = ConvexHull(p)
    except QhullError:
        return False
    return bool(np.all(h.equations[:, 2] < -margin))
