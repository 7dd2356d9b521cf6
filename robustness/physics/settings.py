"""Settings of the physics rollouts: the cell, the part's material, the
engine, and the thresholds that classify an outcome.

Every default carries the number that justifies it, measured with the C
engine (MuJoCo 4.0.0) on this project's scenes by ``bench/fidelity.py`` and
``bench/physics.py`` (2 CPU cores); the figures are repeated in the closing
note of issue 9.  Units: metres, seconds, radians, kilograms, newtons.
"""
from __future__ import annotations

import dataclasses
import math

BACKENDS = ("auto", "c", "mjx")
#: the impratio advised for the soft contact model (no noslip, MJX): see PhysicsSettings
SOFT_IMPRATIO = 30.0
STROKES = ("planned", "contact")

#: The tumble device's pads need a friction coefficient of at least this much (upper pad
#: ``mu_f``, lower pad ``mu_s``): the part pivots about its bottom edge only if the top
#: pad's friction beats the grasp force's resisting moment, for a cube
#: ``mu_top > 1 + m g / (2 F)`` = 1.25 at the default ``grip_ratio`` 2
#: (:mod:`robustness.physics.tumbling`); below it the plates drag the part instead of
#: rolling it and every sample fails.
TUMBLE_PAD_MU = 1.3


def _positive(obj, name: str) -> None:
    v = getattr(obj, name)
    ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0
    if not ok:
        raise ValueError(f"{name}: expected a finite number > 0, got {v!r}")


def _nonneg_int(obj, name: str) -> None:
    v = getattr(obj, name)
    if not (isinstance(v, int) and not isinstance(v, bool) and v >= 0):
        raise ValueError(f"{name}: expected an integer >= 0, got {v!r}")


