"""MuJoCo scenes built in code (``mujoco.MjSpec``, no XML files).

Two cells, each one model per sampled part (every sample of a plan gets a
model with the same structure, so that ``mujoco.rollout`` can run them
together and MJX can batch their differing fields):

* :func:`push_model`: the support plane; the part, a convex mesh (the polygon
  extruded to a prism) resting on its own underside (rigid support) or on
  spherical *feet* at its support family's points
  (:mod:`robustness.physics.geometry`), with its mass and inertia about its
  centre of mass; and the fence, a box on a tool body driven through joints.
  The part has two massless meshes on one body: ``part``, the flat prism the
  fence meets, and ``sole``, the same prism with its bottom corners lowered by
  the sampled flatness errors, which alone touches the support (flat for the
  families on feet).
* :func:`tumble_model`: the lower jaw (a fixed plate of the gripper's size,
  :class:`Jaw`), the part (the polyhedron's hull) and the upper plate, a box
  on the same tool.

The tool (fence or upper plate) is NOT a mocap body: a mocap body has zero
velocity for the contact solver and cannot be driven by ``mujoco.rollout``
controls.  It has x, y, z slides and a yaw hinge, each with a position servo
(``kp``) and a velocity servo (``kv = 2 sqrt(kp m)``, critical damping) whose
control is the commanded velocity, and full gravity compensation.  Controls:
``[x, y, z, yaw, vx, vy, vz, vyaw]`` (m, rad, m/s, rad/s), world frame; the
tool's origin is the centre of its box.

Contacts come only from explicit pairs (every geom has contype = conaffinity
= 0), so that each pair has its own coefficient (MuJoCo would otherwise take
the larger of two geoms' frictions): tool-part ``mu_f``; foot-support (one
pair per foot) and sole-support ``mu_s``.  condim 3 (no torsional or rolling
friction: the contacts are points), elliptic cones, Newton solver, implicitfast
integrator, noslip iterations, multiccd on (see
:class:`~robustness.physics.settings.PhysicsSettings` for the numbers).

The fence's friction acts in every tangential direction, the vertical one
included.  At a sticking contact the vertical component is statically
indeterminate; the soft support contacts let the part move by micrometres
against the fence, and the fence then holds the part down: by about 10 % of
its weight on three feet (50 % on 16 sampled feet), which takes part of the
friction cone from the horizontal and adds to the support friction.  It was
left so after two remedies failed: anisotropic pair friction (a vertical
coefficient near 0; the contact frame's tangents are horizontal and
vertical for a horizontal normal) made a translating edge walk 0.6-3.6 mm
per 10 cm under MuJoCo's elliptic cones and noslip, and a vertically
floating fence let the part and the fence rise together (1 mm of walk).

The fence contact creeps inside its friction cone.  Through a pivot at
``mu_f`` 0.8 (``bench/fence_friction.py``) the part's contact vertex slides
along the fence at 0.14-0.23 mm per mm pushed while the fence's friction is
0.4-0.6 of its normal force (Coulomb sliding would put it at 0.8), and the
velocity at the contact after the step (after noslip) is not zero: 0.06-2.9
mm/s along the fence.  No setting removed it (timestep 1 ms, noslip 100
iterations at tolerance 1e-14, impratio 100, pyramidal cones, stiffer or
more damped ``solref``/``solimp``, ``solreffriction``, a vertical fence
friction of 1 %, the part held level each step: 0.86-3.4 mm a push against
the quasi-static model's 0.28 mm).  MuJoCo's friction is regularised (a
force of the slip velocity): an in-cone load does not guarantee a sticking
contact and noslip is an iterative post-pass (google-deepmind/mujoco#3328,
open; its documentation since #3526).  Physics therefore slips at fence
frictions where Coulomb's law, and the planner, stick.

Sensors: ``tool_contact`` (contact sensor, ``found``: how many tool-part
contacts).  The support's loads are read on the host (:func:`support_loads`).
"""
from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np

from robustness.physics.settings import PhysicsSettings

TOOL_JOINTS = ("tool_x", "tool_y", "tool_z", "tool_yaw")
FOUND = 1                    # contact sensor data bit ("found")
PLANE_HALF = 10.0            # visual half-size of the support plane (collision is infinite)
PLATE_HALF_THICKNESS = 0.005  # m, the tumble cell's plates (upper plate and lower jaw)


