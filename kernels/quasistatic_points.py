r"""Quasi-static fence push of a convex polygon on a point support (the exact
limit surface of the support's points, :mod:`kernels.limit_surface`).

Same contact model, frames, events and outcome as :mod:`kernels.quasistatic`
(read its docstring first); only the support friction differs: instead of an
ellipsoidal limit surface of one ratio ``c``, the part stands on ``S`` points
``p_i`` (body frame, origin at the centre of mass, m) with loads ``w_i``, and
at every instant it moves as :func:`kernels.limit_surface.push_motion` says
(it may stick or slide at the fence, and turn about a loaded support point).

Integration: no time steps.  A push is a sequence of *phases*, each a pivot
about one vertex ``P`` that ends when the next edge lands flush (known in
closed form from the geometry) or when the fence's travel runs out; a stable
flush edge (or the divergent equilibrium ``r x d = 0``) translates with the
fence for the rest of the push.  During a pivot the part's orientation is
fixed by ``beta``, the angle between ``d`` and ``P -> C``, which grows
monotonically (friction never reverses the rotation), so the travel ``s`` and
the slip ``q`` of ``P`` along the fence are integrals over ``beta`` of rates
that depend on the orientation only:

.. math:: \frac{ds}{d\ell} = \frac{\sin\beta}{|\omega|},\qquad
          \frac{dq}{d\ell} = \frac{u \sin\beta}{|\omega|},\qquad
          \ell = \ln\tan(\beta/2)

(``omega``, ``u`` the rotation and slip rates per metre of travel).  In
``ell`` the integrands are bounded and smooth where the contact does not
switch between sticking and sliding (as ``beta -> 0``, ``omega ~ sin beta``;
on the ellipsoid ``ds/dell`` is the constant ``(c^2 + rho^2)/rho``), so a
phase is integrated by 3-point Gauss-Legendre on ``PANELS`` panels (an
open rule: no node on a landing, where a support corner lies on the fence
line and the motion has a kink); a phase that ends mid-way inverts the
cumulative travel on the panel where it crosses (the panel's quadratic
interpolant, Newton's method).  The position is rebuilt from the contact
point, which moves by ``s d + q t``, so ``P`` stays exactly on the fence.  A
convex polygon lands at most ``n`` edges in a push; the loop is capped at
``n + 4`` phases (``truncated`` beyond).

The nodes' motions (:func:`node_motions`): the nodes lie along one pivot, a
few hundredths of a radian apart, so each motion is warm-started from the last
two (:func:`kernels.limit_surface.warm_motion`, a ``lax.scan`` along the
nodes): a few Newton steps where the cold solve brackets from scratch.  A node
whose warm solve does not converge (0.1 % of them on rigid corners and on a
uniform pad of 25 feet, December 2026; the pad's were 10 % before a rejected
sliding step was halved, :data:`kernels.limit_surface.BACKTRACK_MIN`) is solved cold; under ``vmap`` those of the whole
batch are gathered (a ``custom_vmap`` rule), so a rare failure costs its own
cold solve, not one for every sample.  Measured on the nice-stable pentagon's
7-push plan, same draws, 2 CPU cores: rigid corners 165 -> 1,550-1,770
samples/s, a 30-foot ring or pad 60 -> 160; the motions equal the cold
solve's (final poses 4e-12 m apart).  A landing on an edge that holds
translates to the end of the push in the same loop trip.

Profiled (issue 38; same plan, 1,024 samples): each push is one loop trip
(a pivot, its landing and the fold), and the node solves are four fifths of
the time (1 us a node on rigid corners, 14 us on 30 feet), the warm sliding
steps half of a node; the cold fallback 9 % on rigid corners and a third on
``any``; neither the loops' trip overhead (unrolled: 4 %) nor the layout
(the support axis leading, no ``vmap``: 1.27x on one line solve) was worth
a change.  So ``PANELS`` 16 -> 8: rigid corners 2,200 -> 3,900-4,200
samples/s, ``any`` 465 -> 760-830; with a batch's calls on both cores
(:mod:`robustness.replay`, calls of at most 512 samples) 7,700 and 1,300.
Then the solves stopped once settled and the warm sliding steps were taken
only by the nodes that slide (:mod:`kernels.limit_surface`, December 2026):
``bench/robustness.py``, same run before and after, 8,460 -> 11,450 samples/s
on rigid corners and 1,330 -> 2,405 on ``any``; then the pad and rim stood on
their feet alone (:data:`kernels.support.FEET_AT_CORNERS`, 30 -> 25 and 29
-> 24 points on the pentagon): ``any`` 2,240-2,350 -> 2,830-2,890 (two runs
each, alternating), the pads and rims still about 9 times slower per sample
than rigid corners (the node's work is linear in the points); then a sliding
Newton step that overshoots was halved, not the last (the pad's nodes solved
cold 10 % -> 0.1 %, :data:`kernels.limit_surface.BACKTRACK_MIN`): ``any``
2,360-2,490 -> 3,170-3,270 samples/s in ``bench/robustness.py`` (two runs each,
alternating, 1,024 samples; 3,180-3,430 -> 4,320-4,410 on a quieter machine),
a uniform pad alone 1,400 -> 2,700, rigid corners unchanged within noise
(11,000-16,000).
Where a phase's nodes are (same plan, 64 draws): on rigid corners 82 % of
the nodes stick, 7 % turn about a support point and 11 % slide smoothly, and
74 % of the phases stick throughout (``any``: 51 / 11 / 39 %, 36 %).  A phase
that sticks throughout and lands on an edge that holds would be exact at any
node count (no slip, and its travel cancels against the translation after
the landing), but a coarse rule cannot tell such a phase: of 1,792 phases
(256 draws on rigid corners) whose 3 nodes (one panel) all stuck at 80 % of
the friction cone or less, 144 slid somewhere on 96 nodes (32 panels), and at
2 panels 103 (December 2026).  Tried and dropped (December 2026): a phase no
wider than 0.05 in ``ell`` on one panel (3 solves in place of 24: the
pentagon plan's translation pushes turned by their fence angle error, 0.002-0.02
wide, where its reorient pushes are 0.3), each sample its own rule under
``vmap`` (a ``custom_vmap`` switch over one panel, both rules gathered, the
panels): warm, 1,024 draws, 1.2-1.25x on rigid corners and 1.15x on ``any``,
final poses within 5e-8 m; but the phase's compiled code grew three copies of
the node solves, and ``bench/throughput.py``'s ``any`` row (short runs, where
loading the compiled shapes counts) fell from 583 to 102-118 samples/s.
Tried and dropped: the warm sliding
steps in the slip and rotation per metre of advance (rational conditions, no
angles; 1.25x more) converged on fewer nodes next to a kink (a smooth sliding
point beside a turn about a support point: 6 nodes in a row against 3 in
``(g, w)``).

Accuracy: against a fine fixed-step integration of the same motion (the
tests, 2e-7 m), ~1e-7 of the part's size where the contact never switches
and ~1e-5 where it does (a kink of the integrand inside a panel); on an
ellipsoid-like support (many points on a ring) the result approaches
:mod:`kernels.quasistatic`'s.  Against 64 panels, random plans of 6 pushes of
5-50 mm (96 a case, fence friction 0.3/0.8/1.5), final position: 8 panels
median 2e-9-1.3e-5 m, worst 4e-5-4.2e-4 m (16 panels: median 2e-10-3.7e-6,
worst 8.5e-6-3.2e-4) over the nice-stable, biplus and unistable parts on
rigid corners and a uniform pad, the landed edges all the same; 6 panels
miss the fine integration's 2e-7 m.  The heading is the weak side: against 128
panels, 3 random pushes of 5-40 mm on every family of ``any`` at fence friction
0.3/0.8/1.5 (the quadrature test's grid with other draws), the nice-stable
pentagon is within 2.4e-6 m and 1e-8 rad on 8 panels, but the unistable polygon
is off by up to 4.9e-4 m and 2.1e-2 rad (1.2 degrees: a tripod at fence
friction 0.3) on 8 panels and 1.6e-4 m, 3.0e-3 rad on 32 (December 2026; the
landed edges the same; against 256 panels, four seeds: 64 panels still
8.3e-3 rad off, first-order convergence).  The cause, checked against the
cvxpy oracle (``oracles/limit_surface_numpy.py``, equal to 1e-5 at every
node): on a small support (a tripod of 1 mm radius, the contact 35 mm away) the
motion is continuous but turns steeply where the fence contact starts to
slide: the rotation rate goes from 8.2 to 51 rad/m within 0.005 of
``ell`` (a panel is 0.35 wide), so the integrand ``ds/dell`` all but jumps
(0.035 -> 0.004) inside one panel.  Only a push that stops mid-pivot takes its
heading from the travel's inversion (a landing's heading is exact), so the
heading error is confined to pushes that end between landings: on the planned
pushes of the four bundled polygons' default plans (the calibration task,
supports ``rigid`` and ``any``, fence friction 0.3-0.8, 512 samples each,
4,096 in all) 8 panels against 128 leave every final heading the same, final
positions within 8.8e-6 m, and no verdict changed (3 mm, 0.05 rad); rechecked
on ``any`` at fence friction 0.3 and 0.8 after the pad and rim stood on their
feet alone (December 2026): within 1.03e-5 m, the headings the same, no
verdict changed of 4,096.  Not fixed
(a panel split at the switch, located from the sticking force's cone ratio on
the nodes before it, with nodes graded towards it, would; it costs solves on
every sample under ``vmap``).  The ellipsoid's closed form is still
15 times faster on rigid corners and 45-50 times on ``any`` (170,000-230,000
samples/s of the same plan, ``bench/robustness.py``).  What fewer panels would
buy (``bench/quadrature.py``, December 2026, the four bundled polygons' default
plans, rigid and ``any``, fence friction 0.5/0.8/1.5, 7,680 samples against
64 panels): 4 panels 1.7x faster on rigid corners (1.5x on ``any``), worst
final position 0.13 mm apart and 2 verdicts at 3 mm changed; 3 panels 2.1x,
0.32 mm, 4 verdicts; 8 panels 0.06 mm, none (the median sample exact at every
count: a phase that sticks throughout and lands is exact at any).

Assumptions and limits: quasi-static, normal push, fence longer than the part,
one support coefficient (it cancels), loads fixed during the push (no load
transfer by the push's height), Coulomb friction at every support point.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp

from kernels.limit_surface import (Warm, first_start, gathered, kink_base, push_motion,
                                   warm_motion)
from kernels.polygon import PolygonGeometry
from kernels.quasistatic import (SimOutcome, _half_between, _half_to, pivot_contact,
                                 push_outcome, push_start, scan_pushes)

#: quadrature panels per phase (3 PANELS motion solves; accuracy against 64
#: panels in the module docstring)
PANELS = 8


def phase_cap(n: int) -> int:
    """Most phases one push may take on an ``n``-gon (static loop bound)."""
    return int(n) + 4


def _normals(body):
    e = jnp.roll(body, -1, axis=0) - body
    return jnp.stack([e[:, 1], -e[:, 0]], axis=1) / jnp.linalg.norm(e, axis=1, keepdims=True)


def _phase(body, normals, rho, points, weights, mu, d, st):
    """One phase's quadrature: the contact, its landing, and the cumulative
    travel and slip at the panel ends."""
    dtype = body.dtype
    translate, k, r, sigma, target, t_land, t0 = pivot_contact(body, normals, rho, d, st)
    tiny = jnp.finfo(dtype).tiny
    t0s = jnp.maximum(t0, tiny)
    T1 = _half_to(t0s, t_land)
    T1 = jnp.where(T1 > 0, T1, jnp.inf)                    # a landing past beta = pi: never
    l0 = jnp.log(t0s)
    l1 = jnp.log(jnp.minimum(T1, min(1e300, float(jnp.finfo(dtype).max))))   # no overflow in float32
    x = ((jnp.arange(PANELS, dtype=dtype)[:, None] + jnp.asarray(_GAUSS, dtype)[None])
         / PANELS).reshape(-1)                             # 3 Gauss-Legendre nodes a panel
    T = jnp.exp(l0 + x * (l1 - l0))                        # tan(beta / 2) at the nodes
    dt = _half_between(t0s, T)                             # tan(rotation / 2) from the start
    den = 1.0 + dt * dt
    cd, sd = (1.0 - dt * dt) / den, sigma * 2.0 * dt / den
    c, s = st["c"], st["s"]
    cn, sn = c * cd - s * sd, s * cd + c * sd               # orientation at the nodes
    d_b = jnp.stack([cn * d[0] + sn * d[1], -sn * d[0] + cn * d[1]], -1)   # (N, 2)
    mo = node_motions(points, weights, r, d_b, mu)
    sinb = 2.0 * T / (1.0 + T * T)
    gs = sinb / jnp.maximum(jnp.abs(mo.omega), tiny)
    gq = mo.slip * gs
    h = (l1 - l0) / PANELS

    def panels(g):
        g = g.reshape(PANELS, 3)
        return h * (5.0 * g[:, 0] + 8.0 * g[:, 1] + 5.0 * g[:, 2]) / 18.0

    cs = jnp.concatenate([jnp.zeros(1, dtype), jnp.cumsum(panels(gs))])
    cq = jnp.concatenate([jnp.zeros(1, dtype), jnp.cumsum(panels(gq))])
    return dict(translate=translate, k=k, r=r, sigma=sigma, target=target, t_land=t_land,
                t0=t0s, l0=l0, h=h, gs=gs, gq=gq, cs=cs, cq=cq)


def predict(prev: Warm, cur: Warm, two) -> Warm:
    """The next node's start, extrapolated linearly from the last two solutions
    (nodes are evenly spaced in ``ln tan(beta / 2)``, and a motion changes
    smoothly between switches); the sliding point only from two on the same side
    of the cone.  Next to a support point's rest the sticking rate changes by
    more than itself from node to node: from the last solution alone a warm
    solve there needed twice the iterations.  ``two``: both are solutions
    (else ``cur`` is the start)."""
    slid = two & (prev.sigma == cur.sigma)
    return Warm(omega=jnp.where(two, 2.0 * cur.omega - prev.omega, cur.omega),
                g=jnp.where(slid, 2.0 * cur.g - prev.g, cur.g),
                w=jnp.where(slid, 2.0 * cur.w - prev.w, cur.w), sigma=cur.sigma)


def warm_nodes(points, weights, r, d_b, mu, base=None):
    """The motions at a phase's nodes ``d_b`` ((N, 2) fence directions in the
    body frame, in order along the pivot), each warm-started from the last two
    (:func:`kernels.limit_surface.warm_motion` from :func:`predict`; the first
    from :func:`kernels.limit_surface.first_start`).  Returns ``(Motion of (N,)
    arrays, converged (N,))``: a node not converged is to be solved cold."""
    if base is None:
        base = kink_base(points, weights)

    def step(carry, x):
        prev, cur = carry
        dn, k = x
        m, nxt, ok = warm_motion(points, weights, r, dn, mu, predict(prev, cur, k >= 2), base)
        # a node that did not converge still passes on its iterate (nearer than
        # the last start: a first node that needs more steps than a warm one
        # would otherwise fail the whole phase); a non-finite one the last start
        keep = jnp.isfinite(nxt.omega) & jnp.isfinite(nxt.g) & jnp.isfinite(nxt.w)
        nxt = jax.tree_util.tree_map(lambda a, b: jnp.where(keep, a, b), nxt, cur)
        return (cur, nxt), (m, ok)

    first = first_start(points, weights, r, d_b[0])
    return jax.lax.scan(step, (first, first), (d_b, jnp.arange(d_b.shape[0])))[1]


def node_motions(points, weights, r, d_b, mu, base=None):
    """The motions at a phase's nodes (:func:`warm_nodes`), those whose warm
    solve did not converge solved cold (:func:`_resolve`): the same motions as
    :func:`kernels.limit_surface.push_motion` at every node, to the solvers'
    convergence, at a tenth of the cost on rigid corners.  Returns a
    :class:`kernels.limit_surface.Motion` of (N,) arrays."""
    ms, oks = warm_nodes(points, weights, r, d_b, mu, base)
    return _resolve(points, weights, r, d_b, mu, oks, ms)


def _cold_fix(points, weights, r, d_b, mu, ok, ms, chunk, where):
    """Solve cold, ``chunk`` at a time, the motions ``ms`` (flat over the
    leading axis) not ``ok``; ``where(idx)`` gives the flat entries' support
    index and node index."""
    def take(idx):
        b, n = where(idx)
        return points[b], weights[b], r[b], d_b[b, n], mu[b]

    return gathered(push_motion, ~ok, take, ms, chunk)


@jax.custom_batching.custom_vmap
def _resolve(points, weights, r, d_b, mu, ok, ms):
    """The motions ``ms`` at the nodes ``d_b`` with those not ``ok`` solved
    cold.  One support: ``FALLBACK`` nodes a loop trip.  Under ``vmap`` (a
    batch of supports) the nodes left over the whole batch are gathered and
    solved ``chunk`` at a time (:func:`_resolve_batched`), so that a rare
    failure costs its own cold solve, not one for every sample of the batch."""
    one = jax.tree_util.tree_map(lambda x: x[None], (points, weights, r, mu))
    return _cold_fix(*one[:3], d_b[None], one[3], ok, ms, FALLBACK,
                     lambda idx: (jnp.zeros_like(idx), idx))


@_resolve.def_vmap
def _resolve_batched(axis_size, in_batched, points, weights, r, d_b, mu, ok, ms):
    def full(x, batched):
        return x if batched else jnp.broadcast_to(x, (axis_size,) + jnp.shape(x))

    points, weights, r, d_b, mu, ok = (full(x, b) for x, b in zip(
        (points, weights, r, d_b, mu, ok), in_batched[:6]))
    ms = jax.tree_util.tree_map(full, ms, in_batched[6])
    B, N = ok.shape
    flat = jax.tree_util.tree_map(lambda a: a.reshape((B * N,) + a.shape[2:]), ms)
    chunk = max(FALLBACK, (B * N) // CHUNK_SHARE)
    out = _cold_fix(points, weights, r, d_b, mu, ok.reshape(-1), flat, chunk,
                    lambda idx: (idx // N, idx % N))
    out = jax.tree_util.tree_map(lambda a: a.reshape((B, N) + a.shape[1:]), out)
    return out, jax.tree_util.tree_map(lambda _: True, out)


#: nodes solved cold a loop trip where one support's warm solves did not
#: converge (unbatched :func:`_resolve`)
FALLBACK = 2
#: a batch's cold solves a loop trip: its nodes over this (1.6 % of them, about
#: the share that does not converge warm on rigid corners near kinks)
CHUNK_SHARE = 64


def _rotate(st, r, sigma, d, tv, s_used, t, q):
    """Turn the part by ``sigma dt`` (``t = tan(dt/2)``) about its contact point
    ``r`` (body frame), which moves by ``s_used d + q tv`` (world)."""
    c, s = st["c"], st["s"]
    den = 1.0 + t * t
    cd, sd = (1.0 - t * t) / den, sigma * 2.0 * t / den
    cn, sn = c * cd - s * sd, s * cd + c * sd
    norm = jnp.sqrt(cn * cn + sn * sn)
    cn, sn = cn / norm, sn / norm
    rw0 = jnp.stack([c * r[0] - s * r[1], s * r[0] + c * r[1]])
    rw1 = jnp.stack([cn * r[0] - sn * r[1], sn * r[0] + cn * r[1]])
    dtheta = sigma * 2.0 * jnp.arctan(t)
    return st["pos"] + rw0 + s_used * d + q * tv - rw1, st["theta"] + dtheta, cn, sn, dtheta


#: Gauss-Legendre nodes on [0, 1] (weights 5/18, 8/18, 5/18): an open rule, so
#: that no node sits on a landing, where a support corner lies on the fence line
#: and the motion has a kink
_GAUSS = (0.5 - 0.5 * 0.6 ** 0.5, 0.5, 0.5 + 0.5 * 0.6 ** 0.5)


def _quad(g0, g1, g2, x):
    """Integral over [0, x] (and value at x) of the quadratic through the
    panel's Gauss nodes ``(x_k, g_k)``, per unit panel width."""
    e = 0.5 * 0.6 ** 0.5
    # g(x) = g1 + b (x - 1/2) + a (x - 1/2)^2 through the three nodes
    b = (g2 - g0) / (2.0 * e)
    a = (g0 + g2 - 2.0 * g1) / (2.0 * e * e)
    y = x - 0.5
    F = g1 * (y + 0.5) + 0.5 * b * (y * y - 0.25) + a * (y * y * y + 0.125) / 3.0
    return F, g1 + b * y + a * y * y