@dataclasses.dataclass(frozen=True)
class PhysicsSettings:
    """How the cell runs a plan and how MuJoCo simulates it.

    Engine
      timestep: 4 ms.  On the rectangle's 7-push plan (goal (0.05, 0.05, 1.0))
        2 ms moved the final poses by at most 0.07 mm and the summed slips
        by at most 0.4 mm (of 3.5-9.5 mm); 8 ms moved the poses by up to
        0.44 mm.  Soft contacts need ``timeconst >= 2 timestep`` (20 ms).
      noslip_iterations: 20, impratio: 1: the contact model, the same
        whatever the backend (``backend: auto`` never changes it with the
        hardware).  Soft friction creeps at a contact that should stick;
        MuJoCo's noslip solver removes it.  Measured (``bench/physics.py``,
        C engine) on the rectangle's 15 cm reorient push at mu_f 1.5, as the
        slip along the fence in mm, for the supports tripod (c 8 mm) / rigid
        / uniform: noslip 20 + impratio 1 0.06 / 0.33 / 0.08; no noslip,
        impratio 30: 0.46 / 1.63 / 3.89; no noslip, impratio 100: 0.28 /
        2.60 / 4.54 (and a uniform pad on 29 feet flips over while settling
        at impratio 100).  MJX has no noslip solver: it runs only the soft
        model (``noslip_iterations: 0``, with ``impratio`` as given, 30
        advised), and a rollout asked to run MJX with noslip refuses, naming
        the fields; ``auto`` picks MJX on an accelerator only for the soft
        model.
      iterations, ls_iterations, tolerance: Newton solver settings.
        ls_iterations 50: with 20, the C engine's Newton line search stopped
        short under the soft model on a pad of many feet (uniform: 29 sphere
        contacts; ring: 28) and the solver left unbalanced forces: a 2 cm
        push moved the rectangle 34 mm and turned it 42 degrees (MJX followed
        the plan), so C and MJX differed by 3.8 / 23 mm; with 50, by 0.05 /
        0.27 mm.  Under the default (noslip) model the final poses did not
        move (0.000 mm: the rectangle's 7-push plan, 8 samples on rigid,
        tripod and ring supports): converged steps stop at ``tolerance``
        before either cap.
      cone: elliptic always (pyramidal cones: 156 mm and 114 deg of error on
        a plan that elliptic gets to 8 mm, issue 9).  multiccd stays on
        (MuJoCo 4's default; checked when a model is built): with one contact
        point per pair a flush edge walks sideways by ~5 % of the travel.

    Push cell (Akella-Mason: a fence moved by a robot, open loop)
      push_speed: 5 mm/s of fence travel while in contact (quasi-static for
        15-22 g parts; at 15 mm/s the slip changed sign, issue 9).
      push_offset: 10 mm, the approach: the fence comes down this far before
        the planned contact line (a fixture's clearance; the paper's 30 mm
        hid a fence landing on a part that had slipped by up to 30 mm, which
        is now a ``fence_strike``).
      slow_zone: the last 5 mm of the approach run at ``push_speed`` (the
        first ``push_offset - slow_zone`` at ``approach_speed``).
      approach_speed, transit_speed, lift_speed (m/s), yaw_rate (rad/s).
      retract: back-off along the push direction before lifting, m.
      clearance: fence (or plate) bottom above the part's top when lifted, m.
      settle_time, dwell_time: s, rest before the first push and after each
        push (the pose after a push is read at the end of its dwell).
      part_thickness: extrusion of a polygonal part, m (3 mm: a plate; the
        part file's ``thickness`` sets it).  The fence pushes at half the
        thickness above the support, and that moment shifts the support's
        loads (rear feet unload during a push; the planar models know
        nothing of it).
      part_density: kg/m^3 of the extruded polygon (7800, steel; the part
        file's ``density``): the 40 x 20 x 3 mm rectangle weighs 18.7 g, in
        the 15-22 g range that issue 9 found quasi-static at 5 mm/s.
      flatness: m, how far the corners of a part on ``rigid`` support may
        protrude below its nominal underside (the sampled flatness errors'
        scale: corner i is lowered ``flatness * lift_i``; only their order
        picks the three corners it rests on, :mod:`kernels.support`).
      foot_radius: radius of the support feet of the ``uniform``, ``ring``
        and ``tripod`` families (spheres at the family's points, which stay
        ``kernels.support.FOOT_INSET`` inside the outline), m.
      fence_length, fence_thickness, fence_gap (bottom above the support), m.
      tool_mass: kg of the driven fence / plate (gravity-compensated).
      servo_kp: N/m of the x/y position servos; ``servo_yaw_kp`` N m/rad;
        velocity servos critically damp them (``2 sqrt(kp m)``) and take the
        commanded velocity as their reference, so there is no tracking lag.

    Tumble cell (Marigo-Bicchi Fig. 1: a parallel-jaw gripper whose upper
    plate rolls the part on the lower one, both high-friction pads)
      plate_speed: largest horizontal speed of the upper plate, m/s.
      grip_ratio: grasp force of the upper plate in units of the part's
        weight (passive vertical compliance: a soft spring preloaded to it).
      plate_compliance: spring preload travel, m (the grasp force changes by
        ``grip * dz / plate_compliance`` when the part's top is ``dz`` off the
        nominal prediction).
      polyhedron_density: kg/m^3.

    Thresholds (outcome classification)
      contact_tol: a vertex within this of the fence's face touches it, m.
      flush_tol: an edge within this angle of the fence lies flush, rad.
      tip_angle: a tilt above this at any time is ``tipped``, rad.
      topple_angle: a final tilt above this is ``toppled``, rad.
      face_tol: a face within this angle of the support lies on it, rad.
      slip_stride: steps between the samples of the contact point's
        tangential position from which the slip along the fence is summed.

    Runner
      chunk_steps: steps per engine call (the C rollout and the MJX scan run
        this many steps between host-side bookkeeping; MJX compiles once for
        it).
      threads: C-engine threads (0: one per CPU core available).
      batch: samples simulated together (memory: each engine call returns
        ``batch x chunk_steps`` states and sensor rows; MJX compiles once per
        batch size).
    """

    timestep: float = 0.004
    noslip_iterations: int = 20
    impratio: float = 1.0
    iterations: int = 50
    ls_iterations: int = 50
    tolerance: float = 1e-10

    push_speed: float = 0.005
    push_offset: float = 0.01
    slow_zone: float = 0.005
    approach_speed: float = 0.02
    transit_speed: float = 0.05
    lift_speed: float = 0.02
    yaw_rate: float = 1.0
    retract: float = 0.005
    clearance: float = 0.01
    settle_time: float = 0.6
    dwell_time: float = 0.3

    part_thickness: float = 0.003
    part_density: float = 7800.0
    flatness: float = 2.0e-4
    foot_radius: float = 0.0005
    fence_length: float = 0.2
    fence_thickness: float = 0.005
    fence_gap: float = 0.0002
    tool_mass: float = 1.0
    servo_kp: float = 2.0e4
    servo_yaw_kp: float = 100.0

    plate_speed: float = 0.02
    grip_ratio: float = 2.0
    plate_compliance: float = 0.02
    polyhedron_density: float = 500.0

    contact_tol: float = 0.0005
    flush_tol: float = math.radians(0.5)
    tip_angle: float = math.radians(5.0)
    topple_angle: float = math.radians(45.0)
    face_tol: float = math.radians(5.0)
    slip_stride: int = 10

    chunk_steps: int = 1000
    threads: int = 0
    batch: int = 256

    def __post_init__(self):
        from kernels import FOOT_INSET

        for f in dataclasses.fields(self):
            if f.name in ("noslip_iterations", "iterations", "ls_iterations", "threads"):
                _nonneg_int(self, f.name)
            elif f.name in ("slip_stride", "chunk_steps", "batch"):
                _nonneg_int(self, f.name)
                if getattr(self, f.name) < 1:
                    raise ValueError(f"{f.name}: expected an integer >= 1, got "
                                     f"{getattr(self, f.name)!r}")
            else:
                _positive(self, f.name)
        if self.slow_zone > self.push_offset:
            raise ValueError(f"slow_zone: must not exceed push_offset ({self.push_offset} m), got "
                             f"{self.slow_zone}")
        if self.foot_radius > FOOT_INSET:
            raise ValueError(f"foot_radius: the support feet stay {FOOT_INSET * 1e3:g} mm inside the "
                             f"outline; a radius above that would reach outside it, got "
                             f"{self.foot_radius}")
        if self.fence_gap >= self.part_thickness:
            raise ValueError("fence_gap: must be below part_thickness, or the fence misses the part")


