"""The tumble cell: per-sample polyhedra, the upper plate's open-loop schedule,
and the faces and pivot slips read off the rollouts.

The device (Marigo-Bicchi Fig. 1)
---------------------------------
The paper's device is a parallel-jaw gripper with three degrees of freedom
whose plates, covered by compliant high-friction pads, roll the part; the
vertical motion is passively compliant so that the grasp force stays
suitable while the part's height changes.  It is reproduced here: the part
lies on the lower jaw, a fixed plate sized to what the part covers over the
plan (every hull vertex along the nominal rolls, plus a tenth of the part's
diameter: 335 x 135 mm for the 100 mm cube rolled twice; its collision is a
plane's, its extent enforced by the monitor, a support contact outside it
being ``left_workspace``); the upper plate, a square box of the part's reach
about its centre during a roll plus the same margin (335 mm for the cube),
on the joint-driven tool, comes down on the part's top with a soft
vertical spring preloaded to the grasp force (``grip_ratio`` times the
part's weight; ``kp_z = grip / plate_compliance``), then moves horizontally,
perpendicular to the planned tumble edge and towards it: friction at the top
rolls the part about the edge on the support until the next face lands; the
plate then holds, lifts, and comes down over the part for the next tumble.
The plate is released between tumbles, so a plan whose intermediate face
cannot carry the part alone (the bundled irregular polyhedron's face 3: its
centre of mass projects 6.8 mm outside it) fails here: released there, the
part rolled onto face 6.  (Keeping the grasp across tumbles, the paper's
reading, was tried: with the spring target following the nominal top, a
part late to tip lost the grasp; with a constant target, the plate dragged
or held the landed part off its face; see the closing note of issue 9.)  A
stop or a pusher that tips the part over an edge would drop it onto the
next face (a fall whose end a stop must not obstruct); the rolling plates
keep the part held through the whole rotation, which is why the paper uses
them.  The price is friction: pads of ``mu`` well above 1 (the part pivots
about the bottom edge only if the top friction beats the grasp force's
resisting moment: for a cube ``mu_top > 1 + m g / (2 F)``), which the
sampler's ``mu_f`` (upper pad) and ``mu_s`` (lower pad) must provide.

Open loop: the plate's path is the NOMINAL kinematics of the plan.  For a
rotation ``phi`` about the edge the top of the part (its highest point) moves
horizontally at ``z_top(phi)`` per radian (a point at height ``z`` above the
axis moves at ``omega z``), so the plate moves by ``X(phi) = int z_top`` along
the direction ``u`` (horizontal, perpendicular to the edge, away from the
face on the support), ``phi`` from 0 to ``pi`` minus the edge's dihedral
angle, at a constant rate chosen so that the plate moves at most
``plate_speed``, while its spring's target follows ``z_top(phi)`` down by the
preload (``plate_compliance``, 2 cm).  The sampled planar slip
after each tumble (``tumble_slip``) is applied to the part once the plate
has lifted (a horizontal rigid motion about its face frame's origin, as in
the evaluation).
"""
from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np

from kernels import rot2_np
from robustness.physics import geometry as geo
from robustness.physics.monitor import mat_to_quat, quat_to_mat
from robustness.physics.scene import PLATE_HALF_THICKNESS, Jaw
from robustness.physics.schedule import Phase, Schedule, steps_for, transit_steps

ROLL_GRID = 512      # points of the nominal roll kinematics per tumble


def rotz(theta: float) -> np.ndarray:
    """3x3 rotation about world z by ``theta`` rad."""
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def axis_rotation(axis: np.ndarray, phi: float) -> np.ndarray:
    """3x3 rotation by ``phi`` rad about the unit ``axis`` (Rodrigues)."""
    k = np.asarray(axis, np.float64)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(phi) * K + (1 - math.cos(phi)) * K @ K


