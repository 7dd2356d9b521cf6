"""Monte-Carlo evaluation of push and tumble plans on perturbed parts.

``evaluate(plan, sampler, n, key)`` draws ``n`` perturbations
(:mod:`robustness.samplers`), replays the plan on every one of them in
jit-compiled batches (no per-sample host work: the Python loop is over
chunks of ``chunk`` samples), and returns an :class:`Evaluation`: a
per-sample table and a summary.

Compilation: once per shape bucket, not per plan or configuration.  Plans
are padded to a length bucket (pushes: the next power of two >= 2; padding
pushes are skipped by ``lax.cond``; tumbles: >= 16, padding steps are
identities), the caller's vertex list to a power of two >= 4, the last
partial chunk to a power of two >= 8; the plan's numbers and index tables are
traced arguments and every per-sample input is broadcast to a leading sample
axis, so the compiled push batch serves every plan of every part with the
same hull size in one length bucket, at any tolerances and sample counts
(tumbles: every plan of one part, the topology being static).  The sampler
is compiled once per structure (:mod:`robustness.samplers`).  Inside a
compiled call the samples run in blocks of ``BLOCK`` (``lax.map``) so that
their intermediates stay in cache.

Push plans (:class:`planning.pushing.plan.PushPlan`)
-------------------------------------------------
Per sample: the caller's vertices and the centre of mass are offset, the
hull (in the NOMINAL order) is re-expressed about the perturbed centre of mass
and its push geometry rebuilt (:func:`kernels.polygon.polygon_geometry`); the
start pose is offset; each push direction is rotated by its fence angle error;
each distance becomes ``max(0, distance (1 + rel) + abs)``.  Then either

* ``model="quasistatic"``: :func:`kernels.quasistatic.simulate_pushes` with the
  sample's limit-surface ratio ``c`` and fence friction ``mu_f`` (incomplete
  reorientation, slip and a wrong landing edge can happen), or
* ``model="exact"``: :func:`kernels.push.replay_pushes` (the paper's model:
  no slip, the slowest rotation support friction allows).

**Reference point.**  Poses are those of the part's frame with the NOMINAL
centre of mass as reference point (as in :mod:`robustness.bounds`): the robot
places the physical part by its nominal frame, so the perturbed centre of mass
starts at ``start_xy + R(theta0) dcom`` and the reported final position is the
simulated centre of mass minus ``R(theta_f) dcom``.  With zero tolerances the
reported pose is exactly the plan's prediction.

Tumble plans (:class:`planning.tumbling.plan.TumblePlan`)
-------------------------------------------------------
Per sample: :func:`kernels.polyhedron.tumble_geometry` on the perturbed
vertices and centre of mass (``jax.vmap``), then the tumbles are replayed,
each followed by the sample's planar slip ``(dx, dy, dtheta)`` (world frame,
the part turning about its face frame's origin).  The replay is
:func:`kernels.tumble.tumble`'s, regrouped (:func:`_tumble_block`): the faces
visited do not depend on the sample, so each directed edge's planar motion is
computed once per sample and the plan multiplies them (a test checks it
against the kernel, sample by sample, to 1e-13).  The kernel always uses the
nominal face cycles; the same compiled call checks every perturbed hull
(:func:`kernels.hulls.polyhedron_hull_verdict_batch`, in float64, equal to
the host reference :func:`kernels.polyhedron.combinatorics_changed`, which
is asked only for the rare samples the JAX check leaves undecided), and a
sample whose hull has other faces is marked ``combinatorics_changed`` (never
silently counted as a success).  ``model`` does not apply (tumbling is pure
geometry): the exact replay is used and recorded.

**Reference frames.**  A configuration names the pose of a face frame, which
is defined by the vertices and the centre of mass; a perturbed part's own face
frames are shifted and turned by O(tolerance).  The robot places the physical
part by the NOMINAL frame of the start face, and the goal is a pose of the
NOMINAL frame of the goal face.  So the start configuration is converted into
the perturbed face frame's configuration, and the final configuration back
into the nominal frame of the face on the plane.  A centre-of-mass offset
therefore moves nothing (tumbling about edges does not depend on it).

Success, failure modes
----------------------
A sample succeeds when its kernel model is valid (no hull / combinatorics
change) and its final pose is within ``pos_eps_m`` (Euclidean, m) AND
``theta_eps_rad`` (|wrapped difference|) of the goal, and (tumbles) the goal
face is on the plane.  A failed sample gets the first failure mode that
applies, in this order: ``hull_changed`` (polygon no longer convex in the
nominal order, or its centre of mass outside) / ``combinatorics_changed``
(polyhedron); ``incomplete_reorientation`` (a push ended before an edge lay
flush); ``wrong_edge`` (a push ended flush on another edge than planned);
``wrong_face`` (tumbles: an invalid tumble or another face on the plane at the
end); ``slip`` (slip distance at least ``slip_fraction`` x ``pos_eps_m``; for
tumbles the summed execution slip); ``position``; ``orientation``.  Success
has ``failure_mode = "none"``.

A push still moving at the quasi-static kernel's phase cap (never seen) is
warned about and counted as ``incomplete_reorientation``, outside the model.

Summary: success rate with its two-sided Clopper-Pearson interval
(``ci_low``, ``ci_high``) and the ONE-sided lower bound at the same
confidence (``ci_low_one_sided``: what a probability claim uses), quantiles of the
errors, the worst sample (largest ``max(err_pos / pos_eps, |err_theta| /
theta_eps)``), failure counts, and the analytic bound of
:mod:`robustness.bounds` beside the empirical maximum over the samples that
satisfy the bound's assumptions (``in_bound_model``: valid model, every push
complete on its planned edge, no slip at the fence; tumbles: valid tumbles on
the planned faces, combinatorics unchanged; the tumble bound covers the vertex
tolerance, the start error and the slips, see :func:`_tumble_bound`).  An
empirical maximum above the bound is ``bound_violated``: a FINDING, warned
loudly (:class:`BoundViolation`) and stored, never clipped.  The comparison allows only rounding: a relative
1e-9 and an absolute ``1e3 eps sqrt(steps + 1)`` (times the plan's length scale
for positions), ``eps`` the kernels' dtype's machine epsilon.
"""
from __future__ import annotations