@dataclasses.dataclass(frozen=True)
class PhysicsRun:
    """How :func:`robustness.evaluate` rolls plans out with ``model="mujoco"``.

    Attributes:
      backend: ``"auto"`` (MJX on an accelerator, else the C engine), ``"c"`` or ``"mjx"``.
      stroke: ``"planned"`` (open loop: every fence stroke from the planned pose, as a
        cell without sensing runs the plan) or ``"contact"`` (each stroke measured from
        where the part is: the semantics of the quasi-static and exact models).
      settings: the cell and engine settings (:class:`PhysicsSettings`).
    """

    backend: str = "auto"
    stroke: str = "planned"
    settings: PhysicsSettings = dataclasses.field(default_factory=PhysicsSettings)

    def __post_init__(self):
        if self.backend not in BACKENDS:
            raise ValueError(f"backend: expected one of {BACKENDS}, got {self.backend!r}")
        if self.stroke not in STROKES:
            raise ValueError(f"stroke: expected one of {STROKES}, got {self.stroke!r}")


#: margin (added) over the derived pad friction (:func:`robustness.physics.tumbling.pad_friction_needed`)
PAD_MU_MARGIN = 0.05


def check_pad_friction(friction, kind: str, poly=None, grip_ratio: float = 2.0) -> None:
    """Raise ValueError (naming the field) when a tumble plan is to be rolled out in
    MuJoCo with pads of less friction than the device needs.

    With ``poly`` (a :class:`kernels.polyhedron.Polyhedron`) the need is derived
    for that part (:func:`robustness.physics.tumbling.pad_friction_needed`, every
    face and edge, the upper pad pressing with ``grip_ratio`` weights) plus
    ``PAD_MU_MARGIN``; without it, ``TUMBLE_PAD_MU`` for both pads (the cube's).

    Args:
      friction: a :class:`robustness.FrictionRange` (``mu_f`` upper pad, ``mu_s`` lower).
      kind: ``"push"`` (nothing to check) or ``"tumble"``.
    """
    if kind != "tumble":
        return
    if poly is None:
        need = {"mu_f": TUMBLE_PAD_MU, "mu_s": TUMBLE_PAD_MU}
    else:
        from robustness.physics.tumbling import pad_friction_needed

        top, bottom = pad_friction_needed(poly, grip_ratio)
        need = {"mu_f": round(top + PAD_MU_MARGIN, 2), "mu_s": round(bottom + PAD_MU_MARGIN, 2)}
    for name, pad in (("mu_f", "upper"), ("mu_s", "lower")):
        lo = getattr(friction, name)[0]
        if lo < need[name]:
            raise ValueError(f"friction.{name}: the MuJoCo tumble device's {pad} pad needs a "
                             f"friction coefficient >= {need[name]:g} for this part (below it the "
                             f"plates drag the part instead of rolling it), got {lo:g}; set "
                             f"friction.{name}: [1.5, 1.5]")