@dataclasses.dataclass(frozen=True)
class Jaw:
    """The tumble cell's lower jaw: a fixed rectangular plate, its top face at
    z = 0, world frame: ``centre`` (x, y) and ``half`` (half-widths along x, y), m."""
    centre: tuple[float, float]
    half: tuple[float, float]

    @property
    def rectangle(self) -> tuple[float, float, float, float]:
        """``(xmin, xmax, ymin, ymax)``, m, world frame."""
        (cx, cy), (hx, hy) = self.centre, self.half
        return (cx - hx, cx + hx, cy - hy, cy + hy)


@dataclasses.dataclass(frozen=True)
class Layout:
    """Where things are in a scene's state and sensor vectors (the same for
    every model of a plan).

    Attributes:
      nstate: size of the ``mjSTATE_FULLPHYSICS`` vector ``[time, qpos, qvel,
        act]`` that ``mujoco.rollout`` takes and returns.
      nu: number of controls (8); nsensordata: sensor vector size.
      part_qpos: offset of the part's free joint in the state vector
        (position x, y, z then quaternion w, x, y, z); tool_qpos: offset of
        the tool's 4 joints; part_qvel: offset of the part's 6 velocities.
      tool_contact: sensordata offset of the tool-part contact count.
      foot_pairs: pair ids of the foot-support pairs; tool_pair: the
        tool-part pair id.
    """

    nstate: int
    nu: int
    nsensordata: int
    part_qpos: int
    tool_qpos: int
    part_qvel: int
    tool_contact: int
    foot_pairs: tuple
    tool_pair: int


def _options(spec: mujoco.MjSpec, s: PhysicsSettings, impratio: float) -> None:
    o = spec.option
    o.timestep = s.timestep
    o.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    o.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    o.solver = mujoco.mjtSolver.mjSOL_NEWTON
    o.iterations = s.iterations
    o.ls_iterations = s.ls_iterations
    o.tolerance = s.tolerance
    o.noslip_iterations = s.noslip_iterations
    o.impratio = impratio


def _no_collide(geom) -> None:
    geom.contype = 0
    geom.conaffinity = 0
    geom.density = 0.0
    geom.mass = 0.0


def _pair(spec, g1: str, g2: str, mu: float, name: str):
    return spec.add_pair(name=name, geomname1=g1, geomname2=g2, condim=3,
                         friction=[mu, mu, 0.0, 0.0, 0.0])



def _contact_sensor(spec, name: str, g1: str, g2: str, data: int) -> None:
    spec.add_sensor(name=name, type=mujoco.mjtSensor.mjSENS_CONTACT,
                    objtype=mujoco.mjtObj.mjOBJ_GEOM, objname=g1,
                    reftype=mujoco.mjtObj.mjOBJ_GEOM, refname=g2, intprm=[data, 0, 1])


