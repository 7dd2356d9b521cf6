"""Per-sample physical parts for the MuJoCo scenes (host side, numpy float64).

A sampled part (:mod:`robustness.samplers`) is turned into what a scene
needs: the solid (a polygon extruded to a prism, or the polyhedron's hull),
its mass and inertia about its centre of mass, and for a pushed part the
*feet* that realise the sampled support friction distribution.

Support friction (pushed parts)
-------------------------------
The quasi-static model needs only ``c = sum w_i |p_i| / sum w_i`` of the
sampled support points ``p_i`` (body frame, relative to the centre of mass)
and weights ``w_i`` (:func:`kernels.quasistatic.limit_surface_ratio`): the
limit surface of support friction whose capacity at ``p_i`` is proportional
to ``w_i``.  The part in MuJoCo rests on small spherical feet at those
points, relative to its (perturbed) centre of mass; after the part has
settled, each foot's contact friction coefficient is set to
``mu_i = mu_s w_i W / N_i`` from the normal load ``N_i`` that MuJoCo itself
put on it (``W = sum N_j``, the weight), so that the friction capacity
``mu_i N_i = mu_s W w_i`` is the sampled distribution exactly, whatever the
statically indeterminate load sharing is (:func:`foot_friction`).  The part's
exact limit surface is then that of the sampled points, of which the
quasi-static model's ellipsoid with the same ``c`` is the usual approximation.
When ``c`` was drawn directly (``FrictionRange.c``) there are no points; a
distribution with that ``c`` is made up (:func:`feet_for_c`).

By default (``PhysicsSettings.support = "tripod"``) the part stands on three
feet, an equilateral triangle of circumradius ``c`` about the centre of mass
(:func:`tripod_feet`): statically determinate, so the loads are ``W / 3``
whatever the contact compliance, with the sampled ``c`` and the friction
centroid on the centre of mass, the two things the quasi-static model knows
of the support.  Many feet are statically indeterminate, and in MuJoCo that
showed: on the 40 x 20 mm rectangle with 16 sampled feet, 27-45 % of the foot
contacts carried no load during a push (the part rocked on its soft
contacts), the fence's sticking contact pressed the part down with up to 50 %
of its weight, and a translating flush edge walked 0.004-0.008 mm per 10 cm
against 0.0004 mm on three feet; reorient pushes slipped 1-7 mm where the
quasi-static model sticks.  What three feet do not share with the model is
the limit surface's shape: the exact limit surface of three points is
pointier than the ellipsoid with the same ``c``, so a sticking pivot needs a
larger tangential force (computed for the rectangle's corner pivot, c = 12 mm:
0.108 against the ellipsoid's 0.095 at 7 degrees from the divergent
orientation, 0.50 against 0.42 at 30, 0.73-0.82 against 0.64 at 45), and
the part slips earlier than the model says; a uniform pressure over the
rectangle comes within 0.02 of the ellipsoid.  ``support = "centred"`` or
``"sampled"`` stand the part on the sampled points instead:

The sampler does not put the weights' centroid ``sum w_i p_i`` under the
centre of mass (its docstring says so), but a part resting on a support has
its pressure centroid there (statics), and with one friction coefficient its
friction centroid too; the quasi-static model's limit surface is centred on
the centre of mass.  A friction centroid a few millimetres off (the draws of
16 points with Dirichlet(1) weights on the 40 x 20 mm rectangle were 0.2 to
9.5 mm off) reverses the rotation of a reorient push that starts within the
plan's 7 degree margin of the divergent orientation, which no planar model of
a part with its centre of mass at the centroid of support predicts.  So with
``"centred"`` the weights are moved to the nearest ones (least squares) that keep
``c`` and put the centroid on the centre of mass (:func:`centred_weights`);
``PhysicsSettings.support = "sampled"`` realises the draws as they are.

Units: metres, kilograms; inertia in kg m^2 about the centre of mass, in the
part's body frame (``[ixx, iyy, izz, ixy, ixz, iyz]``, MuJoCo's
``fullinertia``).
"""
from __future__ import annotations

import numpy as np

#: a foot whose load is below this fraction of the mean carries no friction
MIN_LOAD_FRACTION = 1e-3
#: no foot gets a friction coefficient above this multiple of mu_s
MAX_FOOT_MU_FACTOR = 25.0
#: ring feet of a made-up distribution sit at this fraction of the vertex radii
RING_SCALE = 0.9
#: orientations tried when fitting the three equivalent feet inside the part
TRIPOD_TRIALS = 72