import dataclasses
import functools
import math
import time
import warnings
from typing import Optional

import jax
import jax.numpy as jnp
import numpy as np
import pandas as pd

from kernels import polygon as pg
from kernels.hulls import polygon_hull_changed
from kernels.planar import rot2, wrap_angle, wrap_angle_np
from kernels.precision import float64
from robustness import stats
from robustness.hulls import face_merge_tol, polyhedron_combinatorics_changed
from robustness.samplers import Sampler, parameter_columns
from robustness.tolerances import ExecutionTolerance, FrictionRange, GeometryTolerance
from robustness.tables import FAILURE_MODES

MODELS = ("quasistatic", "exact")
DEFAULT_POS_EPS = 1e-3      # m
DEFAULT_THETA_EPS = math.radians(1.0)  # rad
SLIP_FRACTION = 0.25
BOUND_RTOL = 1e-9


class BoundViolation(UserWarning):
    """A Monte-Carlo sample exceeded an analytic bound: a finding, not noise."""


@dataclasses.dataclass(frozen=True, eq=False)
class Evaluation:
    """Result of :func:`evaluate`.

    Attributes:
      samples: one row per sample (columns: ``results/README.md``, table
        ``samples``; parameter columns in ``param_columns``).
      summary: dict, the ``summary`` table's row.
      param_columns: names of the sampled-parameter columns of ``samples``.
      kind: ``"push"`` or ``"tumble"``; model: the model used.
      bound: the analytic bound dict (or ``None`` when it does not apply).
      seconds: wall time of the evaluation (not in the tables, which are
        bit-for-bit reproducible).
    """

    samples: pd.DataFrame
    summary: dict
    param_columns: tuple
    kind: str
    model: str
    bound: Optional[dict]
    seconds: float = math.nan

    def summary_frame(self) -> pd.DataFrame:
        """The summary as a one-row DataFrame."""
        return pd.DataFrame([self.summary])


# --------------------------------------------------------------------------
# Batches: one compiled call per shape bucket
# --------------------------------------------------------------------------
# The jitted batch functions below see only arrays: every per-sample input is
# broadcast to a leading sample axis (whatever the sampler's vmap axes), the
# plan's numbers and index tables are traced arguments, the plan is padded to
# a length bucket and the samples to a chunk size.  So one compilation serves
# every plan of a part (push plans: every part with the same hull size) whose
# length falls in the same bucket, every tolerance setting and every sample
# count of a study; ``_push_batch._cache_size()`` counts them (tests).
def _bucket(k: int, minimum: int) -> int:
    """Padded length: the next power of two >= max(k, minimum) (bounds recompiles)."""
    return 1 << max(int(minimum) - 1, int(k) - 1, 0).bit_length()


def _chunks(n: int, chunk: int):
    """``(lo, hi, size)`` of each compiled call: full chunks of ``chunk``
    samples, then the rest padded to a power of two (>= 8, <= chunk)."""
    out = []
    for lo in range(0, n, chunk):
        hi = min(n, lo + chunk)
        out.append((lo, hi, chunk if hi - lo == chunk else min(chunk, _bucket(hi - lo, 8))))
    return out


def _rows(x, axis, n: int):
    """Per-sample array: ``x`` itself (batched) or ``x`` broadcast to ``n`` rows."""
    x = jnp.asarray(x)
    return x if axis == 0 else jnp.broadcast_to(x, (n,) + x.shape)


def _pad_axis(x, k: int, axis: int = 1):
    """Zero-pad ``x`` along ``axis`` to length ``k``."""
    widths = [(0, 0)] * x.ndim
    widths[axis] = (0, k - x.shape[axis])
    return jnp.pad(x, widths)


def _run_chunks(fn, nom, rows: dict, n: int, chunk: int, *args) -> dict:
    """``fn(nom, rows_chunk, *args)`` over chunks of the per-sample ``rows``
    (each padded by repeating its first sample); returns numpy arrays of n rows."""
    outs = []
    for lo, hi, size in _chunks(n, chunk):
        part = {}
        for k, x in rows.items():
            x = x[lo:hi]
            if size > hi - lo:
                x = jnp.concatenate([x, jnp.broadcast_to(x[:1], (size - (hi - lo),) + x.shape[1:])])
            part[k] = x
        outs.append((hi - lo, fn(nom, part, *args)))
    return {k: np.concatenate([np.asarray(o[k])[:m] for m, o in outs]) for k in outs[0][1]}


# --------------------------------------------------------------------------
# Push plans
# --------------------------------------------------------------------------
def _push_one(nom: dict, q: dict, model: str):
    dt = nom["V0"].dtype
    V = nom["V0"] + q["dv"]
    com = nom["com0"] + q["dc"]
    hi = nom["hull"]
    geom = pg.polygon_geometry(V[hi] - com[None, :])
    changed = polygon_hull_changed(V, com, hi)
    start, so = nom["start"], q["start"]
    th0 = start[2] + so[2]
    pose0 = jnp.concatenate([start[:2] + so[:2] + rot2(th0) @ q["dc"], th0[None]])
    ang = nom["ang"] + q["fence"]
    dirs = jnp.stack([jnp.cos(ang), jnp.sin(ang)], axis=-1)
    active = nom["active"]
    dists = jnp.maximum(nom["dist"] * (1.0 + q["rel"]) + q["abs"], 0.0)
    dists = jnp.where(active, dists, 0.0)  # padding pushes are no-ops
    if model == "exact":
        from kernels.push import replay_pushes

        final, outs = replay_pushes(geom, pose0, dirs, dists)
        slip, trunc = jnp.zeros((), dt), jnp.asarray(False)
    else:
        from kernels.quasistatic import simulate_pushes

        final, outs = simulate_pushes(geom, pose0, dirs, dists, q["c"], q["mu"],
                                      expected_edges=nom["planned"], active=active)
        slip = jnp.sum(jnp.where(active, outs.slip, 0.0))
        trunc = jnp.any(active & outs.truncated)
    ref = final[:2] - rot2(final[2]) @ q["dc"]
    return dict(x=ref[0], y=ref[1], theta=final[2], edges=outs.edge, complete=outs.complete,
                slip=slip, changed=changed, truncated=trunc)