def face_pose(origin: np.ndarray, rot: np.ndarray, config) -> tuple:
    """Body pose ``(R (3, 3), t (3,))`` (world = R p + t) that puts the face
    whose frame is ``(origin, rot)`` (body frame; rows of ``rot`` the axes) on
    the support at the planar configuration ``(x, y, theta)``."""
    R = rotz(float(config[2])) @ rot
    t = np.array([float(config[0]), float(config[1]), 0.0]) - R @ origin
    return R, t


def nominal_polyhedron(plan):
    """The plan's part as a :class:`kernels.polyhedron.Polyhedron` (the plan's faces:
    :meth:`planning.TumblePlan.nominal_part`)."""
    return plan.nominal_part()


@dataclasses.dataclass
class TumbleParts:
    """Per-sample polyhedra and execution errors (numpy float64, n samples).

    Attributes:
      valid: (n,) combinatorics unchanged (only these are simulated).
      vertices: (n, m, 3) perturbed caller vertices (body frame, m);
        com: (n, 3).
      origins, rotations, normals: (n, F, 3), (n, F, 3, 3), (n, F, 3)
        perturbed face frames and outward normals (nominal faces).
      mu_f, mu_s: (n,) upper and lower pad coefficients.
      start: (n, 3) start configuration (nominal frame) with its error.
      slip: (n, L, 3) planar slip after each tumble (m, m, rad).
    """

    valid: np.ndarray
    vertices: np.ndarray
    com: np.ndarray
    origins: np.ndarray
    rotations: np.ndarray
    normals: np.ndarray
    mu_f: np.ndarray
    mu_s: np.ndarray
    start: np.ndarray
    slip: np.ndarray


def tumble_parts(plan, poly, draws, merge_factor: float = 8.0, tau_v=None) -> TumbleParts:
    """Per-sample polyhedra of drawn perturbations (``Draws``; the semantics of
    :func:`robustness.replay.run_tumble`); ``tau_v`` (m) sets the
    combinatorics check's tolerance (default the largest sampled offset)."""
    from kernels import tumble_geometry
    from robustness.hulls import face_merge_tol, polyhedron_combinatorics_changed

    n = draws.n
    p = jax.tree_util.tree_map(lambda x: np.asarray(x, np.float64), draws.broadcast())
    g, f, e = p.geometry, p.friction, p.execution
    V = np.asarray(plan.vertices, np.float64)[None] + g.vertex_offset
    com = np.asarray(plan.com, np.float64)[None] + g.com_offset
    tau = float(np.max(np.abs(g.vertex_offset))) if g.vertex_offset.size else 0.0
    if tau > 0 and tau_v is not None:
        tau = float(tau_v)
    if tau > 0:
        diam = float(np.max(np.linalg.norm(poly.vertices[:, None] - poly.vertices[None], axis=-1)))
        changed = polyhedron_combinatorics_changed(V, poly, face_merge_tol(tau, diam, merge_factor))
    else:
        changed = np.zeros(n, bool)
    with jax.enable_x64(True):
        geom = jax.vmap(lambda v, c: tumble_geometry(v, c, poly.topology))(jnp.asarray(V),
                                                                         jnp.asarray(com))
        origins, rots, normals = (np.asarray(a) for a in (geom.origins, geom.rotations,
                                                          geom.normals))
    start = np.asarray(plan.start[:3], np.float64)[None] + e.start_offset
    L = plan.n_tumbles
    return TumbleParts(valid=~changed, vertices=V, com=com, origins=origins, rotations=rots,
                       normals=normals, mu_f=f.mu_f, mu_s=f.mu_s, start=start,
                       slip=e.tumble_slip.reshape(n, L, 3))


def start_pose(parts: TumbleParts, poly, face: int, i: int) -> tuple:
    """Body pose of sample ``i`` placed by the NOMINAL frame of ``face`` at its
    start configuration (the perturbed face on the support; lowest point at
    z = 0)."""
    o, R = parts.origins[i, face], parts.rotations[i, face]
    q = (R @ (poly.face_origins[face] - o))[:2]
    xa = (R @ poly.face_rotations[face][0])[:2]
    phi = math.atan2(xa[1], xa[0])
    th = parts.start[i, 2] - phi
    xy = parts.start[i, :2] - rot2_np(th) @ q
    Rb, tb = face_pose(o, R, (xy[0], xy[1], th))
    hull = parts.vertices[i][list(poly.hull_vertices)]
    tb[2] -= np.min(hull @ Rb[:, 2] + tb[2])
    return Rb, tb


