"""The push cell: per-sample parts, the fence's open-loop schedule, and the
slip and strike tracker.

Execution (as a cell with a fence on a robot runs a plan, open loop)
--------------------------------------------------------------------
For push ``k`` the robot knows only the PLAN: the planned pose before the
push (the plan's start, or the previous push's ``pose_after``) of the
nominal part.  From it, the planned contact line ``h = min_j <p_j, d>`` of
the nominal hull along the planned direction ``d``, and the fence is centred
on the centre of mass's line along ``d``.  The fence (its pushing face) is
lowered ``push_offset`` (10 mm) before that line, moved along
the sample's direction (``d`` rotated by the sampled fence angle error; the
fence's face stays normal to its motion) at ``approach_speed`` and, for the
last ``slow_zone`` before the planned contact and the sampled push distance
``max(0, D (1 + rel) + abs)`` after it, at ``push_speed``; it dwells, backs
off by ``retract``, lifts ``clearance`` above the part and moves, lifted, to
the next push's start.  Where the part really is plays no role in the fence's
path: if it is not where the plan says, the fence meets it earlier or later
(its in-contact travel differs from the quasi-static and exact models',
which start every push with the fence touching the part), strikes it while
coming down, or misses it.
"""
from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from kernels import polygon_hull_changed, rot2_np
from robustness.physics import geometry as geo
from robustness.physics.monitor import fence_frame, vertices_world
from robustness.physics.schedule import Phase, Schedule, steps_for, transit_steps, unwrap_near


@dataclasses.dataclass
class PushParts:
    """Per-sample parts and execution errors (numpy, float64; n samples).

    Attributes:
      valid: (n,) hull unchanged (only these are simulated).
      body: (n, h, 2) perturbed hull in the nominal order, relative to the
        perturbed centre of mass, m.
      dcom: (n, 2) centre-of-mass offset, part frame, m.
      family: (n,) support family codes (:data:`kernels.support.CODES`).
      feet: (n, F, 2) support feet relative to the perturbed centre of mass
        (body frame, m), ``n_feet`` (n,) of them used (0 for ``rigid``).
      lift: (n, h) the corners' flatness ranks (rigid; zeros otherwise).
      c: (n,) sampled limit-surface ratio, m; ``c_support`` (n,) the one the
        family's loads give on the perturbed part (what the scene should
        realise); mu_f, mu_s: (n,).
      start: (n, 3) start pose of the perturbed centre of mass (world, m, rad).
      fence_angle: (n, P) rad; distance: (n, P) sampled push distances, m.
    """

    valid: np.ndarray
    body: np.ndarray
    dcom: np.ndarray
    family: np.ndarray
    feet: np.ndarray
    n_feet: np.ndarray
    lift: np.ndarray
    c: np.ndarray
    c_support: np.ndarray
    mu_f: np.ndarray
    mu_s: np.ndarray
    start: np.ndarray
    fence_angle: np.ndarray
    distance: np.ndarray


_hull_changed = jax.jit(jax.vmap(polygon_hull_changed, in_axes=(0, 0, None)))


def nominal_polygon(plan):
    """The plan's part as a :class:`kernels.polygon.Polygon` and the planned
    hull edge of each push."""
    poly = plan.nominal_part()   # the plan interface
    return poly, [poly.caller_edge_to_hull(p.edge) for p in plan.pushes]


