"""Diagnostic: the fence's friction in MuJoCo through one reorient push, against
what the quasi-static model on the exact limit surface needs to stick.

Run by hand from the repository root (no assertions)::

    python bench/fence_friction.py                        # nice_stable, fidelity goal 0, rigid
    python bench/fence_friction.py --part rectangle --push 1 --mu-f 0.5 1.5

Why: on rigid corner support MuJoCo's part slips along the fence at fence
frictions where :mod:`kernels.limit_surface` says the contact sticks
(``bench/fidelity.py``: nice_stable goal 0 at mu_f 0.8 slips ~1.5 mm a push,
the model ~0.3 mm).  This script steps the C engine on the host through the
plan's pushes up to ``--push`` (the fidelity bench's plan, goal and support
draw, default settings, planned strokes) and, at every step of that push with
the fence touching the part, reads the fence's contact forces
(``mujoco.mj_contactForce`` in each contact's frame, rotated to the world by
the rows of ``contact.frame``, summed over the fence's contacts): the normal
force, the horizontal and the vertical parts of the friction.  Beside them, at
the part's orientation of that step, the kernel's sticking solution
(``push_motion`` with ``mu_f = inf``, the support's corner loads at rest): the
ratio of tangential to normal fence force it needs.

Printed per fence friction: the contact vertex's slip along the fence (mm per
mm of travel) in physics and in the kernel at ``--mu-f``, the three force
figures, and the part's rocking (its angular velocity about horizontal axes
over its yaw rate; its tilt from level), over the push's orientation (rows
every few degrees).  Last line: ``RESULT fence_horizontal_ratio=H
fence_vertical_w=V kernel_stick_ratio=K tilt_yaw_rate=T slip_share_rocking=S``
(medians over the push's pivoting steps at the first ``--mu-f``, the fence
touching the part and its edge not yet flush: horizontal friction / normal
force, vertical friction / the part's weight, the kernel's required ratio,
tilt rate / yaw rate; and the share of the push's slip made on the steps where
the part rocks, its tilt rate above half its yaw rate).

``--creep`` (with ``--kind``, ``--support``, ``--goal``): every push of the
plan, the length of the contact vertex's path along the fence in physics (its
steps' moves summed, back and forth) and how much of it was made on steps where the fence's friction (summed over its contacts,
horizontal and vertical) was inside 0.9 of its cone, where Coulomb's law
would have the contact stick; beside it the limit-surface model's total slip.
Last line ``RESULT slip_share_inside_cone=S`` (the first ``--mu-f``).
"""
from __future__ import annotations

import argparse
import math
import pathlib
import sys
import warnings

ROOT = pathlib.Path(__file__).resolve().parents[1]
# the package ``robustness`` must win over bench/robustness.py: ROOT first, this folder last
sys.path.insert(0, str(ROOT))
sys.path.append(str(ROOT / "bench"))

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402

import fidelity  # noqa: E402  (the fidelity bench's goals and draws)
from kernels import corner_weights  # noqa: E402
from kernels.limit_surface import push_motion  # noqa: E402
from planning import plan_pose  # noqa: E402
from robustness.physics import PhysicsSettings  # noqa: E402
from robustness.physics import push as rp  # noqa: E402
from robustness.physics import scene  # noqa: E402
from robustness.physics.pushing import FenceStrokes, nominal_polygon, push_parts  # noqa: E402
from sweeps.partfile import load_part  # noqa: E402


def _perp(a):
    return np.array([-a[1], a[0]])