def nominal_configs(plan, poly) -> np.ndarray:
    """(L + 1, 4) planned configurations before each tumble and at the end."""
    from kernels import make_config, replay_trajectory

    with jax.enable_x64(True):
        start = make_config(*plan.start[:3], int(plan.start[3]), dtype=jnp.float64)
        faces = jnp.asarray(np.asarray(plan.faces, np.int32))
        _, _, traj = replay_trajectory(poly.geometry(jnp.float64), start, faces)
        xy, th, fc = (np.asarray(a) for a in (traj.xy, traj.theta, traj.face))
    rows = [list(plan.start[:3]) + [int(plan.start[3])]]
    rows += [[xy[k, 0], xy[k, 1], th[k], fc[k]] for k in range(len(fc))]
    return np.asarray(rows, np.float64)


def _roll(W: np.ndarray, A: np.ndarray, axis: np.ndarray, psi: float):
    """Nominal roll kinematics: the top height ``z_top`` and the plate's
    horizontal travel ``X`` on a grid of ``ROLL_GRID + 1`` angles in [0, psi]."""
    phis = np.linspace(0.0, psi, ROLL_GRID + 1)
    ztop = np.empty_like(phis)
    for j, ph in enumerate(phis):
        ztop[j] = np.max(((W - A) @ axis_rotation(axis, ph).T)[:, 2]) + A[2]
    X = np.concatenate([[0.0], np.cumsum(0.5 * (ztop[1:] + ztop[:-1]) * np.diff(phis))])
    return phis, ztop, X