def tripod_feet(c: float, body: np.ndarray):
    """Three feet realising the limit-surface ratio ``c`` (m): an equilateral
    triangle of circumradius ``c`` centred on the centre of mass (the
    origin), turned so that its feet lie as deep inside the CCW polygon
    ``body`` as possible (a foot may still fall outside a slender part: it is
    only a support point).  With one friction coefficient the loads are
    ``W / 3`` each by statics, so ``sum w |p| = c`` with the friction centroid
    on the centre of mass.  Returns ``(points (3, 2), weights (3,))``."""
    body = np.asarray(body, np.float64)
    e = np.roll(body, -1, axis=0) - body
    normal = np.stack([e[:, 1], -e[:, 0]], -1) / np.linalg.norm(e, axis=1, keepdims=True)
    best, best_pts = -np.inf, None
    for rot in np.linspace(0.0, 2 * np.pi / 3, TRIPOD_TRIALS, endpoint=False):
        a = rot + np.arange(3) * 2 * np.pi / 3
        pts = c * np.stack([np.cos(a), np.sin(a)], -1)
        depth = np.min(np.einsum("ei,pei->pe", normal, body[None] - pts[:, None, :]))
        if depth > best:
            best, best_pts = depth, pts
    return best_pts, np.full(3, 1.0 / 3.0)


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


def feet_for_c(c: float, body: np.ndarray):
    """A support distribution inside the part with limit-surface ratio ``c``
    (m) when ``c`` was drawn directly: a foot under the centre of mass and a
    ring at ``RING_SCALE`` times the hull vertices (body frame, m).  Weights:
    ``1 - lam`` at the centre and ``lam / n`` on the ring, or, for a ``c``
    larger than the ring's mean radius, the ring with weight moved to its
    farthest foot.  Returns ``(points (n + 1, 2), weights (n + 1,))``; the
    ``c`` they realise is ``min(c, RING_SCALE * max |v|)``."""
    body = np.asarray(body, np.float64)
    ring = RING_SCALE * body
    r = np.linalg.norm(ring, axis=1)
    n = len(ring)
    w = np.zeros(n + 1)
    if c <= r.mean():
        lam = c / r.mean()
        w[0], w[1:] = 1.0 - lam, lam / n
    else:
        far = int(np.argmax(r))
        mu = min(1.0, (c - r.mean()) / max(r[far] - r.mean(), 1e-300))
        w[1:] = (1.0 - mu) / n
        w[1 + far] += mu
    return np.vstack([np.zeros((1, 2)), ring]), w


def centred_weights(points: np.ndarray, weights: np.ndarray, c: float):
    """The weights nearest to ``weights`` (least squares, non-negative, sum 1)
    whose centroid is the origin (the centre of mass) and whose
    limit-surface ratio is ``c``: ``sum q p = 0``, ``sum q |p| = c``.

    Solved as a non-negative least-squares problem with the constraints
    weighted 1e8 (coordinates scaled by the largest radius).

    Returns:
      ``(q (S,), ok)``: ``ok`` when the constraints hold to 1e-6 of the
      radius (a centre of mass outside the points' hull, or a ``c`` out of
      reach, leaves them unmet).
    """
    from scipy.optimize import nnls

    p = np.asarray(points, np.float64)
    w = np.asarray(weights, np.float64)
    r = np.linalg.norm(p, axis=1)
    a = max(float(r.max()), 1e-12)
    A = np.vstack([np.ones(len(p)), p[:, 0] / a, p[:, 1] / a, r / a])
    b = np.array([1.0, 0.0, 0.0, c / a])
    k = 1e4
    q, _ = nnls(np.vstack([np.eye(len(p)), k * A]), np.concatenate([w, k * b]), maxiter=50 * len(p))
    ok = bool(np.max(np.abs(A @ q - b)) <= 1e-6)
    return q / max(q.sum(), 1e-300), ok


def foot_friction(weights: np.ndarray, loads: np.ndarray, mu_s: float):
    """Per-foot friction coefficients realising the sampled distribution.

    Args:
      weights: (S,) sampled weights (sum 1).
      loads: (S,) normal loads MuJoCo put on the feet at rest, N.
      mu_s: the sampled support coefficient.

    Returns:
      ``(mu (S,), capacity (S,), ok)``: ``mu_i = mu_s w_i W / N_i``, capped at
      ``MAX_FOOT_MU_FACTOR mu_s``; a foot with (almost) no load gets 0; the
      capacity ``mu_i N_i`` actually realised (N); ``ok`` is False when a cap
      or an unloaded foot changed the distribution.
    """
    w = np.asarray(weights, np.float64)
    N = np.maximum(np.asarray(loads, np.float64), 0.0)
    W = N.sum()
    loaded = N > MIN_LOAD_FRACTION * W / max(len(N), 1)
    mu = np.where(loaded, mu_s * w * W / np.where(loaded, N, 1.0), 0.0)
    cap = MAX_FOOT_MU_FACTOR * mu_s
    ok = bool(W > 0) and bool(np.all(loaded | (w <= 1e-12))) and bool(np.all(mu <= cap))
    mu = np.minimum(mu, cap)
    return mu, mu * N, ok


def realised_c(points: np.ndarray, capacity: np.ndarray) -> float:
    """Limit-surface ratio (m) of friction capacities at ``points`` (body
    frame, relative to the centre of mass)."""
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