def _run(plan, draws, j, s):
    """Sample ``j`` of ``draws`` in the C engine, stepped through the plan's
    schedule: ``(model, data, body, steps)``, ``steps`` a generator that takes
    one step per item and yields that step's phase (``body``: the part's
    vertices in its body frame)."""
    poly, _ = nominal_polygon(plan)
    parts = push_parts(plan, poly, draws)
    idx = np.flatnonzero(parts.valid)
    models = rp._models(parts, idx, s, s.impratio)
    lay = scene.layout(models[0])
    sched = FenceStrokes(plan, poly, parts, idx, s, False).schedule
    st0 = rp._initial_state(parts, idx, lay, sched, s)[j]
    m = models[j]
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, st0, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    ctrl = sched.controls(0, sched.total, len(idx))[j]
    phase = sched.phase_at(np.arange(sched.total))

    def steps():
        for t in range(sched.total):
            d.ctrl[:] = ctrl[t]
            mujoco.mj_step(m, d)
            yield sched.phases[phase[t]]

    return m, d, np.asarray(parts.body[idx[j]]), steps()


def _fence_force(m, d, f6):
    """The fence's contact force on the part, summed over its contacts: normal
    (N) and friction (3-vector, world frame, N)."""
    tool = m.geom("tool").id
    fn, ft = 0.0, np.zeros(3)
    for i in range(d.ncon):
        c = d.contact[i]
        if tool in (c.geom1, c.geom2):
            mujoco.mj_contactForce(m, d, i, f6)
            fr = c.frame.reshape(3, 3)
            fn += f6[0]
            ft += f6[1] * fr[1] + f6[2] * fr[2]
    return fn, ft


def _contact(plan, body, k):
    """Push ``k``'s contact vertex (index into ``body``) and its unit push direction (world)."""
    q = plan.pushes[k]
    vtx = int(np.argmin(np.linalg.norm(body - (np.asarray(plan.vertices)[q.contact_vertex]
                                              - np.asarray(plan.com)), axis=1)))
    return vtx, np.asarray(q.direction, float) / np.linalg.norm(q.direction)


def step_push(plan, draws, j, k, s):
    """Step sample ``j`` of ``draws`` through the plan up to push ``k``; per
    contact step of push ``k``: (yaw, contact vertex slip coordinate, fence
    travel, normal/W, horizontal friction/W, vertical friction/W, tilt rate,
    yaw rate (rad/s; tilt rate: the part's angular velocity about horizontal
    axes, its rocking), tilt (rad, the body z axis from the vertical))."""
    m, d, body, steps = _run(plan, draws, j, s)
    part = m.body("part").id
    W = float(m.body_mass[part]) * 9.81
    vtx, dw = _contact(plan, body, k)
    tw = _perp(dw)
    x_tool = m.jnt_qposadr[m.joint("tool_x").id]
    f6, v6, rows = np.zeros(6), np.zeros(6), []
    for ph in steps:
        if ph.kind != "push" or ph.step != k:
            continue
        fn, ft = _fence_force(m, d, f6)
        if fn <= 1e-9:
            continue
        R = d.xmat[part].reshape(3, 3)
        pv = d.xpos[part][:2] + R[:2, :2] @ body[vtx]
        mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, part, v6, 0)  # world frame [w, v]
        rows.append((math.atan2(R[1, 0], R[0, 0]), float(pv @ tw), float(d.qpos[x_tool:x_tool + 2] @ dw),
                     fn / W, math.hypot(ft[0], ft[1]) / W, abs(ft[2]) / W,
                     math.hypot(v6[0], v6[1]), abs(v6[2]), math.acos(min(1.0, abs(R[2, 2])))))
    return np.asarray(rows), body, vtx, dw


def creep_by_push(plan, draws, j, s, mu):
    """Step sample ``j`` through the whole plan; per push: (kind, the length of
    the contact vertex's path along the fence in mm (the sum of its steps'
    moves, back and forth), the part of it made on steps where the
    fence's friction (horizontal and vertical, summed over its contacts) is
    inside 0.9 of its cone, i.e. where Coulomb's law would have the contact
    stick)."""
    m, d, body, steps = _run(plan, draws, j, s)
    part = m.body("part").id
    contacts = [_contact(plan, body, k) for k in range(plan.n_pushes)]
    f6 = np.zeros(6)
    total = np.zeros(plan.n_pushes)
    inside = np.zeros(plan.n_pushes)
    last = {}      # push -> the contact vertex's coordinate along the fence at the last touching step
    for ph in steps:
        if ph.kind != "push":
            continue
        k = ph.step
        fn, ft = _fence_force(m, d, f6)
        if fn <= 1e-9:
            last.pop(k, None)
            continue
        vtx, dw = contacts[k]
        R = d.xmat[part].reshape(3, 3)
        u = float((d.xpos[part][:2] + R[:2, :2] @ body[vtx]) @ _perp(dw))
        if k in last:
            step = abs(u - last[k])
            total[k] += step
            if np.linalg.norm(ft) < 0.9 * mu * fn:
                inside[k] += step
        last[k] = u
    return [(q.kind, total[k] * 1e3, inside[k] * 1e3) for k, q in enumerate(plan.pushes)]