def tumble_schedule(plan, poly, s, mass: float) -> tuple:
    """The upper plate's open-loop schedule (module docstring), common to all
    samples: per tumble, transit (lifted) over the part, press, dwell, roll,
    hold, lift (hook: the face reached, the sampled slip).  Returns
    ``(Schedule, plate_half, jaw, grip)``: the upper plate's half-width (m),
    the lower jaw (:class:`~robustness.physics.scene.Jaw`) and the grasp
    force (N, nominal mass)."""
    configs = nominal_configs(plan, poly)
    hull = poly.vertices[list(poly.hull_vertices)]
    diam = float(np.max(np.linalg.norm(hull[:, None] - hull[None], axis=-1)))
    grip = s.grip_ratio * mass * 9.81
    ht = PLATE_HALF_THICKNESS
    dt = s.timestep
    phases, prev, reach = [], None, 0.0
    footprint = []           # every hull vertex's (x, y) over every roll: the lower jaw's area
    for k, tumble in enumerate(plan.tumbles):
        cfg = configs[k]
        f = int(cfg[3])
        Rb, tb = face_pose(poly.face_origins[f], poly.face_rotations[f], cfg)
        W = hull @ Rb.T + tb
        A = poly.vertices[tumble.edge[0]] @ Rb.T + tb
        B = poly.vertices[tumble.edge[1]] @ Rb.T + tb
        edir = (B - A) / np.linalg.norm(B - A)
        cf = poly.vertices[list(poly.face_cycles[f])] @ Rb.T + tb
        u = 0.5 * (A + B) - cf.mean(axis=0)
        u = u - np.dot(u, edir) * edir
        u[2] = 0.0
        u /= np.linalg.norm(u)
        axis = np.cross([0.0, 0.0, 1.0], u)
        psi = math.pi - float(poly.dihedral_angles[poly.edge_index(*tumble.edge)])
        phis, ztop, X = _roll(W, A, axis, psi)
        p0 = (poly.com @ Rb.T + tb)[:2]
        lifted = np.r_[p0, ztop[0] + s.clearance + ht, 0.0]
        pressed = np.r_[p0, ztop[0] - s.plate_compliance + ht, 0.0]
        if prev is None:
            phases.append(Phase("settle", -1, steps_for(s.settle_time, dt), lifted, lifted))
        else:
            phases.append(Phase("transit", k, transit_steps(prev, lifted, s.transit_speed,
                                                            s.yaw_rate, dt), prev, lifted))
        nroll = steps_for(psi * float(ztop.max()) / s.plate_speed, dt)
        grid = np.linspace(0.0, psi, nroll + 1)[1:]
        path = np.zeros((nroll, 4))
        path[:, :2] = p0[None] + np.interp(grid, phis, X)[:, None] * u[None, :2]
        path[:, 2] = np.interp(grid, phis, ztop) - s.plate_compliance + ht
        end = path[-1].copy()
        prev = np.r_[end[:2], ztop[-1] + s.clearance + ht, 0.0]
        # the plate must hold the part's top under it all along the roll: the
        # part's extent about the plate's centre (nominal kinematics, every angle)
        for ph, xj in zip(phis[::8], X[::8]):
            Wr = (W - A) @ axis_rotation(axis, ph).T + A
            centre = p0 + xj * u[:2]
            reach = max(reach, float(np.max(np.abs(Wr[:, :2] - centre[None]))))
            footprint.append(Wr[:, :2])
        phases += [
            Phase("press", k, steps_for((lifted[2] - pressed[2]) / s.lift_speed, dt), lifted,
                  pressed),
            Phase("dwell", k, steps_for(s.dwell_time, dt), pressed, pressed),
            Phase("roll", k, nroll, pressed, end, path=path),
            Phase("hold", k, steps_for(s.dwell_time, dt), end, end),
            Phase("lift", k, steps_for((prev[2] - end[2]) / s.lift_speed, dt), end, prev,
                  hook=True),
        ]
    phases.append(Phase("final", -1, steps_for(s.settle_time, dt), prev, prev))
    # a gripper's plate: the part's largest extent about the plate's centre during
    # any roll, plus a margin of a tenth of the part's size (a few part diameters
    # across, where the plate used to be the roll's reach + the diameter + 5 cm)
    plate_half = reach + 0.1 * diam
    # the lower jaw: a fixed plate under everything the part covers over the
    # plan (every hull vertex at every roll angle, nominal kinematics), with
    # the same margin; a part whose support leaves it has left the workspace
    pts = np.concatenate(footprint)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    jaw = Jaw(centre=tuple(float(v) for v in 0.5 * (lo + hi)),
              half=tuple(float(v) for v in 0.5 * (hi - lo) + 0.1 * diam))
    return Schedule(phases, dt), plate_half, jaw, grip


def body_pose(state: np.ndarray, layout):
    """Body rotations (n, 3, 3) and origins (n, 3) of the part."""
    pq = layout.part_qpos
    return quat_to_mat(state[:, pq + 3:pq + 7]), state[:, pq:pq + 3]


def face_down(R: np.ndarray, normals: np.ndarray, face_tol: float) -> np.ndarray:
    """The face (n,) lying on the support (outward normal within
    ``face_tol`` of straight down), -1 if none."""
    nz = np.einsum("nj,nfj->nf", R[:, 2, :], normals)       # world z of each normal
    f = np.argmin(nz, axis=1)
    return np.where(nz[np.arange(len(f)), f] <= -math.cos(face_tol), f, -1)