def push_parts(plan, poly, draws) -> PushParts:
    """Per-sample parts of drawn perturbations (``Draws``; the semantics of
    :func:`robustness.replay.run_push`), each with the support of its
    family (:func:`robustness.physics.geometry.support_of`)."""
    n = draws.n
    p = jax.tree_util.tree_map(lambda x: np.asarray(x, np.float64), draws.broadcast())
    g, f, e = p.geometry, p.friction, p.execution
    V = np.asarray(plan.vertices, np.float64)[None] + g.vertex_offset
    com = np.asarray(plan.com, np.float64)[None] + g.com_offset
    hi = np.asarray(poly.hull_index)
    with jax.enable_x64(True):
        changed = np.asarray(_hull_changed(jnp.asarray(V), jnp.asarray(com), jnp.asarray(hi)))
    body = V[:, hi] - com[:, None, :]
    h = body.shape[1]
    family = np.broadcast_to(np.asarray(f.family, np.int64), (n,)).copy()
    lift = np.broadcast_to(np.asarray(f.corner_lift, np.float64), (n, h)).copy()
    c = np.broadcast_to(np.asarray(f.c, np.float64), (n,)).copy()
    made = [geo.support_of(int(k), b, float(ci), li) for k, b, ci, li in zip(family, body, c, lift)]
    F = max([len(m[0]) for m in made] + [0])
    feet = np.zeros((n, F, 2))
    n_feet = np.zeros(n, np.int64)
    c_support = np.zeros(n)
    for i, (pts, w) in enumerate(made):
        n_feet[i] = len(pts)
        feet[i, :len(pts)] = pts
        at = pts if len(pts) else body[i]
        c_support[i] = float(w @ np.linalg.norm(at, axis=1))
    th0 = plan.start[2] + e.start_offset[:, 2]
    c0, s0 = np.cos(th0), np.sin(th0)
    dc = g.com_offset
    start = np.stack([plan.start[0] + e.start_offset[:, 0] + c0 * dc[:, 0] - s0 * dc[:, 1],
                      plan.start[1] + e.start_offset[:, 1] + s0 * dc[:, 0] + c0 * dc[:, 1], th0], -1)
    P = len(plan.pushes)
    dist0 = np.array([q.distance for q in plan.pushes], np.float64).reshape(1, P)
    dist = np.maximum(dist0 * (1.0 + e.distance_rel.reshape(n, P))
                      + e.distance_abs.reshape(n, P), 0.0)
    return PushParts(valid=~changed, body=body, dcom=dc, family=family, feet=feet, n_feet=n_feet,
                     lift=lift, c=c, c_support=c_support, mu_f=f.mu_f, mu_s=f.mu_s, start=start,
                     fence_angle=e.fence_angle.reshape(n, P), distance=dist)


def fence_heights(s):
    """Tool-origin heights (m) of the fence when pushing and when lifted, and
    its half-height."""
    half = 0.5 * (s.foot_radius + s.part_thickness + s.clearance)
    low = s.fence_gap + half
    high = s.foot_radius + s.part_thickness + s.clearance + half
    return low, high, half


def push_directions(plan, parts: PushParts, idx: np.ndarray) -> np.ndarray:
    """(n, P, 2) directions of the fence's motion (planned, rotated by the
    sampled fence angle errors), world frame."""
    d0 = np.array([q.direction for q in plan.pushes], np.float64)
    ang = np.arctan2(d0[:, 1], d0[:, 0])[None] + parts.fence_angle[idx]
    return np.stack([np.cos(ang), np.sin(ang)], -1)