def _step(body, normals, rho, points, weights, mu, d, tv, st):
    """One loop phase: translate to the end, land the next edge, or (the
    travel running out first) turn by the rotation the travel left gives."""
    ph = _phase(body, normals, rho, points, weights, mu, d, st)
    dtype = body.dtype
    tr = ph["translate"]
    s_left = st["s_left"]
    total = ph["cs"][-1]
    land = (~tr) & (total <= s_left)
    # the panel where the cumulative travel reaches s_left, and the point in it
    m = jnp.clip(jnp.searchsorted(ph["cs"], s_left, side="right") - 1, 0, PANELS - 1)
    g0, g1, g2 = ph["gs"][3 * m], ph["gs"][3 * m + 1], ph["gs"][3 * m + 2]
    need = (s_left - ph["cs"][m]) / jnp.where(ph["h"] > 0, ph["h"], 1.0)
    xa = jnp.clip(need / jnp.maximum(g1, jnp.finfo(dtype).tiny), 0.0, 1.0)

    def newton(_, xx):
        f, df = _quad(g0, g1, g2, xx)
        return jnp.clip(xx - (f - need) / jnp.maximum(df, jnp.finfo(dtype).tiny), 0.0, 1.0)

    xs = jax.lax.fori_loop(0, 6, newton, xa)
    q0, q1, q2 = ph["gq"][3 * m], ph["gq"][3 * m + 1], ph["gq"][3 * m + 2]
    q_end = ph["cq"][m] + ph["h"] * _quad(q0, q1, q2, xs)[0]
    T_end = jnp.exp(ph["l0"] + (m + xs) * ph["h"])
    t_end = jnp.clip(_half_between(ph["t0"], T_end), 0.0, ph["t_land"])
    t = jnp.where(land, ph["t_land"], t_end)
    q = jnp.where(land, ph["cq"][-1], q_end)
    s_used = jnp.where(land, total, s_left)
    pos, theta, cn, sn, dth = _rotate(st, ph["r"], ph["sigma"], d, tv, s_used, t, q)
    new = dict(st)
    new["pos"] = jnp.where(tr, st["pos"] + s_left * d, pos)
    new["theta"] = jnp.where(tr, st["theta"], theta)
    new["c"] = jnp.where(tr, st["c"], cn)
    new["s"] = jnp.where(tr, st["s"], sn)
    new["flush"] = jnp.where(tr, st["flush"], jnp.where(land, ph["target"], -1))
    new["kv"] = jnp.where(tr, st["kv"], ph["k"])
    new["s_left"] = jnp.where(land, s_left - total, 0.0)
    new["rot"] = st["rot"] + jnp.where(tr, 0.0, dth)
    new["slip"] = st["slip"] + jnp.where(tr, 0.0, jnp.abs(q))
    new["landings"] = st["landings"] + land.astype(jnp.int32)
    new["phases"] = st["phases"] + 1
    # a landing on an edge that holds: the translation to the end of the travel is
    # the next loop phase's whole work; done here, that phase's motion solves (half
    # of a typical push's) are not run (the same state as the phase would give)
    cap = phase_cap(body.shape[0])
    hold = pivot_contact(body, normals, rho, d, new)[0]
    fold = land & hold & (new["s_left"] > 0) & (new["phases"] < cap)
    new["pos"] = jnp.where(fold, new["pos"] + new["s_left"] * d, new["pos"])
    new["s_left"] = jnp.where(fold, 0.0, new["s_left"])
    new["phases"] = new["phases"] + fold.astype(new["phases"].dtype)
    return new