def kernel_along(body, weights, vtx, dw, yaws, mu):
    """The kernel's slip rate (per unit travel) at ``mu`` and its sticking ratio
    |f_t| / f_n at each yaw (world frame fence direction ``dw``)."""
    out = []
    for th in yaws:
        c, s_ = math.cos(th), math.sin(th)
        dB = np.array([[c, s_], [-s_, c]]) @ dw
        stick = push_motion(jnp.asarray(body), jnp.asarray(weights), jnp.asarray(body[vtx]),
                            jnp.asarray(dB), jnp.inf)
        f = np.asarray(stick.force)
        slide = push_motion(jnp.asarray(body), jnp.asarray(weights), jnp.asarray(body[vtx]),
                            jnp.asarray(dB), mu)
        out.append((float(slide.slip), abs(f @ _perp(dB)) / (f @ dB)))
    return np.asarray(out)


def main():
    warnings.simplefilter("ignore")
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", default="nice_stable", choices=fidelity.PUSH_PARTS)
    ap.add_argument("--goal", type=int, default=0, help="the fidelity bench's goal index (seed 0)")
    ap.add_argument("--support", default="rigid", choices=("rigid", "uniform", "ring", "tripod"))
    ap.add_argument("--push", type=int, default=0, help="which push of the plan (a reorient push)")
    ap.add_argument("--mu-f", type=float, nargs="+", default=[0.8], choices=fidelity.MU_F)
    ap.add_argument("--kind", default="default", choices=list(fidelity.KINDS),
                    help="the fidelity bench's plan kind")
    ap.add_argument("--creep", action="store_true",
                    help="every push of the plan: the slip, and how much of it was made with the "
                         "fence's friction inside its cone")
    args = ap.parse_args()
    part = load_part(ROOT / "examples" / f"{args.part}.yaml")
    goal = fidelity._push_goals(args.goal + 1, 0)[args.goal]
    plan = plan_pose(part.vertices, (0.0, 0.0, 0.0), goal, com=part.com,
                     options=fidelity.KINDS[args.kind])
    if args.creep:
        return creep(args, plan)
    if plan.pushes[args.push].kind != "reorient":
        sys.exit(f"--push: push {args.push} of this plan is a {plan.pushes[args.push].kind}; "
                 f"reorient pushes: {[i for i, q in enumerate(plan.pushes) if q.kind == 'reorient']}")
    draws = fidelity._params(plan, args.goal, args.support)
    s = PhysicsSettings()
    result = None
    with jax.enable_x64(True):
        for mu in args.mu_f:
            j = fidelity.MU_F.index(mu)
            rows, body, vtx, dw = step_push(plan, draws, j, args.push, s)
            lift = np.asarray(draws.params.friction.corner_lift)
            lift = lift[j] if lift.ndim > 1 else lift
            w = np.asarray(corner_weights(jnp.asarray(body), jnp.asarray(lift)))
            yaw = np.unwrap(rows[:, 0])
            # the pivot only: once the edge lands the part translates flush and needs no friction
            turning = np.abs(yaw - yaw[-1]) > math.radians(0.5)
            rows, yaw = rows[turning], yaw[turning]
            kern = kernel_along(body, w, vtx, dw, yaw[::25], mu)
            print(f"\n{args.part} goal {args.goal} push {args.push} ({args.support}, corner loads "
                  f"{np.round(w[w > 0], 3).tolist()}), mu_f {mu}: {len(rows)} steps of pivoting, "
                  f"physics slip {(rows[-1, 1] - rows[0, 1]) * 1e3:.2f} mm over "
                  f"{(rows[-1, 2] - rows[0, 2]) * 1e3:.1f} mm of travel")
            print(f"{'yaw deg':>8}{'phys slip/travel':>17}{'kernel slip/travel':>19}"
                  f"{'normal/W':>9}{'horiz/normal':>13}{'vert/W':>8}{'kernel stick ratio':>19}"
                  f"{'tilt/yaw rate':>14}{'tilt deg':>9}")
            for i in range(0, len(rows) - 25, max(len(rows) // 12, 1)):
                a, b = i, i + 25
                rate = (rows[b, 1] - rows[a, 1]) / max(rows[b, 2] - rows[a, 2], 1e-12)
                kr = kern[i // 25]
                print(f"{math.degrees(yaw[i]):>8.1f}{rate:>17.3f}{kr[0]:>19.3f}{rows[i, 3]:>9.3f}"
                      f"{rows[i, 4] / rows[i, 3]:>13.3f}{rows[i, 5]:>8.3f}{kr[1]:>19.3f}"
                      f"{np.median(rows[a:b, 6] / rows[a:b, 7]):>14.2f}{math.degrees(rows[i, 8]):>9.2f}")
            h = float(np.median(rows[:, 4] / rows[:, 3]))
            v = float(np.median(rows[:, 5]))
            k = float(np.median(kern[:, 1]))
            # rocking: the part turning about a horizontal axis faster than half its yaw rate
            rock = rows[1:, 6] > 0.5 * rows[1:, 7]
            dslip = np.diff(rows[:, 1])
            share = float(dslip[rock].sum() / dslip.sum()) if dslip.sum() else math.nan
            r = float(np.median(rows[:, 6] / rows[:, 7]))
            print(f"medians: horizontal friction / normal {h:.3f}, vertical friction / weight {v:.3f}, "
                  f"kernel's sticking ratio {k:.3f}, tilt rate / yaw rate {r:.2f}; rocking (tilt rate "
                  f"> half the yaw rate) on {rock.mean():.0%} of the steps, {share:.0%} of the slip")
            result = result or (h, v, k, r, share)
    print(f"RESULT fence_horizontal_ratio={result[0]:.3f} fence_vertical_w={result[1]:.3f} "
          f"kernel_stick_ratio={result[2]:.3f} tilt_yaw_rate={result[3]:.2f} slip_share_rocking={result[4]:.2f}")


def creep(args, plan):
    """``--creep``: per push, physics' slip and its part made inside the cone."""
    draws = fidelity._params(plan, args.goal, args.support)
    s = PhysicsSettings()
    shares = []
    with jax.enable_x64(True):
        ls = fidelity._model_rows(plan, draws, "limit_surface")
        for mu in args.mu_f:
            j = fidelity.MU_F.index(mu)
            rows = creep_by_push(plan, draws, j, s, mu)
            model = float(np.sum(ls["slip"][j])) * 1e3
            print(f"\n{args.part} goal {args.goal} ({args.kind} plan, {args.support}), mu_f {mu}:")
            print(f"{'push':>5}{'kind':>10}{'slip path mm':>16}{'inside the cone':>16}")
            for k, (kind, tot, ins) in enumerate(rows):
                print(f"{k:>5}{kind:>10}{tot:>16.2f}{ins:>16.2f}")
            tot = sum(r[1] for r in rows)
            ins = sum(r[2] for r in rows)
            shares.append(ins / tot if tot else math.nan)
            print(f"total: physics' slip path {tot:.2f} mm, {ins:.2f} mm of it inside the cone; "
                  f"the limit-surface model's slip {model:.2f} mm")
    print(f"RESULT slip_share_inside_cone={shares[0]:.2f}")


if __name__ == "__main__":
    main()