class FenceStrokes:
    """The fence's schedule for samples ``idx`` (module docstring).

    Each push's stroke is fixed by ``face0`` (n, 2): where the fence's
    pushing face is lowered, ``push_offset`` before the contact line, at the
    lateral position of the centre of mass.  ``stroke="planned"`` (open loop,
    the default of the rollouts) takes it from the PLANNED pose and the
    nominal part; ``stroke="contact"`` (a cell that measures the part before
    each push, as the quasi-static and exact models assume: the fence's
    in-contact travel is the sampled distance) from the actual pose and the
    perturbed part, set by :meth:`retarget` at the hook before the push.

    Hooks (host actions, see :mod:`robustness.physics.runner`) follow the
    ``settle`` phase (the support's loads are measured) and, for contact strokes
    (``contact=True``), every ``lift`` phase (the coming push's stroke).

    Attributes:
      schedule: the :class:`Schedule`.
      directions: (n, P, 2) the fence's motion per push (world).
      phase_of: per push, a dict phase kind -> phase index.
    """

    def __init__(self, plan, poly, parts: PushParts, idx: np.ndarray, s,
                 contact: bool = False):
        self.s = s
        self.low, self.high, _ = fence_heights(s)
        dt = s.timestep
        n = len(idx)
        self.directions = push_directions(plan, parts, idx)
        ang = np.arctan2(self.directions[..., 1], self.directions[..., 0])
        self.yaw = np.zeros_like(ang)
        prev = np.zeros(n)
        for k in range(ang.shape[1]):
            self.yaw[:, k] = prev = unwrap_near(ang[:, k], prev)
        self.D = parts.distance[idx]
        poses = [plan.start] + [q.pose_after for q in plan.pushes[:-1]]
        self.face0 = np.zeros((n, len(plan.pushes), 2))
        for k, (push, pose) in enumerate(zip(plan.pushes, poses)):
            d0 = np.asarray(push.direction, np.float64)
            d0 = d0 / np.linalg.norm(d0)
            t0 = np.array([-d0[1], d0[0]])
            W = poly.body @ rot2_np(pose[2]).T + np.asarray(pose[:2])
            self.face0[:, k] = (np.min(W @ d0) - s.push_offset) * d0 + float(np.dot(pose[:2], t0)) * t0
        nz = steps_for((self.high - self.low) / s.lift_speed, dt)
        phases, self.phase_of = [], []
        prev_lifted = None
        for k, push in enumerate(plan.pushes):
            tg = self._targets(k)
            idx_k = {}
            if k == 0:
                phases.append(Phase("settle", -1, steps_for(s.settle_time, dt), tg["lifted"],
                                    tg["lifted"], hook=True))
            else:
                idx_k["transit"] = len(phases)
                phases.append(Phase("transit", k, transit_steps(prev_lifted, tg["lifted"],
                                                                s.transit_speed, s.yaw_rate, dt),
                                    prev_lifted, tg["lifted"]))
            steps = {"descend": nz,
                     "approach": steps_for((s.push_offset - s.slow_zone) / s.approach_speed, dt),
                     "push": steps_for((s.slow_zone + push.distance) / s.push_speed, dt),
                     "dwell": steps_for(s.dwell_time, dt),
                     "retract": steps_for(s.retract / s.lift_speed, dt), "lift": nz}
            for kind, ns in steps.items():
                idx_k[kind] = len(phases)
                a, b = tg[kind]
                phases.append(Phase(kind, k, ns, a, b, hook=contact and kind == "lift"))
            self.phase_of.append(idx_k)
            prev_lifted = tg["lift"][1]
        phases.append(Phase("final", -1, steps_for(s.dwell_time, dt), prev_lifted, prev_lifted))
        self.schedule = Schedule(phases, dt)

    def _targets(self, k: int) -> dict:
        """Start and end targets of push ``k``'s phases from its ``face0``."""
        s, n = self.s, self.face0.shape[0]
        d, yaw, D = self.directions[:, k], self.yaw[:, k], self.D[:, k]

        def at(travel, z):
            xy = self.face0[:, k] + (np.asarray(travel)[..., None] - 0.5 * s.fence_thickness) * d
            return np.c_[xy, np.full(n, z), yaw]

        lowered, lifted = at(np.zeros(n), self.low), at(np.zeros(n), self.high)
        a_end = at(np.full(n, s.push_offset - s.slow_zone), self.low)
        p_end = at(s.push_offset + D, self.low)
        r_end = at(s.push_offset + D - s.retract, self.low)
        up = at(s.push_offset + D - s.retract, self.high)
        return {"lifted": lifted, "descend": (lifted, lowered), "approach": (lowered, a_end),
                "push": (a_end, p_end), "dwell": (p_end, p_end), "retract": (p_end, r_end),
                "lift": (r_end, up)}

    def retarget(self, k: int, state: np.ndarray, layout, body: np.ndarray) -> None:
        """Contact strokes: set push ``k``'s ``face0`` from the part's actual
        pose in ``state`` (perturbed hull ``body``, (n, h, 2))."""
        from robustness.physics.monitor import vertices_world

        d = self.directions[:, k]
        t = np.stack([-d[:, 1], d[:, 0]], -1)
        v = vertices_world(state, layout, body)
        h = np.min(np.einsum("nhi,ni->nh", v, d), axis=1)
        com = state[:, layout.part_qpos:layout.part_qpos + 2]
        self.face0[:, k] = (h - self.s.push_offset)[:, None] * d \
            + np.einsum("ni,ni->n", com, t)[:, None] * t
        tg = self._targets(k)
        ph = self.schedule.phases
        for kind, i in self.phase_of[k].items():
            if kind == "transit":
                ph[i].end = tg["lifted"]
            else:
                ph[i].start, ph[i].end = tg[kind]
        nxt = self.phase_of[k + 1] if k + 1 < len(self.phase_of) else None
        if nxt is not None:
            ph[nxt["transit"]].start = tg["lift"][1]
        else:
            ph[-1].start = ph[-1].end = tg["lift"][1]