def simulate_push(geom: PolygonGeometry, pose, direction, distance, points, weights, mu_f,
                  expected_edge=-1) -> SimOutcome:
    """Simulate one normal fence push on a point support (module docstring).

    Args:
      geom: the part, body frame (possibly perturbed); its ``body`` dtype is
        the computation dtype.
      pose: (3,) start pose ``(x, y, theta)``, world frame (m, rad).
      direction: (2,) direction of the fence's motion, world frame (normalised here).
      distance: fence travel in contact with the part, m (>= 0).
      points: (S, 2) support points, body frame (origin at the centre of mass), m.
      weights: (S,) their loads (>= 0, sum 1, centroid at the centre of mass;
        zero-weight points are padding).
      mu_f: fence-part friction coefficient (>= 0; ``inf``: never slips).
      expected_edge: hull edge the push should end flush on (-1 to skip).

    Returns:
      :class:`kernels.quasistatic.SimOutcome` (``phases``: loop phases).  Pure,
      jit- and vmap-able over every array argument.
    """
    body = geom.body
    dtype = body.dtype
    n = body.shape[0]
    points = jnp.asarray(points, dtype)
    weights = jnp.asarray(weights, dtype)
    mu = jnp.asarray(mu_f, dtype)
    normals = _normals(body)
    rho = jnp.linalg.norm(body, axis=1)
    pose, d, tv, distance, h0, st = push_start(geom, pose, direction, distance)
    cap = phase_cap(n)
    st = jax.lax.while_loop(
        lambda v: (v["s_left"] > 0) & (v["phases"] < cap),
        lambda v: _step(body, normals, rho, points, weights, mu, d, tv, v), st)
    return push_outcome(body, pose, d, distance, h0, st, expected_edge, st["s_left"] > 0)


def simulate_pushes(geom: PolygonGeometry, pose, directions, distances, points, weights, mu_f,
                    expected_edges=None, active=None):
    """A push plan on a point support with ``lax.scan`` (arguments as
    :func:`kernels.quasistatic.simulate_pushes`, with ``(points, weights)`` in
    place of ``c``).  Returns ``(final_pose, outcomes)``."""
    return scan_pushes(lambda p, dvec, dist, exp: simulate_push(geom, p, dvec, dist, points,
                                                                weights, mu_f, exp),
                       geom.body.dtype, pose, directions, distances, expected_edges, active)