def apply_slip(state, layout, parts, idx, k, faces) -> np.ndarray:
    """Apply the sampled planar slip after tumble ``k``: a rotation by
    ``dtheta`` about the vertical through the (perturbed) face frame origin of
    the face on the support, then ``(dx, dy)``."""
    st = state.copy()
    R, t = body_pose(st, layout)
    pq = layout.part_qpos
    for j, i in enumerate(idx):
        dx, dy, dth = parts.slip[i, k]
        if dx == 0 and dy == 0 and dth == 0:
            continue
        f = faces[j] if faces[j] >= 0 else int(np.argmin(R[j, 2] @ parts.normals[i].T))
        o = R[j] @ parts.origins[i, f] + t[j]
        Rz = rotz(dth)
        t_new = Rz @ (t[j] - np.r_[o[:2], 0.0]) + np.r_[o[:2], 0.0] + np.r_[dx, dy, 0.0]
        st[j, pq:pq + 3] = t_new
        st[j, pq + 3:pq + 7] = mat_to_quat((Rz @ R[j])[None])[0]
        st[j, layout.part_qvel:layout.part_qvel + 6] = 0.0
    return st


def pad_friction_needed(poly, grip_ratio: float, grid: int = 64) -> tuple[float, float]:
    """The pad friction the tumble device needs to roll ``poly`` (a
    :class:`kernels.polyhedron.Polyhedron`) over every edge of every face,
    quasi-statically, the upper pad pressing with ``grip_ratio`` times the
    part's weight.

    Rolling about the edge A on the lower pad by ``phi``, the upper pad touches
    the highest vertex T (height ``h`` above A, ``d_T`` along the roll
    direction u from A; the one farthest back when several tie) and pushes it
    along u with friction ``f <= mu_top F``.  Moments about the edge: the
    part turns when ``f h >= m g (-d_G) + F (-d_T)`` (centre of mass and T
    behind the edge resist) until the centre of mass passes over the edge, so
    ``mu_top >= max_phi ((-d_G)^+ / ratio + (-d_T)^+) / h``; the lower pad holds
    the edge against the same horizontal force under the normal load
    ``F + m g``: ``mu_bottom >= mu_top ratio / (ratio + 1)``.  For a cube at
    ratio 2: 1.25 and 0.83 (the top pad's contact is the cube's rear top edge).

    Returns ``(mu_top, mu_bottom)``, the largest over every face and edge.
    """
    hull = poly.vertices[list(poly.hull_vertices)]
    size = float(np.max(np.linalg.norm(hull[:, None] - hull[None], axis=-1)))
    r = float(grip_ratio)
    need = 0.0
    for f, cycle in enumerate(poly.face_cycles):
        Rb, tb = face_pose(poly.face_origins[f], poly.face_rotations[f], (0.0, 0.0, 0.0))
        W = hull @ Rb.T + tb
        G = poly.com @ Rb.T + tb
        cf = poly.vertices[list(cycle)] @ Rb.T + tb
        for k in range(len(cycle)):
            A = poly.vertices[cycle[k]] @ Rb.T + tb
            B = poly.vertices[cycle[(k + 1) % len(cycle)]] @ Rb.T + tb
            e = (B - A) / np.linalg.norm(B - A)
            u = 0.5 * (A + B) - cf.mean(axis=0)
            u = u - np.dot(u, e) * e
            u[2] = 0.0
            u /= np.linalg.norm(u)
            axis = np.cross([0.0, 0.0, 1.0], u)
            psi = math.pi - float(poly.dihedral_angles[poly.edge_index(cycle[k],
                                                                      cycle[(k + 1) % len(cycle)])])
            for ph in np.linspace(0.0, psi, grid, endpoint=False):
                Q = axis_rotation(axis, ph)
                Wr = (W - A) @ Q.T
                dG = float((G - A) @ Q.T @ u)
                if dG >= 0.0:            # the centre of mass is over the edge: it falls on
                    break
                top = Wr[:, 2] >= Wr[:, 2].max() - 1e-9 * size
                h = float(Wr[:, 2].max())
                dT = float(np.min(Wr[top] @ u))
                need = max(need, (max(-dG, 0.0) / r + max(-dT, 0.0)) / h)
    return need, need * r / (r + 1.0)


def part_mass(poly, s) -> float:
    """Nominal mass (kg) of the uniform polyhedron."""
    return geo.polyhedron_mass_properties(poly.vertices[list(poly.hull_vertices)], poly.com,
                                          s.polyhedron_density)[0]