def _tool(spec, s: PhysicsSettings, half_size, kp_z: float) -> None:
    """The driven tool: box geom ``tool`` of ``half_size`` on 4 servoed joints."""
    body = spec.worldbody.add_body(name="tool", gravcomp=1.0)
    body.explicitinertial = True
    body.mass = s.tool_mass
    i_yaw = s.tool_mass * 0.01
    body.inertia = [i_yaw, i_yaw, i_yaw]
    types = (mujoco.mjtJoint.mjJNT_SLIDE,) * 3 + (mujoco.mjtJoint.mjJNT_HINGE,)
    axes = ([1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, 1])
    for name, typ, ax in zip(TOOL_JOINTS, types, axes):
        body.add_joint(name=name, type=typ, axis=ax)
    g = body.add_geom(name="tool", type=mujoco.mjtGeom.mjGEOM_BOX, size=list(half_size))
    _no_collide(g)
    kps = (s.servo_kp, s.servo_kp, kp_z, s.servo_yaw_kp)
    masses = (s.tool_mass, s.tool_mass, s.tool_mass, i_yaw)
    for name, kp in zip(TOOL_JOINTS, kps):
        a = spec.add_actuator(name="pos_" + name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        a.set_to_position(kp=kp)
    for name, kp, m in zip(TOOL_JOINTS, kps, masses):
        a = spec.add_actuator(name="vel_" + name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        a.set_to_velocity(kv=2.0 * math.sqrt(kp * m))


def _plane(spec, centre=(0.0, 0.0), half=(PLANE_HALF, PLANE_HALF)) -> None:
    """The support plane ``support`` (collision infinite; ``half`` sizes its rendering)."""
    g = spec.worldbody.add_geom(name="support", type=mujoco.mjtGeom.mjGEOM_PLANE,
                                pos=[float(centre[0]), float(centre[1]), 0.0],
                                size=[float(half[0]), float(half[1]), 0.1])
    _no_collide(g)


def _mesh_geom(spec, body, name: str, vertices3: np.ndarray) -> None:
    """A massless, pair-only mesh geom ``name`` of the hull of ``vertices3`` on ``body``."""
    spec.add_mesh(name=name, uservert=np.asarray(vertices3, np.float64).ravel().tolist())
    g = body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_MESH, meshname=name)
    _no_collide(g)


def _part_body(spec, vertices3: np.ndarray, mass: float, ipos, fullinertia):
    body = spec.worldbody.add_body(name="part")
    body.add_freejoint(name="part")
    body.explicitinertial = True
    body.mass = float(mass)
    body.ipos = [float(v) for v in ipos]
    body.fullinertia = [float(v) for v in fullinertia]
    _mesh_geom(spec, body, "part", vertices3)
    return body


def _compile(spec) -> mujoco.MjModel:
    m = spec.compile()
    if m.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_MULTICCD):
        raise RuntimeError("multiccd is disabled in this MuJoCo build's defaults; the scenes need "
                           "multi-point convex contacts (a flush edge walks sideways without them)")
    return m


def push_model(body: np.ndarray, feet: np.ndarray, n_feet: int, drop: np.ndarray, mass: float,
               fullinertia, mu_f: float, mu_s: float, s: PhysicsSettings,
               impratio: float) -> mujoco.MjModel:
    """The push cell for one sampled part.

    Args:
      body: (h, 2) hull vertices, CCW, body frame (origin at the centre of
        mass), m; the prism spans z in [0, part_thickness] of the body frame,
        its bottom corner i lowered to ``-drop[i]`` (flatness errors of a part
        on rigid support; zeros otherwise).
      feet: (F, 2) foot positions, body frame, m: the first ``n_feet`` are
        spheres at z = 0 (the part stands on them, ``foot_radius`` above the
        support); the others are parked inside the part (every model of a
        batch has the same F, so that they run together) and never touch.
      mass, fullinertia: about the centre of mass at (0, 0, thickness / 2).
      mu_f, mu_s: fence and support coefficients (every support contact
        has ``mu_s``).
      s: settings; impratio: the engine's.
    """
    spec = mujoco.MjSpec()
    _options(spec, s, impratio)
    _plane(spec)
    h = s.part_thickness
    b = np.asarray(body, np.float64)
    top = np.c_[b, np.full(len(b), h)]
    part = _part_body(spec, np.vstack([np.c_[b, np.zeros(len(b))], top]), mass,
                      (0.0, 0.0, 0.5 * h), fullinertia)
    # the underside the support touches: the prism with its bottom corners lowered.
    # The fence meets the flat prism ``part``: the lowered corners split its faces
    # into triangles, and MJX's convex collider then let the fence pass through
    # the part (a 2 cm push moved it 1-9 mm; the C engine 20 mm)
    _mesh_geom(spec, part, "sole", np.vstack([np.c_[b, -np.asarray(drop, np.float64)], top]))
    for i, p in enumerate(np.asarray(feet, np.float64)):
        pos = [float(p[0]), float(p[1]), 0.0] if i < n_feet else [0.0, 0.0, 0.5 * h]
        g = part.add_geom(name=f"foot{i}", type=mujoco.mjtGeom.mjGEOM_SPHERE,
                          size=[s.foot_radius, 0, 0], pos=pos)
        _no_collide(g)
    top = s.foot_radius + h + s.clearance
    half = (0.5 * s.fence_thickness, 0.5 * s.fence_length, 0.5 * top)
    _tool(spec, s, half, s.servo_kp)
    _pair(spec, "tool", "part", mu_f, "tool_part")
    for i in range(len(feet)):
        _pair(spec, "support", f"foot{i}", mu_s, f"foot{i}")
    _pair(spec, "support", "sole", mu_s, "part_support")
    _contact_sensor(spec, "tool_contact", "tool", "part", FOUND)
    return _compile(spec)


