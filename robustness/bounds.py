"""Analytic tolerance-propagation bounds for push and tumble plans.

Pushing (first order; the Akella-Mason paper has no such bound)
----------------------------------------------------------------
A push plan's final pose is a function ``F(p)`` of the uncertain parameters
``p``: the hull vertices (part frame), the centre-of-mass offset, the start
pose, and per push the fence angle and the push distance.  Under the paper's
assumptions (quasi-static, no slip, every reorient completes: the exact
replay of :mod:`kernels.push`) ``F`` is smooth as long as every push lands the
same edge, and to first order

    |dF_i| <= sum_k |dF_i / dp_k| tau_k

for every parameter within its box tolerance ``|dp_k| <= tau_k``.  The
structure of ``dF/dp``, derived by hand:

* A *complete reorient push* onto edge ``s`` ends flush, so its final
  orientation is ``theta = angle(-d) - nu_s``: it depends only on the fence
  direction ``d`` (fence angle error, coefficient 1) and on the edge's normal
  angle ``nu_s`` (``d nu_s = cross(e, dV_b - dV_a) / |e|^2`` for the edge
  ``e = V_b - V_a``), NOT on any earlier error: orientation errors are reset
  by every reorient.  Its final centre of mass is
  ``P + s d - R(theta) v`` with ``P`` the pivot's world position at the
  start: start-pose errors and earlier position errors pass through with
  coefficient 1 along the fence and are re-aligned with the pivot,
  the distance error moves it along ``d``, and the orientation error at the
  end turns the lever ``v``.
* A *translation push* adds ``s d``: a fence angle error ``da`` moves the
  part by ``s da`` across the push, a distance error along it; its
  orientation is the flush orientation of its edge (as above).
* The centre-of-mass offset ``dc`` changes the lever arms (``v - dc``) and
  the reported reference point.

The planner's own kinematics are differentiated exactly (forward-mode
automatic differentiation through :func:`kernels.push.replay_pushes`), so
the bound is the exact first-order term of the model, not an estimate.  It is
NOT a guarantee beyond first order, and it does not cover slip at the fence,
incomplete reorientation (a push shorter than the perturbed part's Peshkin
distance) or a different landing edge: the Monte-Carlo layer reports those
as failure modes, and a bound exceeded by a sample is reported as a finding.

Tumbling
--------
:func:`tumble_first_order_bound` is the same construction for a tumble plan
(vertex tolerance ``tau_v`` per coordinate, box) through
:func:`kernels.tumble.replay`; :func:`tumble_plan_paper_bounds` computes the
Marigo-Bicchi bounds of section III-A and IV as the tumble planner computed
them (they are far looser: the paper bounds the worst case over every
lattice coefficient and generator).

Units: metres and radians; position bounds are Euclidean norms of the
worst-case (x, y) box corner, ``hypot(bound_x, bound_y)``.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Mapping

import jax
import jax.numpy as jnp
import numpy as np

from kernels import float64, polygon_geometry, replay_pushes, rot2
from planning import PushPlan
from robustness.tolerances import ExecutionTolerance, GeometryTolerance


def _final_pose(body0, start, ang0, dists, dV, dcom, dstart, dfence, ddist):
    body = body0 + dV - dcom[None, :]
    geom = polygon_geometry(body)
    th0 = start[2] + dstart[2]
    com_w = start[:2] + dstart[:2] + rot2(th0) @ dcom
    ang = ang0 + dfence
    d = jnp.stack([jnp.cos(ang), jnp.sin(ang)], -1)
    final, _ = replay_pushes(geom, jnp.concatenate([com_w, th0[None]]), d, dists + ddist)
    ref = final[:2] - rot2(final[2]) @ dcom
    return jnp.concatenate([ref, final[2:]])


#: Jacobian of the final pose in the perturbations; jit caches one compilation per
#: (vertex count, padded push count), so a study's plans share compilations.
_final_pose_jacobian = jax.jit(jax.jacfwd(_final_pose, argnums=(4, 5, 6, 7, 8)))


def _one_sided_jacobians(arrays, n: int, Pp: int, scale: float):
    """Absolute Jacobians of the final pose, the larger of the two one-sided ones.

    The final pose is only piecewise smooth at the nominal plan: a flush edge against the
    fence (every translation push, every push that lands an edge) pivots about one corner
    or the other depending on the sign of the perturbation, so the derivative AT zero is
    whichever branch a tie-break picks (on a flush edge, neither corner: 0, which would
    drop the pivot's displacement from the bound).  The derivatives are taken at the two
    points a relative 1e-7 beside the nominal (every perturbation positive, every one
    negative), and the elementwise larger absolute value is kept.
    """
    h_len, h_ang = 1e-7 * scale, 1e-7
    best = None
    for sg in (1.0, -1.0):
        pert = (jnp.full((n, 2), sg * h_len), jnp.full(2, sg * h_len),
                jnp.array([sg * h_len, sg * h_len, sg * h_ang]),
                jnp.full(Pp, sg * h_ang), jnp.full(Pp, sg * h_len))
        jac = [np.abs(np.asarray(j)) for j in _final_pose_jacobian(*arrays, *pert)]
        best = jac if best is None else [np.maximum(b, j) for b, j in zip(best, jac)]
    return best


def _plan_arrays(plan: PushPlan, pad_to: int = 0):
    """Body-frame hull, start, push angles and distances of a plan; the pushes
    padded with zero-distance pushes (no-ops) to ``pad_to``."""
    part = plan.nominal_part()   # the geometry only: the planner's margin is not needed here
    P = len(plan.pushes)
    Pp = max(P, pad_to)
    ang = np.zeros(Pp)
    dist = np.zeros(Pp)
    if P:
        dirs = np.array([p.direction for p in plan.pushes]).reshape(-1, 2)
        ang[:P] = np.arctan2(dirs[:, 1], dirs[:, 0])
        dist[:P] = [p.distance for p in plan.pushes]
    return (jnp.asarray(part.body), jnp.asarray(plan.start), jnp.asarray(ang), jnp.asarray(dist)), \
        part.n, P


def push_final_pose_fn(plan: PushPlan):
    """The plan's final pose as a function of parameter perturbations.

    Returns ``(f, sizes)``: ``f(dV, dcom, dstart, dfence, ddist) -> (3,)``
    final pose of the part frame (the NOMINAL centre of mass as reference
    point), with ``dV`` (n, 2) hull-vertex offsets (part frame), ``dcom`` (2,)
    centre-of-mass offset (part frame), ``dstart`` (3,) start-pose error,
    ``dfence`` (P,) fence angle errors (rad, CCW), ``ddist`` (P,) distance
    errors (m).  Pure JAX, exact replay kinematics; call it in float64
    (``jax.enable_x64``).
    """
    arrays, n, P = _plan_arrays(plan)

    def f(dV, dcom, dstart, dfence, ddist):
        return _final_pose(*arrays, dV, dcom, dstart, dfence, ddist)

    return f, dict(n=n, pushes=P)


@dataclasses.dataclass(frozen=True)
class SourceBound:
    """One tolerance's share of a :class:`Bound`: position (m) and angle (rad)."""

    position_m: float
    theta_rad: float


@dataclasses.dataclass(frozen=True)
class Bound:
    """First-order worst-case bound on a plan's final pose error (world frame).

    Attributes:
      x_m, y_m: per-coordinate bounds of the final position error (m).
      theta_rad: bound of the final orientation error (rad).
      by_source: the contribution of each tolerance (name -> :class:`SourceBound`),
        to see what dominates (empty where not itemised).
    """

    x_m: float
    y_m: float
    theta_rad: float
    by_source: Mapping[str, SourceBound] = dataclasses.field(default_factory=dict)

    @property
    def position_m(self) -> float:
        """Bound of the final position error, ``hypot(x_m, y_m)`` (m)."""
        return math.hypot(self.x_m, self.y_m)


@float64
def push_plan_bound(plan: PushPlan, geometry: GeometryTolerance = GeometryTolerance(),
                    execution: ExecutionTolerance = ExecutionTolerance()) -> Bound:
    """First-order worst-case bound on a push plan's final pose error.

    Args:
      plan: a verified :class:`~planning.pushing.plan.PushPlan`.
      geometry: part tolerances; ``tau_v`` bounds each vertex coordinate and
        ``tau_com`` each centre-of-mass coordinate (a disc of radius ``tau_com``
        lies in that box).
      execution: robot errors (start pose, fence angle, push distance; the
        tumble fields do not apply).

    Returns:
      :class:`Bound`, with the contribution of each tolerance (``tau_v``,
      ``tau_com``, ``start_xy``, ``start_theta``, ``fence_angle``, ``distance``).
    """
    P = len(plan.pushes)
    arrays, n, _ = _plan_arrays(plan, pad_to=-(-max(P, 1) // 4) * 4)
    Pp = arrays[2].shape[0]
    dists = np.array([p.distance for p in plan.pushes])
    jv, jc, js, jf, jd = _one_sided_jacobians(arrays, n, Pp, scale=float(np.ptp(arrays[0], 0).max()))
    jf, jd = jf[:, :P], jd[:, :P]   # the padding pushes' own columns are not perturbations
    g, e = geometry, execution
    contrib = {
        "tau_v": np.abs(jv).reshape(3, -1).sum(1) * g.tau_v,
        "tau_com": np.abs(jc).sum(1) * g.tau_com,
        "start_xy": np.abs(js[:, :2]).sum(1) * e.start_xy,
        "start_theta": np.abs(js[:, 2]) * e.start_theta,
        "fence_angle": np.abs(jf).sum(1) * e.fence_angle,
        "distance": (np.abs(jd) * (e.distance_abs + e.distance_rel * dists)[None, :]).sum(1),
    }
    total = sum(contrib.values())
    return Bound(float(total[0]), float(total[1]), float(total[2]),
                 {k: SourceBound(float(math.hypot(v[0], v[1])), float(v[2]))
                  for k, v in contrib.items()})


@float64
def tumble_first_order_bound(vertices, com, topology, start, faces, tau_v: float) -> Bound:
    """First-order worst-case bound on a tumble sequence's final configuration
    error when every vertex coordinate is within ``tau_v`` (m, box).

    Args:
      vertices: (m, 3) nominal vertices (part frame, m); com: (3,).
      topology: the nominal :class:`~kernels.polyhedron.TumbleTopology`.
      start: :class:`~kernels.tumble.TumbleConfig` start configuration.
      faces: (T,) int landing faces of the plan.
      tau_v: vertex tolerance, m.

    Returns:
      :class:`Bound` (not itemised: one source).
    """
    from kernels import tumble_geometry, replay

    if not (math.isfinite(tau_v) and tau_v >= 0):
        raise ValueError(f"tau_v: tolerance must be a finite number >= 0, got {tau_v!r}")
    v0 = jnp.asarray(vertices, jnp.float64)
    c0 = jnp.asarray(com, jnp.float64)
    seq = jnp.asarray(np.asarray(faces, np.int32))

    def f(dv):
        geom = tumble_geometry(v0 + dv, c0, topology)
        final, _ = replay(geom, start, seq)
        return jnp.concatenate([final.xy, final.theta[None]])

    j = np.asarray(jax.jacfwd(f)(jnp.zeros_like(v0)))
    b = np.abs(j).reshape(3, -1).sum(1) * tau_v
    return Bound(float(b[0]), float(b[1]), float(b[2]))


@float64
def tumble_plan_paper_bounds(plan, tau_v: float, tau_g=None) -> dict:
    """The Marigo-Bicchi bounds (section III-A, eqs. 4-6, and the tumble counts
    of section IV) for a tumble plan's part and goal, at vertex tolerance
    ``tau_v`` (m) and generator tolerance ``tau_g`` (default: the plan's).

    Keys (floats, ``inf`` where the paper's expression overflows): ``Delta_D``,
    ``Delta_beta``, ``Delta_gen``, ``E``, ``U_max`` (eq. 4),
    ``Delta_theta_f`` (eq. 5, rad), ``Delta_C_f`` (eq. 6, m),
    ``tumbles_L_f``, ``tumbles_R_bar_k``, ``tumbles_translation``,
    ``lattice_mesh_Delta`` (m^2), ``beta`` (rad).  ``d_f`` is the distance
    from the start to the goal position.  Note that the paper's expressions
    raise lengths to powers (``d_max^{2N}``...), so they depend on the unit of
    length; they are evaluated in metres, as everything in nudge.
    """
    from planning import paper_bounds, analyze_polyhedron

    if not (math.isfinite(tau_v) and tau_v >= 0):
        raise ValueError(f"tau_v: tolerance must be a finite number >= 0, got {tau_v!r}")
    analysis = analyze_polyhedron(plan.vertices, plan.com, tau_v=tau_v,
                                  tau_g=plan.tau_g if tau_g is None else tau_g,
                                  start_face=int(plan.start[3]))
    d_f = math.hypot(plan.goal[0] - plan.start[0], plan.goal[1] - plan.start[1])
    return paper_bounds(analysis, d_f)


@float64
def tumble_plan_bound(plan, geometry: GeometryTolerance = GeometryTolerance(),
                      execution: ExecutionTolerance = ExecutionTolerance()) -> Bound:
    """First-order bound of a tumble plan's final error: the vertex tolerance
    (:func:`tumble_first_order_bound`) plus the start and slip errors of
    ``execution`` (m, rad).

    The execution part:  A planar error ``(dx, dy, dtheta)`` of
    the face frame at ``p_k`` (the start, ``k = 0``, or after tumble ``k``) is a
    rigid motion of the part on the plane; every later tumble is a motion
    relative to the part, so the final frame at ``p_f`` moves by the same
    rigid motion: ``d p_f = (dx, dy) + dtheta perp(p_f - p_k)``,
    ``d theta_f = dtheta``.  Summing the worst cases over the box tolerances,
    per coordinate: ``|dx_f| <= sum_k tau_xy + tau_theta |y_f - y_k|``, ``|dy_f| <=
    sum_k tau_xy + tau_theta |x_f - x_k|``, ``|dtheta_f| <= sum_k tau_theta``, with
    the nominal positions ``p_k`` of the plan's trajectory.  The position bound
    is ``hypot`` of the x and y sums, as in :mod:`robustness.bounds`.
    """
    from kernels import make_config, replay_trajectory

    poly = plan.nominal_part()   # the plan's faces (the plan interface)
    e = execution
    start = make_config(*plan.start[:3], int(plan.start[3]), dtype=jnp.float64)
    faces = np.asarray(plan.faces, np.int32)
    tau_v = geometry.tau_v
    vb = (tumble_first_order_bound(poly.vertices, poly.com, poly.topology, start, faces, tau_v)
          if tau_v > 0 else Bound(0.0, 0.0, 0.0))
    bx, by, bt = vb.x_m, vb.y_m, vb.theta_rad
    if len(faces):
        fin, _, traj = replay_trajectory(poly.geometry(jnp.float64), start, jnp.asarray(faces))
        pk = np.asarray(traj.xy, np.float64)
        pf = np.asarray(fin.xy, np.float64)
    else:
        pk = np.zeros((0, 2))
        pf = np.asarray(plan.start[:2], np.float64)
    p0 = np.asarray(plan.start[:2], np.float64)
    ex = (e.start_xy + e.start_theta * abs(pf[1] - p0[1])
          + len(pk) * e.tumble_slip_xy + e.tumble_slip_theta * np.abs(pf[1] - pk[:, 1]).sum())
    ey = (e.start_xy + e.start_theta * abs(pf[0] - p0[0])
          + len(pk) * e.tumble_slip_xy + e.tumble_slip_theta * np.abs(pf[0] - pk[:, 0]).sum())
    et = e.start_theta + len(pk) * e.tumble_slip_theta
    bx, by, bt = bx + float(ex), by + float(ey), bt + float(et)
    return Bound(bx, by, bt, {"tau_v": SourceBound(vb.position_m, vb.theta_rad),
                              "execution": SourceBound(math.hypot(ex, ey), float(et))})