class PushTracker:
    """Per push: whether the fence touched the part, the slip along the fence;
    over the run: fence strikes.

    The slip of push ``k`` sums, over the samples of its ``push`` and
    ``dwell`` phases every ``stride`` steps, the tangential displacement
    relative to the fence of the vertex that was closest to the fence's face
    at the earlier sample, when that vertex is within ``contact_tol`` of the
    face at both (a sticking contact adds nothing; a flush edge that slides
    adds its slide once).  A strike is a fence-part contact while the fence
    moves lifted or comes down (``transit``, ``descend``).
    """

    def __init__(self, schedule, layout, body: np.ndarray, n_pushes: int, s):
        self.schedule, self.layout, self.body = schedule, layout, body
        n = body.shape[0]
        self.thickness, self.tol, self.stride = s.fence_thickness, s.contact_tol, s.slip_stride
        self.slip = np.zeros((n, n_pushes))
        self.contact = np.zeros((n, n_pushes), bool)
        self.strike = np.zeros(n, bool)
        self._prev = None                    # (k, dist (n, h), tau (n, h))

    def update(self, i0: int, states: np.ndarray, sens: np.ndarray) -> None:
        K = states.shape[1]
        sch = self.schedule
        ph = sch.phase_at(np.arange(i0, i0 + K))
        kinds = np.array([sch.phases[p].kind for p in ph])
        steps = np.array([sch.phases[p].step for p in ph])
        touch = sens[:, :, self.layout.tool_contact] > 0.5
        self.strike |= (touch & np.isin(kinds, ("transit", "descend"))[None]).any(axis=1)
        for k in np.unique(steps[np.isin(kinds, ("approach", "push", "dwell"))]):
            sel = (steps == k) & np.isin(kinds, ("approach", "push", "dwell"))
            self.contact[:, k] |= touch[:, sel].any(axis=1)
        rel = np.arange(i0, i0 + K) - sch.first[ph]
        last = rel == np.array([sch.phases[p].nstep - 1 for p in ph])
        pick = np.isin(kinds, ("push", "dwell")) & ((rel % self.stride == 0) | last)
        js = np.flatnonzero(pick)
        if js.size == 0:
            return
        st = states[:, js]
        face, d, t = fence_frame(st, self.layout, self.thickness)      # (n, J, 2)
        v = vertices_world(st, self.layout, self.body)                 # (n, J, h, 2)
        rel_v = v - face[:, :, None, :]
        dist = np.einsum("njhi,nji->njh", rel_v, d)
        tau = np.einsum("njhi,nji->njh", rel_v, t)
        rows = np.arange(st.shape[0])
        for j, jj in enumerate(js):
            k = int(steps[jj])
            if self._prev is not None and self._prev[0] == k:
                _, pd, pt = self._prev
                cv = np.argmin(pd, axis=1)
                ok = (pd[rows, cv] <= self.tol) & (dist[rows, j, cv] <= self.tol)
                self.slip[:, k] += np.where(ok, np.abs(tau[rows, j, cv] - pt[rows, cv]), 0.0)
            self._prev = (k, dist[:, j], tau[:, j])