def support_loads(m: mujoco.MjModel, state: np.ndarray):
    """The support's contacts of a push scene in ``state`` (a
    ``mjSTATE_FULLPHYSICS`` vector, C engine): ``(points (k, 2), loads (k,))``,
    contact positions in the part's body frame (m, relative to the centre of
    mass's vertical) and normal forces (N)."""
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, np.asarray(state, np.float64), mujoco.mjtState.mjSTATE_FULLPHYSICS)
    mujoco.mj_forward(m, d)
    support = m.geom("support").id
    part = m.body("part").id
    R = d.xmat[part].reshape(3, 3)
    pts, loads = [], []
    f = np.zeros(6)
    for i in range(d.ncon):
        con = d.contact[i]
        if support not in (con.geom1, con.geom2) or con.efc_address < 0:
            continue
        mujoco.mj_contactForce(m, d, i, f)
        pts.append((R.T @ (con.pos - d.xpos[part]))[:2])
        loads.append(max(float(f[0]), 0.0))
    return np.reshape(np.asarray(pts, np.float64), (-1, 2)), np.asarray(loads, np.float64)


def tumble_model(vertices: np.ndarray, com, mass: float, fullinertia, mu_f: float, mu_s: float,
                 plate_half: float, jaw: Jaw, grip: float, s: PhysicsSettings,
                 impratio: float) -> mujoco.MjModel:
    """The tumble cell (Marigo-Bicchi Fig. 1) for one sampled polyhedron.

    Args:
      vertices: (m, 3) hull vertices, body frame (the caller's part frame), m.
      com: (3,) centre of mass, body frame; mass, fullinertia about it.
      mu_f: upper plate-part coefficient; mu_s: lower plate (support)-part.
      plate_half: half-width of the square upper plate, m.
      jaw: the lower jaw (the support the part rolls on; a plane collider
        of the jaw's size, whose edges the monitor enforces).
      grip: grasp force of the upper plate, N (sets its vertical spring:
        ``kp_z = grip / plate_compliance``).
    """
    spec = mujoco.MjSpec()
    _options(spec, s, impratio)
    # the jaw's collision is a plane's (its size is the jaw's, for rendering):
    # MuJoCo's plane-mesh contact is exact at the part's vertices, where a box
    # jaw (the general convex collider) let the irregular polyhedron's pivot
    # slip 7.6-12.7 mm per roll with the same static contacts, on a 10 m box as
    # on a jaw-sized one.  The jaw's extent is enforced by the monitor instead
    # (a support contact outside it: ``left_workspace``).
    _plane(spec, jaw.centre, jaw.half)
    _part_body(spec, vertices, mass, com, fullinertia)
    _tool(spec, s, (plate_half, plate_half, PLATE_HALF_THICKNESS), grip / s.plate_compliance)
    _pair(spec, "tool", "part", mu_f, "tool_part")
    _pair(spec, "support", "part", mu_s, "part_support")
    _contact_sensor(spec, "tool_contact", "tool", "part", FOUND)
    return _compile(spec)



def layout(m: mujoco.MjModel) -> Layout:
    """The :class:`Layout` of a scene model."""
    part_q = int(m.jnt_qposadr[m.joint("part").id])
    tool_q = int(m.jnt_qposadr[m.joint("tool_x").id])
    part_v = int(m.jnt_dofadr[m.joint("part").id])
    pairs = []
    while True:
        try:
            pairs.append(int(m.pair(f"foot{len(pairs)}").id))
        except KeyError:
            break
    return Layout(nstate=int(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS.value)),
                  nu=int(m.nu), nsensordata=int(m.nsensordata), part_qpos=1 + part_q,
                  tool_qpos=1 + tool_q, part_qvel=1 + m.nq + part_v,
                  tool_contact=int(m.sensor_adr[m.sensor("tool_contact").id]),
                  foot_pairs=tuple(pairs),
                  tool_pair=int(m.pair("tool_part").id))