def _blocks(fn, q: dict, block: int):
    """``fn`` over blocks of ``block`` samples of the per-sample arrays ``q``
    (``lax.map``; the whole batch when it does not divide): a block's
    intermediates stay in cache, which on a CPU is worth 1.5-2.5x."""
    n = jax.tree_util.tree_leaves(q)[0].shape[0]
    if n <= block or n % block:
        return fn(q)
    qb = jax.tree_util.tree_map(lambda x: x.reshape((n // block, block) + x.shape[1:]), q)
    out = jax.lax.map(fn, qb)
    return jax.tree_util.tree_map(lambda x: x.reshape((n,) + x.shape[2:]), out)


BLOCK = 512   # samples per block inside a compiled call


@functools.partial(jax.jit, static_argnames=("model",))
def _push_batch(nom, q, model):
    one = functools.partial(_push_one, model=model)
    return _blocks(lambda b: jax.vmap(one, in_axes=(None, 0))(nom, b), q, BLOCK)


def _push_nominal(plan):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", pg.PartWarning)
        poly = pg.make_polygon(np.asarray(plan.vertices), np.asarray(plan.com))
    planned = [poly.caller_edge_to_hull(p.edge) for p in plan.pushes]
    return poly, planned


def _run_push(plan, params, in_axes, n, model, dtype, chunk):
    """Replay a push plan on ``n`` samples; returns ``(poly, planned, results)``."""
    poly, planned = _push_nominal(plan)
    P, m = len(plan.pushes), len(plan.vertices)
    Pp, mp = _bucket(P, 2), _bucket(m, 4)
    dirs = np.zeros((Pp, 2))
    dirs[:, 0] = 1.0
    dist = np.zeros(Pp)
    plan_e = np.full(Pp, -1, np.int32)
    if P:
        dirs[:P] = np.array([p.direction for p in plan.pushes], dtype=np.float64)
        dist[:P] = [p.distance for p in plan.pushes]
        plan_e[:P] = planned
    V0 = np.zeros((mp, 2))
    V0[:m] = poly.vertices
    nom = dict(V0=jnp.asarray(V0, dtype), com0=jnp.asarray(poly.com, dtype),
               start=jnp.asarray(plan.start, dtype),
               ang=jnp.asarray(np.arctan2(dirs[:, 1], dirs[:, 0]), dtype),
               dist=jnp.asarray(dist, dtype), planned=jnp.asarray(plan_e),
               active=jnp.asarray(np.arange(Pp) < P),
               hull=jnp.asarray(np.asarray(poly.hull_index, np.int32)))
    g, f, e = params.geometry, params.friction, params.execution
    ga, fa, ea = in_axes.geometry, in_axes.friction, in_axes.execution
    rows = dict(dv=_pad_axis(_rows(g.vertex_offset, ga.vertex_offset, n), mp),
                dc=_rows(g.com_offset, ga.com_offset, n),
                start=_rows(e.start_offset, ea.start_offset, n),
                fence=_pad_axis(_rows(e.fence_angle, ea.fence_angle, n), Pp),
                rel=_pad_axis(_rows(e.distance_rel, ea.distance_rel, n), Pp),
                abs=_pad_axis(_rows(e.distance_abs, ea.distance_abs, n), Pp),
                c=_rows(f.c, fa.c, n), mu=_rows(f.mu_f, fa.mu_f, n))
    rows = {k: v.astype(dtype) for k, v in rows.items()}
    res = _run_chunks(_push_batch, nom, rows, n, chunk, model)
    res["edges"] = res["edges"][:, :P]
    res["complete"] = res["complete"][:, :P]
    return poly, planned, res


def _edge_pairs(poly, hull_edges: np.ndarray):
    a = np.full(len(hull_edges), -1, np.int64)
    b = np.full(len(hull_edges), -1, np.int64)
    for i, e in enumerate(hull_edges):
        if e >= 0:
            a[i], b[i] = poly.edge_vertices(int(e))
    return a, b


# --------------------------------------------------------------------------
# Tumble plans
# --------------------------------------------------------------------------
def _frame_offset(geom, nom_origins, nom_xaxes, face):
    """Nominal frame of ``face`` expressed in the perturbed face frame:
    ``(q (2,), phi)``, its origin's and x-axis's planar coordinates."""
    R = geom.rotations[face]
    q = (R @ (nom_origins[face] - geom.origins[face]))[:2]
    xa = (R @ nom_xaxes[face])[:2]
    return q, jnp.arctan2(xa[1], xa[0])


@functools.lru_cache(maxsize=256)
def _edge_tables(topology):
    """Flat (F K,) index tables of the directed edges ``(f, k)`` (edge slot k of
    face f, the face ``g`` across it landing): the corners ``a``, ``b`` of the
    edge in f (slots ``k``, ``k+1``) and in g (the edge runs b -> a there)."""
    nf = topology.next_face_array
    ns = topology.next_slot_array
    sizes = topology.face_sizes
    F, K = nf.shape
    f = np.repeat(np.arange(F), K)
    k = np.tile(np.arange(K), F)
    valid = nf.reshape(-1) >= 0
    g = np.where(valid, nf.reshape(-1), 0)
    kb = np.where(valid, (k + 1) % sizes[f], 0)
    gb = np.where(valid, ns.reshape(-1), 0)
    ga = np.where(valid, (gb + 1) % sizes[g], 0)
    return tuple(a.astype(np.int32) for a in (f, np.where(valid, k, 0), kb, g, ga, gb))


def _tumble_walk(plan, topology):
    """The faces a plan visits, decided on the host from the nominal topology
    (the kernel never changes it): per step the directed edge ``f * K + k``
    it tumbles over, or ``F K`` for a no-op (padding, or an invalid step,
    which leaves the configuration unchanged as :func:`kernels.tumble.tumble`
    does); the final face and whether every step was valid."""
    nf = topology.next_face
    F, K = topology.n_faces, topology.max_face_size
    f, ok, idx = int(plan.start[3]), True, []
    for g in np.asarray(plan.faces, np.int64).reshape(-1)[: plan.n_tumbles]:
        g = int(g)
        row = list(nf[f]) if 0 <= f < F else []
        if g < 0:
            idx.append(F * K)
        elif g in row:
            idx.append(f * K + row.index(g))
            f = g
        else:
            idx.append(F * K)
            ok = False
    return np.asarray(idx, np.int32), f, ok


SLIP_SERIES_MAX = 0.1   # rad: rotational slips up to this use the series below


def _cos_sin_small(x):
    """``(cos x, sin x)`` for ``|x| <= SLIP_SERIES_MAX`` by their Taylor series
    (truncation below 3e-17; multiply-adds only: on a CPU a float64 sine costs
    as much as ~50 of them)."""
    x2 = x * x
    c = 1.0 - x2 / 2.0 * (1.0 - x2 / 12.0 * (1.0 - x2 / 30.0 * (1.0 - x2 / 56.0)))
    s = x * (1.0 - x2 / 6.0 * (1.0 - x2 / 20.0 * (1.0 - x2 / 42.0 * (1.0 - x2 / 72.0))))
    return c, s


def _edge_motions(C, topology):
    """Planar rigid motion of every directed edge, for a batch of corner
    arrays ``C`` (B, F, K, 2): ``(c, s, tx, ty)``, each (B, F K + 1), the
    rotation ``[[c, -s], [s, c]]`` and translation of the motion that maps the
    landing face's frame into the current face's; column ``F K`` is the
    identity (a no-op step)."""
    f, k, kb, g, ga, gb = _edge_tables(topology)
    ca, cb, qa, qb = C[:, f, k], C[:, f, kb], C[:, g, ga], C[:, g, gb]
    dc, dq = cb - ca, qb - qa
    # the rotation taking dq onto dc: (dq . dc, dq x dc) normalised
    rc = dq[..., 0] * dc[..., 0] + dq[..., 1] * dc[..., 1]
    rs = dq[..., 0] * dc[..., 1] - dq[..., 1] * dc[..., 0]
    rn = jnp.sqrt(rc * rc + rs * rs)
    rc, rs = rc / rn, rs / rn
    mq = 0.5 * (qa + qb)
    mc = 0.5 * (ca + cb)
    tx = mc[..., 0] - (rc * mq[..., 0] - rs * mq[..., 1])
    ty = mc[..., 1] - (rs * mq[..., 0] + rc * mq[..., 1])
    B = C.shape[0]
    one, zero = jnp.ones((B, 1), C.dtype), jnp.zeros((B, 1), C.dtype)
    return (jnp.concatenate([rc, one], 1), jnp.concatenate([rs, zero], 1),
            jnp.concatenate([tx, zero], 1), jnp.concatenate([ty, zero], 1))


def _tumble_block(nom: dict, q: dict, topology, slip_series: bool):
    """Replay a tumble plan on a block of samples, as a composition of planar
    rigid motions.

    A tumble over edge ``(a, b)`` of face f onto face g maps g's frame to
    ``T o M``, ``T`` f's pose and ``M`` the motion that takes the edge's
    corners in g's frame (``q_a``, ``q_b``) onto those in f's frame (``c_a``,
    ``c_b``): the rotation from ``q_b - q_a`` to ``c_b - c_a``, translation
    ``(c_a + c_b)/2 - R (q_a + q_b)/2`` -- what :func:`kernels.tumble.tumble`
    computes from the world positions of the corners, regrouped.  The faces
    visited do not depend on the sample (:func:`_tumble_walk`), so the
    motions of every directed edge are computed once per sample and gathered
    per step.  A slip ``(s, dtheta)`` after a tumble (world translation,
    rotation about the face frame's origin) makes the pose
    ``Trans(s) o T o M o Rot(dtheta)``; world translations act on the left and
    body motions on the right, so the final pose is
    ``Trans(sum s) o T_0 o N_1 o ... o N_L`` with ``N_t = M_t o Rot(dtheta_t)``:
    the loop over the plan multiplies 2x2 rotations (no trigonometric
    function), on rows of samples laid out contiguously.  ``slip_series``:
    every rotational slip is at most ``SLIP_SERIES_MAX`` (static; the tolerance
    bounds it), so its cosine and sine come from a series.
    """
    from kernels.tumble_geometry import tumble_geometry

    geom = jax.vmap(lambda v, c: tumble_geometry(v, c, topology))(nom["V0"] + q["dv"],
                                                                  nom["com0"] + q["dc"])
    ec, es, ex, ey = _edge_motions(geom.corners_2d, topology)
    idx = nom["idx"]
    slip = q["slip"]
    dth = slip[:, :, 2].T                                         # (L, B)
    sc, ss = _cos_sin_small(dth) if slip_series else (jnp.cos(dth), jnp.sin(dth))
    c1, s1 = ec[:, idx].T, es[:, idx].T                            # (L, B): the step's motion
    rows = (c1 * sc - s1 * ss, s1 * sc + c1 * ss, ex[:, idx].T, ey[:, idx].T)

    def step(carry, r):
        C, S, X, Y = carry
        c, s, x, y = r
        return (C * c - S * s, S * c + C * s, X + C * x - S * y, Y + S * x + C * y), None

    B = slip.shape[0]
    dt = slip.dtype
    init = (jnp.ones(B, dt), jnp.zeros(B, dt), jnp.zeros(B, dt), jnp.zeros(B, dt))
    (C, S, X, Y), _ = jax.lax.scan(step, init, rows)

    def finish(geom, so, slip_xy, C, S, X, Y):
        # start: nominal frame of the start face at start (+ error) -> perturbed frame
        start = nom["start"]
        q0, phi0 = _frame_offset(geom, nom["origins"], nom["xaxes"], nom["start_face"])
        th0 = start[2] + so[2] - phi0
        R0 = rot2(th0)
        xy = start[:2] + so[:2] - R0 @ q0 + R0 @ jnp.stack([X, Y]) + slip_xy
        th = th0 + jnp.arctan2(S, C)
        qf, phif = _frame_offset(geom, nom["origins"], nom["xaxes"], nom["final_face"])
        xy_ref = xy + rot2(th) @ qf
        return xy_ref[0], xy_ref[1], wrap_angle(th + phif)

    x, y, th = jax.vmap(finish)(geom, q["start"], jnp.sum(slip[:, :, :2], axis=1), C, S, X, Y)
    return dict(x=x, y=y, theta=th, slip=jnp.sum(jnp.linalg.norm(slip[:, :, :2], axis=-1), axis=1))


@functools.partial(jax.jit, static_argnames=("topology", "check", "slip_series"))
def _tumble_batch(nom, q, merge_tol, topology, check, slip_series):
    out = _blocks(lambda b: _tumble_block(nom, b, topology, slip_series), q, BLOCK)
    if check:   # the perturbed hulls, in float64 (their tolerance can be ~ float32's rounding)
        from kernels.hulls import polyhedron_hull_tables, polyhedron_hull_verdict_batch

        out["changed"], out["undecided"] = polyhedron_hull_verdict_batch(
            nom["V64"] + q["dv64"], polyhedron_hull_tables(topology), merge_tol)
    return out


def _tumble_nominal(plan):
    from kernels.polyhedron import PartWarning, make_polyhedron

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PartWarning)
        return make_polyhedron(np.asarray(plan.vertices), np.asarray(plan.com))


def _run_tumble(plan, params, in_axes, n, dtype, chunk, merge_tol=None, slip_theta=math.inf):
    """Replay a tumble plan on ``n`` samples (and, with ``merge_tol``, check
    every perturbed hull); returns ``(poly, results)``; ``results`` holds
    ``face`` and ``ok`` (the same for every sample) beside the poses.
    ``slip_theta``: a bound on the rotational slips (rad; the tolerance)."""
    poly = _tumble_nominal(plan)
    topo = poly.topology
    idx, final_face, ok = _tumble_walk(plan, topo)
    L = len(idx)
    Lp = _bucket(L, 16)
    seq = np.full(Lp, topo.n_faces * topo.max_face_size, np.int32)
    seq[:L] = idx
    nom = dict(V0=jnp.asarray(poly.vertices, dtype), com0=jnp.asarray(poly.com, dtype),
               origins=jnp.asarray(poly.face_origins, dtype),
               xaxes=jnp.asarray(poly.face_rotations[:, 0, :], dtype),
               start=jnp.asarray(plan.start[:3], dtype),
               start_face=jnp.asarray(int(plan.start[3]), jnp.int32),
               final_face=jnp.asarray(final_face, jnp.int32), idx=jnp.asarray(seq),
               V64=jnp.asarray(poly.vertices, jnp.float64))
    g, e = params.geometry, params.execution
    ga, ea = in_axes.geometry, in_axes.execution
    dv64 = _rows(g.vertex_offset, ga.vertex_offset, n).astype(jnp.float64)
    rows = dict(dv=dv64.astype(dtype), dc=_rows(g.com_offset, ga.com_offset, n).astype(dtype),
                start=_rows(e.start_offset, ea.start_offset, n).astype(dtype),
                slip=_pad_axis(_rows(e.tumble_slip, ea.tumble_slip, n), Lp).astype(dtype),
                dv64=dv64)
    check = merge_tol is not None
    tol = jnp.asarray(0.0 if merge_tol is None else merge_tol, jnp.float64)
    res = _run_chunks(_tumble_batch, nom, rows, n, chunk, tol, topo, check,
                      bool(slip_theta <= SLIP_SERIES_MAX))
    res["face"] = np.full(n, final_face, np.int64)
    res["ok"] = np.full(n, ok)
    if check:
        und = res.pop("undecided").astype(bool)
        changed = res["changed"].astype(bool)
        if und.any():   # a point the nominal hull dropped pops out by < the merge distance
            V = poly.vertices[None] + np.asarray(dv64)[und]
            changed[und] = polyhedron_combinatorics_changed(V, poly, merge_tol)
        res["changed"] = changed
    else:
        res["changed"] = np.zeros(n, bool)
    return poly, res


# --------------------------------------------------------------------------
# Bounds
# --------------------------------------------------------------------------
def _push_bound(plan, sampler) -> Optional[dict]:
    """:func:`robustness.bounds.push_plan_bound` for the box that holds every
    draw of ``sampler`` (a disc of radius tau_com lies in the box of half-width
    tau_com; Gaussians are truncated to their boxes)."""
    from robustness.bounds import push_plan_bound

    return push_plan_bound(plan, sampler.geometry, sampler.execution)


def _tumble_bound(plan, sampler, poly) -> Optional[dict]:
    """First-order bound of a tumble plan's final error: the vertex tolerance
    (:mod:`robustness.bounds`) plus the start and slip errors.

    The execution part is derived here.  A planar error ``(dx, dy, dtheta)`` of
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
    from robustness import bounds
    from kernels.tumble import make_config, replay_trajectory

    e = sampler.execution
    start = make_config(*plan.start[:3], int(plan.start[3]), dtype=jnp.float64)
    faces = np.asarray(plan.faces, np.int32)
    tau_v = sampler.geometry.tau_v
    if hasattr(bounds, "tumble_plan_bound"):
        vb = bounds.tumble_plan_bound(plan, tau_v)
    elif tau_v > 0:
        vb = bounds.tumble_first_order_bound(poly.vertices, poly.com, poly.topology, start, faces,
                                             tau_v)
    else:
        vb = {"x_m": 0.0, "y_m": 0.0, "theta_rad": 0.0}
    # per-coordinate terms when given; a bound with only a norm is used for both
    bx = float(vb.get("x_m", vb.get("position_m", math.nan)))
    by = float(vb.get("y_m", vb.get("position_m", math.nan)))
    bt = float(vb["theta_rad"])
    vb = {"x_m": bx, "y_m": by, "theta_rad": bt}
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
    return {"x_m": bx, "y_m": by, "position_m": math.hypot(bx, by), "theta_rad": bt,
            "by_source": {"tau_v": {"position_m": math.hypot(vb["x_m"], vb["y_m"]),
                                    "theta_rad": float(vb["theta_rad"])},
                          "execution": {"position_m": math.hypot(ex, ey), "theta_rad": float(et)}}}


# --------------------------------------------------------------------------
# Public API
# --------------------------------------------------------------------------
def _cast(params, dtype):
    """The float64 draws in the kernels' dtype: a float32 evaluation sees the same
    samples as a float64 one (drawing in float32 would give other numbers)."""
    if dtype == jnp.dtype(jnp.float64):
        return params
    return jax.tree_util.tree_map(lambda x: jnp.asarray(x, dtype), params)


def _warn_truncated(r: dict, task) -> None:
    """A push still moving at the kernel's phase cap is reported, never silently kept."""
    k = int(np.sum(np.asarray(r.get("truncated", False))))
    if k:
        warnings.warn(f"task {task!r}: {k} sample(s) had a push still moving at the quasi-static "
                      "kernel's phase cap (kernels.quasistatic.phase_cap); they are counted as "
                      "incomplete_reorientation failures, outside the kernel's model",
                      RuntimeWarning, stacklevel=4)


def _kind(plan) -> str:
    if hasattr(plan, "pushes"):
        return "push"
    if hasattr(plan, "tumbles"):
        return "tumble"
    raise TypeError(f"plan: expected a PushPlan or a TumblePlan, got {type(plan).__name__}")


@float64
def evaluate(plan, sampler: Sampler, n: int, key, model: str = "quasistatic",
             dtype=jnp.float64, *, pos_eps_m: Optional[float] = None,
             theta_eps_rad: Optional[float] = None, confidence: float = 0.95,
             n_steps: int = 64, chunk: int = 4096, task: str = "task",
             bound: bool = True, slip_fraction: float = SLIP_FRACTION,
             merge_factor: float = 8.0) -> Evaluation:
    """Evaluate a plan on ``n`` perturbed samples.

    Args:
      plan: a :class:`~planning.pushing.plan.PushPlan` or a
        :class:`~planning.tumbling.plan.TumblePlan`.
      sampler: the :class:`~robustness.samplers.Sampler` (tolerances).
      n: number of samples (>= 1).
      key: a ``jax.random`` key.
      model: ``"quasistatic"`` or ``"exact"`` (push plans; tumbles always exact).
      dtype: float dtype of the kernels (``jnp.float64`` or ``jnp.float32``); the
        perturbations are drawn in float64 and cast, so both dtypes see the same
        samples (compare them row by row).
      pos_eps_m, theta_eps_rad: success tolerances (default: the tumble plan's
        eps for both; 1 mm and 1 degree for push plans).
      confidence: of the Clopper-Pearson interval.
      n_steps: ignored (kept for callers of the former fixed-step
        quasi-static integrator: :mod:`kernels.quasistatic` integrates each
        contact phase in closed form and has no step size).
      chunk: samples per compiled call (bounds memory; the last, partial
        chunk is padded to a power of two, so sample counts share compilations).
      task: the task name written in the tables.
      bound: compute the analytic bound (set False to skip it).
      slip_fraction: a failed sample whose slip is at least this times
        ``pos_eps_m`` fails by ``slip``.
      merge_factor: polyhedra: face-merging tolerance factor for the
        combinatorics check (:func:`robustness.samplers.face_merge_tol`).

    Returns:
      :class:`Evaluation`.
    """
    kind = _kind(plan)
    if model not in MODELS:
        raise ValueError(f"model: expected one of {MODELS}, got {model!r}")
    if not (isinstance(n, (int, np.integer)) and n >= 1):
        raise ValueError(f"n: expected an integer >= 1, got {n!r}")
    dtype = jnp.dtype(dtype)
    t0 = time.perf_counter()
    if kind == "tumble":
        model = "exact"
        pe = float(plan.eps) if pos_eps_m is None else float(pos_eps_m)
        te = float(plan.eps) if theta_eps_rad is None else float(theta_eps_rad)
    else:
        pe = DEFAULT_POS_EPS if pos_eps_m is None else float(pos_eps_m)
        te = DEFAULT_THETA_EPS if theta_eps_rad is None else float(theta_eps_rad)
    for name, v in (("pos_eps_m", pe), ("theta_eps_rad", te)):
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"{name}: expected a finite number > 0, got {v!r}")
    chunk = max(1, int(chunk))
    goal = np.asarray(plan.goal[:3], np.float64)
    cols: dict = {}
    if kind == "push":
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", pg.PartWarning)
            poly0 = pg.make_polygon(np.asarray(plan.vertices), np.asarray(plan.com))
        m, P = len(plan.vertices), len(plan.pushes)
        params64, in_axes = sampler.sample(key, n, n_vertices=m, dim=2, n_pushes=P,
                                           body=poly0.body, dtype=jnp.float64, keep_support=False)
        params = _cast(params64, dtype)
        poly, planned, r = _run_push(plan, params64, in_axes, n, model, dtype, chunk)
        _warn_truncated(r, task)
        edges = np.asarray(r["edges"]).reshape(n, P)
        complete = np.asarray(r["complete"]).reshape(n, P).astype(bool)
        planned_arr = np.asarray(planned, np.int64)[None, :]
        wrong = complete & (edges != planned_arr)
        n_incomplete = (~complete).sum(axis=1)
        first_wrong = np.where(wrong.any(axis=1), np.argmax(wrong, axis=1), -1)
        last = edges[:, -1] if P else np.full(n, -1)
        fa, fb = _edge_pairs(poly, last)
        pa, pb = _edge_pairs(poly, np.full(n, planned[-1] if P else -1))
        changed = np.asarray(r["changed"]).astype(bool)
        trunc = np.asarray(r["truncated"]).astype(bool)
        slip = np.asarray(r["slip"], np.float64)
        face = np.full(n, -1, np.int64)
        pface = np.full(n, -1, np.int64)
        structural = np.select(
            [changed, (n_incomplete > 0) | trunc, wrong.any(axis=1)],
            ["hull_changed", "incomplete_reorientation", "wrong_edge"], default="")
        in_model = ((~changed) & (n_incomplete == 0) & (~wrong.any(axis=1)) & (slip == 0.0)
                    & ~trunc)
        valid = ~changed & ~trunc
        cols = parameter_columns(params, in_axes, n, n_vertices=m, dim=2, n_pushes=P)
    else:
        poly = _tumble_nominal(plan)
        m, L = len(plan.vertices), plan.n_tumbles
        params64, in_axes = sampler.sample(key, n, n_vertices=m, dim=3, n_tumbles=L,
                                           dtype=jnp.float64)
        params = _cast(params64, dtype)
        tol = None
        if sampler.geometry.tau_v > 0:   # the perturbed hulls, checked in the same compiled call
            v = np.asarray(poly.vertices)
            diam = float(np.max(np.linalg.norm(v[:, None] - v[None], axis=-1)))
            tol = face_merge_tol(sampler.geometry.tau_v, diam, merge_factor)
        poly, r = _run_tumble(plan, params64, in_axes, n, dtype, chunk, merge_tol=tol,
                              slip_theta=sampler.execution.tumble_slip_theta)
        changed = np.asarray(r["changed"]).astype(bool)
        face = np.asarray(r["face"], np.int64)
        ok = np.asarray(r["ok"]).astype(bool)
        pface = np.full(n, int(plan.goal[3]), np.int64)
        bad_face = (~ok) | (face != pface)
        structural = np.select([changed, bad_face], ["combinatorics_changed", "wrong_face"],
                               default="")
        slip = np.asarray(r["slip"], np.float64)
        fa = fb = pa = pb = np.full(n, -1, np.int64)
        n_incomplete = (~ok).astype(np.int64)
        first_wrong = np.full(n, -1, np.int64)
        in_model = (~changed) & (~bad_face)
        valid = ~changed
        cols = parameter_columns(params, in_axes, n, n_vertices=m, dim=3, n_tumbles=L)

    x = np.asarray(r["x"], np.float64)
    y = np.asarray(r["y"], np.float64)
    th = wrap_angle_np(np.asarray(r["theta"], np.float64))
    ex, ey = x - goal[0], y - goal[1]
    ep = np.hypot(ex, ey)
    et = wrap_angle_np(th - goal[2])
    within = (ep <= pe) & (np.abs(et) <= te)
    success = valid & within & (structural != "wrong_face")
    mode = np.where(success, "none",
                    np.where(structural != "", structural,
                             np.where(slip >= slip_fraction * pe, "slip",
                                      np.where(ep > pe, "position", "orientation"))))
    # a successful sample with an incomplete / wrong intermediate push is still a success
    # (the final pose is within eps); its structural flag stays visible in its columns.
    param_names = tuple(cols)
    data = {"task": task, "kind": kind, "model": model, "dtype": dtype.name,
            "sample_id": np.arange(n, dtype=np.int64)}
    data.update(cols)
    data.update({
        "final_x_m": x, "final_y_m": y, "final_theta_rad": th,
        "final_edge_a": fa, "final_edge_b": fb, "planned_edge_a": pa, "planned_edge_b": pb,
        "final_face": face, "planned_face": pface,
        "err_x_m": ex, "err_y_m": ey, "err_pos_m": ep, "err_theta_rad": et,
        "slip_m": slip, "n_incomplete": np.asarray(n_incomplete, np.int64),
        "first_wrong_step": np.asarray(first_wrong, np.int64),
        "hull_changed": changed, "model_valid": valid, "in_bound_model": in_model,
        "success": success, "failure_mode": mode,
    })
    df = pd.DataFrame(data)

    b = None
    if bound:
        if kind == "push":
            b = _push_bound(plan, sampler)
        else:
            b = _tumble_bound(plan, sampler, poly)
    # rounding allowance of the bound comparison: the kernels' dtype over the plan's steps
    verts = np.asarray(plan.vertices, np.float64)
    scale = (float(np.max(np.linalg.norm(verts - verts.mean(axis=0), axis=1)))
             + max(float(np.hypot(*plan.start[:2])), float(np.hypot(*plan.goal[:2]))))
    steps = len(plan.pushes) if kind == "push" else plan.n_tumbles
    rtol_eps = 1e3 * float(jnp.finfo(dtype).eps) * math.sqrt(steps + 1)
    summary = _summarise(df, kind, model, dtype.name, pe, te, confidence, b, task,
                         atol=(rtol_eps * scale, rtol_eps))
    _paper_bound(summary, df, plan, sampler, kind, bound, task, atol=(rtol_eps * scale, rtol_eps))
    return Evaluation(samples=df, summary=summary, param_columns=param_names, kind=kind,
                      model=model, bound=b, seconds=time.perf_counter() - t0)


def _paper_bound(s: dict, df, plan, sampler, kind: str, bound: bool, task,
                 atol=(0.0, 0.0)) -> None:
    """Confront the Marigo-Bicchi bounds (eqs. 5 and 6) with the Monte-Carlo
    maximum of a tumble plan's error (``paper_bound_*`` summary fields).

    The paper's bounds cover the vertex tolerance only, so the comparison is
    made when the execution errors are zero (else the fields are NaN/None).
    ``atol`` is the rounding allowance (m, rad) of the kernels' dtype, as for
    the first-order bound.  A violation is a finding, warned as
    :class:`BoundViolation`, never clipped:
    eq. (6) raises lengths to high powers, so in metres it can collapse to an
    impossibly small number for parts smaller than a metre.
    """
    s["paper_bound_position_m"] = s["paper_bound_theta_rad"] = math.nan
    s["paper_bound_violated"] = None
    e = sampler.execution
    if kind != "tumble" or not bound or e.start_xy or e.start_theta or e.tumble_slip_xy \
            or e.tumble_slip_theta:
        return
    from robustness.bounds import tumble_plan_paper_bounds

    pb = tumble_plan_paper_bounds(plan, sampler.geometry.tau_v)
    bp, bt = float(pb["Delta_C_f"]), float(pb["Delta_theta_f"])
    s["paper_bound_position_m"], s["paper_bound_theta_rad"] = bp, bt
    inm = df["in_bound_model"].to_numpy(bool)
    if not inm.any():
        return
    emp_p = float(df["err_pos_m"][inm].max())
    emp_t = float(df["err_theta_rad"][inm].abs().max())
    msgs = []
    if not emp_p <= bp + atol[0]:
        msgs.append(f"position {emp_p:.6g} m > Delta_C_f {bp:.6g} m (eq. 6)")
    if not emp_t <= bt + atol[1]:
        msgs.append(f"orientation {emp_t:.6g} rad > Delta_theta_f {bt:.6g} rad (eq. 5)")
    s["paper_bound_violated"] = bool(msgs)
    if msgs:
        warnings.warn(f"PAPER BOUND VIOLATED (task {task!r}, tumble plan): the Monte-Carlo "
                      f"maximum over {int(inm.sum())} samples exceeds the Marigo-Bicchi bound: "
                      f"{'; '.join(msgs)}. A finding, not clipped.", BoundViolation, stacklevel=4)


def _summarise(df, kind, model, dtype_name, pe, te, confidence, b, task,
               atol=(0.0, 0.0)) -> dict:
    n = len(df)
    k = int(df["success"].sum())
    lo, hi = stats.clopper_pearson(k, n, confidence)
    s = {"task": task, "kind": kind, "model": model, "dtype": dtype_name, "n": n, "n_success": k,
         "success_rate": k / n if n else math.nan, "confidence": confidence, "ci_low": lo,
         "ci_high": hi,
         # what a probability claim uses: the ONE-sided lower bound at `confidence`
         "ci_low_one_sided": stats.one_sided_lower(k, n, confidence) if n else math.nan,
         "pos_eps_m": pe, "theta_eps_rad": te}
    for stem, vals in (("err_pos_m", df["err_pos_m"]), ("err_x_abs_m", df["err_x_m"].abs()),
                       ("err_y_abs_m", df["err_y_m"].abs()),
                       ("err_theta_abs_rad", df["err_theta_rad"].abs()), ("slip_m", df["slip_m"])):
        for q, v in stats.quantiles(vals).items():
            s[f"{stem}_{q}"] = v
    score = np.maximum(df["err_pos_m"].to_numpy() / pe, np.abs(df["err_theta_rad"].to_numpy()) / te)
    score = np.where(np.isfinite(score), score, np.inf)
    w = int(np.argmax(score)) if n else -1
    s["worst_sample_id"] = int(df["sample_id"].iloc[w]) if n else -1
    s["worst_err_pos_m"] = float(df["err_pos_m"].iloc[w]) if n else math.nan
    s["worst_err_theta_abs_rad"] = float(abs(df["err_theta_rad"].iloc[w])) if n else math.nan
    inm = df["in_bound_model"].to_numpy(bool)
    s["n_in_bound_model"] = int(inm.sum())
    emp_p = float(df["err_pos_m"][inm].max()) if inm.any() else math.nan
    emp_t = float(df["err_theta_rad"][inm].abs().max()) if inm.any() else math.nan
    s["emp_max_pos_in_model_m"], s["emp_max_theta_in_model_rad"] = emp_p, emp_t
    if b is None:
        s["bound_position_m"] = s["bound_theta_rad"] = math.nan
        s["bound_violated"] = None
    else:
        bp, bt = float(b["position_m"]), float(b["theta_rad"])
        s["bound_position_m"], s["bound_theta_rad"] = bp, bt
        viol = False
        msgs = []
        if inm.any():
            if not emp_p <= bp * (1 + BOUND_RTOL) + atol[0]:
                viol = True
                msgs.append(f"position {emp_p:.6g} m > bound {bp:.6g} m")
            if not emp_t <= bt * (1 + BOUND_RTOL) + atol[1]:
                viol = True
                msgs.append(f"orientation {emp_t:.6g} rad > bound {bt:.6g} rad")
        s["bound_violated"] = viol
        if viol:
            warnings.warn(f"BOUND VIOLATED (task {task!r}, {kind} plan, {model} model): the "
                          f"Monte-Carlo maximum over {int(inm.sum())} samples inside the bound's "
                          f"model exceeds the analytic first-order bound: {'; '.join(msgs)}. "
                          "This is a finding (a second-order effect or a modelling gap), "
                          "not clipped.", BoundViolation, stacklevel=4)
    counts = df["failure_mode"].value_counts()
    for mname in FAILURE_MODES:
        s[f"n_{mname}"] = int(counts.get(mname, 0))
    fails = {mname: s[f"n_{mname}"] for mname in FAILURE_MODES if mname != "none"}
    worst = max(fails.items(), key=lambda kv: kv[1]) if fails else ("none", 0)
    s["dominant_failure_mode"] = worst[0] if worst[1] > 0 else "none"
    return s


__all__ = ["evaluate", "Evaluation", "BoundViolation", "MODELS",
           "Sampler", "GeometryTolerance", "FrictionRange", "ExecutionTolerance"]
