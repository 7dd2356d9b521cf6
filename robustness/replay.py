"""Compiled Monte-Carlo replays of push and tumble plans (the hot path of
:func:`robustness.evaluation.evaluate`): per-sample perturbed parts and
executions in, final poses and per-step outcomes out, with no per-sample host
work and one compilation per shape bucket.  Frames, reference points and the
per-sample semantics are those of :mod:`robustness.evaluation`.
"""
from __future__ import annotations

import dataclasses
import functools
import math
from typing import Optional

import jax
import jax.numpy as jnp
import numpy as np

from kernels import edge_motion, polygon_geometry, polygon_hull_changed, rot2, wrap_angle
from robustness.hulls import polyhedron_combinatorics_changed


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class PushNominal:
    """A push plan's numbers, padded to its buckets (traced: one compilation per
    shape bucket).  ``V0`` (mp, 2) caller's vertices (m, zero rows past the
    part's), ``com0`` (2,), ``start`` (3,) start pose (m, rad; world),
    ``ang`` (Pp,) fence directions (rad), ``dist`` (Pp,) push distances (m),
    ``planned`` (Pp,) the hull edge each push lands (-1: padding), ``active``
    (Pp,) real pushes, ``hull`` the hull's vertex indices."""

    V0: jax.Array
    com0: jax.Array
    start: jax.Array
    ang: jax.Array
    dist: jax.Array
    planned: jax.Array
    active: jax.Array
    hull: jax.Array


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class PushSamples:
    """Per-sample perturbations of a push plan (leading axis: samples): vertex
    and centre-of-mass offsets (m), start-pose error (m, rad), per-push fence
    angle (rad), relative and absolute distance errors, the support's ``c``
    (m) and ``mu`` the fence friction; for the exact limit surface the
    support's family code, corner ranks and sampled points and loads
    (:func:`kernels.support.family_support`)."""

    dv: jax.Array
    dc: jax.Array
    start: jax.Array
    fence: jax.Array
    rel: jax.Array
    abs: jax.Array
    c: jax.Array
    mu: jax.Array
    family: jax.Array = None
    lift: jax.Array = None
    points: jax.Array = None
    weights: jax.Array = None


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class PushReplay:
    """Per-sample outcomes of a push plan: the final pose of the reference
    point (m, rad; world), the hull edge flush after each push and whether it
    completed, the summed slip (m), the hull changed, a push truncated at the
    kernel's phase cap."""

    x: jax.Array
    y: jax.Array
    theta: jax.Array
    edges: jax.Array
    complete: jax.Array
    slip: jax.Array
    changed: jax.Array
    truncated: jax.Array


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class TumbleNominal:
    """A tumble plan's numbers: the nominal vertices ``V0`` (m, the kernels'
    dtype; ``V64`` in float64 for the hull check), ``com0``, the face frames
    (``origins``, ``xaxes``), the start configuration, the start and final
    faces, ``idx`` the directed edge of every (padded) step and ``n_steps``
    the plan's tumbles (the steps from it on are no-ops without a slip)."""

    V0: jax.Array
    com0: jax.Array
    origins: jax.Array
    xaxes: jax.Array
    start: jax.Array
    start_face: jax.Array
    final_face: jax.Array
    idx: jax.Array
    V64: jax.Array
    n_steps: jax.Array


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class TumbleSamples:
    """Per-sample perturbations of a tumble plan: vertex (``dv``; ``dv64`` in
    float64) and centre-of-mass offsets (m), start error (m, rad), the slip
    after every step (m, m, rad; a step past the plan's tumbles ignores its
    slip)."""

    dv: jax.Array
    dc: jax.Array
    start: jax.Array
    slip: jax.Array
    dv64: jax.Array


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class TumbleReplay:
    """Per-sample outcomes of a tumble plan: the final configuration of the
    final face's nominal frame (m, rad; world), the summed slip (m), the face
    reached and whether every step was valid (the same for every sample),
    the perturbed hull changed its combinatorics (``undecided``: the compiled
    check left it to the host reference)."""

    x: jax.Array
    y: jax.Array
    theta: jax.Array
    slip: jax.Array
    changed: Optional[jax.Array] = None
    undecided: Optional[jax.Array] = None
    face: Optional[np.ndarray] = None
    ok: Optional[np.ndarray] = None


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


def _chunks(n: int, chunk: int, whole: bool = False):
    """``(lo, hi, size)`` of each compiled call: full chunks of ``chunk``
    samples, then the rest padded to a power of two (>= 8, <= chunk), or to a
    whole chunk when ``whole`` (one compiled shape)."""
    out = []
    for lo in range(0, n, chunk):
        hi = min(n, lo + chunk)
        full = hi - lo == chunk or whole
        out.append((lo, hi, chunk if full else min(chunk, _bucket(hi - lo, 8))))
    return out


def _pad_axis(x, k: int, axis: int = 1):
    """Zero-pad ``x`` along ``axis`` to length ``k``."""
    widths = [(0, 0)] * x.ndim
    widths[axis] = (0, k - x.shape[axis])
    return jnp.pad(x, widths)


def replay_devices() -> tuple:
    """The devices a batch's compiled calls are spread over: every local device
    of JAX's default backend.  On the CPU that is one device unless
    ``jax_num_cpu_devices`` (``JAX_NUM_CPU_DEVICES``) asks for more before JAX
    starts: nudge's command lines and Dask workers set it to their cores
    (:func:`robustness.cpus.cpu_threads`); a library caller may set it too."""
    return tuple(jax.local_devices())


@functools.lru_cache(maxsize=128)
def _spread_call(fn, statics: tuple, n_args: int, sample_axis: int, devices: tuple):
    """``fn(nom, rows, *args)`` as one compiled call over ``devices``: the rows
    (sample axis 0) split evenly, one share per device, ``nom`` and the array
    arguments copied to each (``statics``: the other arguments, ``(position,
    value)``); the outcomes' shares joined along ``sample_axis``.  Each device
    runs its share's loops on its own, as the plain call runs them: the
    outcomes are the plain calls' bit for bit."""
    spec = jax.sharding.PartitionSpec
    mesh = jax.sharding.Mesh(np.asarray(devices, dtype=object), ("samples",))
    fixed = dict(statics)

    def share(nom, rows, traced):
        it = iter(traced)
        args = [fixed[i] if i in fixed else next(it) for i in range(n_args)]
        return fn(nom, rows, *args)

    return jax.jit(jax.shard_map(share, mesh=mesh, in_specs=(spec(), spec("samples"), spec()),
                                 out_specs=spec(*(None,) * sample_axis, "samples"),
                                 check_vma=False))


def _map_calls(fn, nom, rows, args, calls, sample_axis: int, devices: tuple):
    """The outcomes (numpy pytrees) of ``fn(nom, cut(rows), *args)`` for each
    ``(cut, size)`` in ``calls``, in this thread.  With several ``devices``
    (:func:`replay_devices`) each run of as many calls of one size is ONE
    compiled call spread over the devices (:func:`_spread_call`; a short run
    padded by repeating its last call), so that a batch's calls use every
    core; with one device, one call after the other.

    In this thread: JAX runs the spread call's shares on its own threads, one
    per device.  (Two Python threads ran a batch's calls until December 2026;
    ``nudge certify examples/certify_plate.yaml`` then hung in 7 of 8 runs, and
    one call over two devices hung too: LAPACK's batched LU in the support
    kernels blocked every XLA worker thread.  Those solves are closed form now,
    :mod:`kernels.linsolve`, and a test holds LAPACK out of the compiled
    replays.)"""
    tm = jax.tree_util.tree_map
    D = len(devices)
    if D == 1 or len(calls) == 1:
        return [tm(np.asarray, fn(nom, tm(cut, rows), *args)) for cut, _ in calls]
    is_array = [isinstance(a, (jax.Array, np.ndarray)) for a in args]
    statics = tuple((i, a) for i, a in enumerate(args) if not is_array[i])
    traced = tuple(a for i, a in enumerate(args) if is_array[i])
    lead = (slice(None),) * sample_axis
    outs = []
    i = 0
    while i < len(calls):
        size, run = calls[i][1], []
        while i < len(calls) and len(run) < D and calls[i][1] == size:
            run.append(calls[i][0])
            i += 1
        group = run + [run[-1]] * (D - len(run))
        spread = _spread_call(fn, statics, len(args), sample_axis, devices)
        both = tm(lambda *xs: np.concatenate(xs), *[tm(cut, rows) for cut in group])
        out = tm(np.asarray, spread(nom, both, traced))
        outs += [tm(lambda x, k=k: x[lead + (slice(k * size, (k + 1) * size),)], out)
                 for k in range(len(run))]
    return outs


#: a batch that fits one call is cut into a share per device (:func:`replay_devices`)
#: when every share holds at least this many samples
SPREAD_MIN_SAMPLES = 64


def _run_chunks(fn, nom, rows, n: int, chunk: int, *args, sample_axis: int = 0,
                whole: bool = False):
    """``fn(nom, rows_chunk, *args)`` over chunks of the per-sample pytree
    ``rows`` (each padded by repeating its first sample; :func:`_map_calls`:
    over every device, else one after the other); returns
    the outcome pytree with numpy arrays of n rows (along the outcomes'
    ``sample_axis``).  ``whole``: every call ``chunk`` samples (the last
    padded), one compiled shape; else a batch of one call on several devices
    is cut into a share per device (:data:`SPREAD_MIN_SAMPLES`).  ``fn`` is a
    jitted function (a new one per batch would compile per batch) and the
    ``args`` hashable or arrays."""
    tm = jax.tree_util.tree_map
    cuts = _chunks(n, chunk, whole)
    devices = replay_devices()
    D = len(devices)
    if len(cuts) == 1 and not whole and D > 1 and n >= D * SPREAD_MIN_SAMPLES:
        cuts = _chunks(n, _bucket(-(-n // D), 8), True)     # a share per device
    elif n == chunk or (n < chunk and not whole and _bucket(n, 8) == n):   # one call, as they are
        return tm(np.asarray, fn(nom, rows, *args))
    sizes, calls = [], []
    # sliced on the host: numpy slices are views, where eager jax slices of the
    # (n, L, 3) slips cost a third of a 200-tumble evaluation
    rows = tm(np.asarray, rows)
    for lo, hi, size in cuts:
        def cut(x, lo=lo, hi=hi, size=size):
            x = x[lo:hi]
            if size > hi - lo:
                x = np.concatenate([x, np.broadcast_to(x[:1], (size - (hi - lo),) + x.shape[1:])])
            return x

        calls.append((cut, size))
        sizes.append(hi - lo)
    outs = _map_calls(fn, nom, rows, args, calls, sample_axis, devices)
    lead = (slice(None),) * sample_axis
    return tm(lambda *xs: np.concatenate([np.asarray(x)[lead + (slice(0, m),)]
                                          for x, m in zip(xs, sizes)], axis=sample_axis), *outs)


#: the exact limit surface's batches of several support families (``any``) are
#: split on the host into families of at most this many support points and the
#: rest: each part replays at its own point count, not the largest family's
#: (``any``: rigid corners and tripods, then the pads and rings of 24-25 feet)
FEW_POINTS = 8
#: ... when the batch has more samples than this (below it, one compiled call
#: costs less than a second compilation would save)
SPLIT_MIN_SAMPLES = 64
#: each group is padded to whole calls of this many samples (one compiled shape
#: per group, whatever the sample count)
SPLIT_CALL = 64


def _split_by_points(model, rows, n: int, n_corners: int):
    """The host-side split of a limit-surface batch (:data:`FEW_POINTS`):
    ``[(static model, sample indices), ...]``, or None to run it whole."""
    if not (isinstance(model, tuple) and len(model[1]) > 1 and n > SPLIT_MIN_SAMPLES):
        return None
    from kernels import FAMILIES, family_point_count

    n_sampled = int(np.shape(rows.points)[1]) if rows.points is not None else 0
    few = tuple(f for f in model[1] if family_point_count(f, n_corners, n_sampled) <= FEW_POINTS)
    many = tuple(f for f in model[1] if f not in few)
    if not few or not many:
        return None
    code = np.asarray(rows.family)
    out = []
    for fams in (few, many):
        idx = np.flatnonzero(np.isin(code, [FAMILIES.index(f) for f in fams]))
        if len(idx):
            out.append(((model[0], fams), idx))
    return out


def _run_split(fn, nom, rows, n: int, chunk: int, model, n_corners: int,
               sample_axis: int = 0):
    """:func:`_run_chunks` of a push batch, with a limit-surface batch of
    several support families split by point count (:func:`_split_by_points`):
    each group padded to whole calls of :data:`SPLIT_CALL` samples (one
    compilation per group whatever the sample count), the outcomes put back in
    sample order."""
    groups = _split_by_points(model, rows, n, n_corners)
    if groups is None:
        chunk, whole = limit_surface_calls(model, n, chunk)
        return _run_chunks(fn, nom, rows, n, chunk, model, sample_axis=sample_axis, whole=whole)
    tm = jax.tree_util.tree_map
    rows = tm(np.asarray, rows)
    lead = (slice(None),) * sample_axis
    out = None
    for static, idx in groups:
        res = _run_chunks(fn, nom, tm(lambda x: x[idx], rows), len(idx), SPLIT_CALL,
                          static, sample_axis=sample_axis, whole=True)
        if out is None:
            out = tm(lambda x: np.zeros(x.shape[:sample_axis] + (n,) + x.shape[sample_axis + 1:],
                                        x.dtype), res)
        for o, r in zip(jax.tree_util.tree_leaves(out), jax.tree_util.tree_leaves(res)):
            o[lead + (idx,)] = r
    return out


# --------------------------------------------------------------------------
# Push plans
# --------------------------------------------------------------------------
def perturbed_polygon(nom, q):
    """A sample's perturbed part (one sample; traced): ``(geometry, hull changed)``,
    the nominal vertices ``nom.V0`` and centre of mass ``nom.com0`` plus the
    sample's offsets ``q.dv``, ``q.dc`` (m, part frame), the geometry in the
    centre-of-mass frame over the nominal hull ``nom.hull``."""
    V = nom.V0 + q.dv
    com = nom.com0 + q.dc
    return (polygon_geometry(V[nom.hull] - com[None, :]),
            polygon_hull_changed(V, com, nom.hull))


def _push_one(nom: PushNominal, q: PushSamples, model: str) -> PushReplay:
    dt = nom.V0.dtype
    geom, changed = perturbed_polygon(nom, q)
    start, so = nom.start, q.start
    th0 = start[2] + so[2]
    pose0 = jnp.concatenate([start[:2] + so[:2] + rot2(th0) @ q.dc, th0[None]])
    ang = nom.ang + q.fence
    dirs = jnp.stack([jnp.cos(ang), jnp.sin(ang)], axis=-1)
    active = nom.active
    dists = jnp.maximum(nom.dist * (1.0 + q.rel) + q.abs, 0.0)
    dists = jnp.where(active, dists, 0.0)  # padding pushes are no-ops
    if model == "exact":
        from kernels import replay_pushes

        final, outs = replay_pushes(geom, pose0, dirs, dists)
        slip, trunc = jnp.zeros((), dt), jnp.asarray(False)
    elif isinstance(model, tuple):          # ("limit_surface", families): the exact surface
        from kernels import family_support, simulate_pushes_on_points

        pts, wts = family_support(model[1], q.family, geom.body, q.c, q.lift, q.points, q.weights)
        final, outs = simulate_pushes_on_points(geom, pose0, dirs, dists, pts, wts, q.mu,
                                                expected_edges=nom.planned, active=active)
        slip = jnp.sum(jnp.where(active, outs.slip, 0.0))
        trunc = jnp.any(active & outs.truncated)
    else:
        from kernels import simulate_pushes

        final, outs = simulate_pushes(geom, pose0, dirs, dists, q.c, q.mu,
                                      expected_edges=nom.planned, active=active)
        slip = jnp.sum(jnp.where(active, outs.slip, 0.0))
        trunc = jnp.any(active & outs.truncated)
    ref = final[:2] - rot2(final[2]) @ q.dc
    return PushReplay(x=ref[0], y=ref[1], theta=final[2], edges=outs.edge, complete=outs.complete,
                      slip=slip, changed=changed, truncated=trunc)


def _blocks(fn, q, block: int):
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
#: the exact limit surface's blocks: its warm-started node solves carry a
#: phase's motions through a scan (the nice-stable pentagon's 7-push plan on
#: rigid corners, unblocked: 1,480 samples/s at 256, 670 at 512, 520 at 2,048;
#: 2 CPU cores).  The cliff above 256 is XLA's CPU library fusions (YNN), not
#: the cache: compiled without them (``compiler_options=
#: {"xla_cpu_experimental_ynn_fusion_type": ""}``) one call of 1,024 samples in
#: blocks of 512 runs at 3,400 samples/s against 1,500 with them (256: 3,000
#: either way), but a batch's calls on both cores are then slower in blocks of
#: 512 than of 256 (4,000-4,500 against 5,700-6,000 samples/s; December 2026)
LIMIT_SURFACE_BLOCK = 256
#: the most samples in one compiled limit-surface call: a batch of more runs
#: as several calls of one compiled shape, spread over the devices
#: (:func:`_map_calls`; on 2 threads, as they once ran: 4,096 samples of the
#: plan above, 2 cores, 1 call 4,300 samples/s, 8 calls of 512 8,100-8,400)
LIMIT_SURFACE_CALL = 512


def limit_surface_calls(model, n: int, chunk: int) -> tuple:
    """``(chunk, whole)`` for :func:`_run_chunks` of a batch of ``n`` samples
    under the static ``model``: a limit-surface batch of more than
    :data:`LIMIT_SURFACE_CALL` samples runs in whole calls of that many (one
    compiled shape whatever ``n``); others as asked."""
    if isinstance(model, tuple):
        call = min(chunk, LIMIT_SURFACE_CALL)
        if n > call:
            return call, True
    return chunk, False


def _block(model) -> int:
    """Samples per block for the static ``model`` (:func:`_static_model`)."""
    return LIMIT_SURFACE_BLOCK if isinstance(model, tuple) else BLOCK


@functools.partial(jax.jit, static_argnames=("model",))
def _push_batch(nom, q, model):
    one = functools.partial(_push_one, model=model)
    return _blocks(lambda b: jax.vmap(one, in_axes=(None, 0))(nom, b), q, _block(model))


def push_nominal(plan):
    """``(poly, planned)``: the plan's nominal polygon (:meth:`planning.PushPlan.nominal_part`)
    and the hull edge each push lands."""
    poly = plan.nominal_part()
    planned = [poly.caller_edge_to_hull(p.edge) for p in plan.pushes]
    return poly, planned


def _push_nominal_of(plan, poly, planned, Pp: int, mp: int, dtype) -> PushNominal:
    """A plan's :class:`PushNominal`, padded to ``Pp`` pushes and ``mp`` vertices."""
    P, m = len(plan.pushes), len(plan.vertices)
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
    return PushNominal(V0=jnp.asarray(V0, dtype), com0=jnp.asarray(poly.com, dtype),
                       start=jnp.asarray(plan.start, dtype),
                       ang=jnp.asarray(np.arctan2(dirs[:, 1], dirs[:, 0]), dtype),
                       dist=jnp.asarray(dist, dtype), planned=jnp.asarray(plan_e),
                       active=jnp.asarray(np.arange(Pp) < P),
                       hull=jnp.asarray(np.asarray(poly.hull_index, np.int32)))


def _push_samples_of(draws, Pp: int, mp: int, dtype) -> PushSamples:
    """The draws as per-sample :class:`PushSamples` rows, padded to ``Pp`` pushes
    and ``mp`` vertices, in ``dtype``."""
    p, a, rows_of = draws.params, draws.in_axes, draws.rows
    g, f, e = p.geometry, p.friction, p.execution
    ga, fa, ea = a.geometry, a.friction, a.execution
    rows = PushSamples(dv=_pad_axis(rows_of(g.vertex_offset, ga.vertex_offset), mp),
                       dc=rows_of(g.com_offset, ga.com_offset),
                       start=rows_of(e.start_offset, ea.start_offset),
                       fence=_pad_axis(rows_of(e.fence_angle, ea.fence_angle), Pp),
                       rel=_pad_axis(rows_of(e.distance_rel, ea.distance_rel), Pp),
                       abs=_pad_axis(rows_of(e.distance_abs, ea.distance_abs), Pp),
                       c=rows_of(f.c, fa.c), mu=rows_of(f.mu_f, fa.mu_f),
                       lift=rows_of(f.corner_lift, fa.corner_lift),
                       points=rows_of(f.support_points, fa.support_points),
                       weights=rows_of(f.support_weights, fa.support_weights))
    rows = jax.tree_util.tree_map(lambda v: v.astype(dtype), rows)
    return dataclasses.replace(rows, family=rows_of(f.family, fa.family).astype(jnp.int32))


def _static_model(model: str, draws):
    """The replay's static model: ``"limit_surface"`` becomes
    ``("limit_surface", families)``, the support families the draws hold
    (only those are built in the compiled replay)."""
    if model != "limit_surface":
        return model
    from kernels import FAMILIES

    f, fa = draws.params.friction, draws.in_axes.friction
    if fa.family is None:
        return ("limit_surface", (FAMILIES[int(np.asarray(f.family))],))
    present = {FAMILIES[int(k)] for k in np.unique(np.asarray(f.family))}
    return ("limit_surface", tuple(x for x in FAMILIES if x in present))


#: the fewest pushes a limit-surface replay is compiled for: a padded push costs
#: it nothing (its phase loop takes no trip) while each compilation costs 8-20 s
#: (the main job, margins.yaml under ``model: limit_surface``, compiled plans of
#: 4, 8 and 16 pushes: 48 s of its 1 min 44 s cold)
LIMIT_SURFACE_MIN_PUSHES = 16


def _push_bucket(P: int, model: str) -> int:
    """Pushes a replay of ``P`` pushes under ``model`` is padded to."""
    return _bucket(P, LIMIT_SURFACE_MIN_PUSHES if model == "limit_surface" else 2)


def run_push(plan, draws, model, dtype, chunk):
    """Replay a push plan on the samples ``draws`` (:class:`robustness.samplers.Draws`);
    returns ``(poly, planned, PushReplay)``."""
    poly, planned = push_nominal(plan)
    P, m = len(plan.pushes), len(plan.vertices)
    Pp, mp = _push_bucket(P, model), _bucket(m, 4)
    nom = _push_nominal_of(plan, poly, planned, Pp, mp, dtype)
    rows = _push_samples_of(draws, Pp, mp, dtype)
    res = _run_split(_push_batch, nom, rows, draws.n, chunk, _static_model(model, draws),
                     len(poly.hull_index))
    res = dataclasses.replace(res, edges=res.edges[:, :P], complete=res.complete[:, :P])
    return poly, planned, res


@functools.partial(jax.jit, static_argnames=("model",))
def _push_batch_many(noms, q, model):
    one = functools.partial(_push_one, model=model)
    return jax.lax.map(
        lambda nom: _blocks(lambda b: jax.vmap(one, in_axes=(None, 0))(nom, b), q, _block(model)),
        noms)


def run_push_many(plans, draws, model, dtype, chunk: int = 4096) -> PushReplay:
    """Replay ``K`` push plans of one part (the same vertices, centre of mass
    and start) on the SAME samples ``draws`` (common random numbers), in one
    compiled call per chunk of samples: the plans are padded to the longest
    (padding pushes are no-ops) and mapped over inside the call.  Push ``j`` of
    every plan sees the sample's push-``j`` errors, so ``draws`` must carry at
    least as many pushes as the longest plan (``n_pushes`` of the sampler).

    Returns:
      A :class:`PushReplay` of numpy arrays with a leading plan axis ``(K, n,
      ...)``; ``edges`` / ``complete`` padded to the longest plan (a plan's
      pushes past its own count are padding).
    """
    plans = list(plans)
    if not plans:
        raise ValueError("plans: expected at least one plan")
    ref = plans[0]
    for i, pl in enumerate(plans[1:], 1):
        if (pl.vertices, pl.com, pl.start) != (ref.vertices, ref.com, ref.start):
            raise ValueError(f"plans[{i}]: another part or start than plans[0] (candidates of "
                             "one task share both)")
    poly, _ = push_nominal(ref)
    width = np.shape(draws.params.execution.fence_angle)[-1] \
        if draws.in_axes.execution.fence_angle == 0 else 0
    P = max(len(pl.pushes) for pl in plans)
    if width and width < P:
        raise ValueError(f"draws: carry {width} pushes, the longest plan has {P} (draw with "
                         f"n_pushes={P})")
    Pp, mp = _push_bucket(max(P, width), model), _bucket(len(ref.vertices), 4)
    K = len(plans)
    noms = [_push_nominal_of(pl, poly, [poly.caller_edge_to_hull(p.edge) for p in pl.pushes],
                             Pp, mp, dtype) for pl in plans]
    noms += [noms[0]] * (_bucket(K, 1) - K)   # a power of two of plans: shared compilations
    noms = jax.tree_util.tree_map(lambda *xs: jnp.stack(xs), *noms)
    rows = _push_samples_of(draws, Pp, mp, dtype)
    res = _run_split(_push_batch_many, noms, rows, draws.n, chunk, _static_model(model, draws),
                     len(poly.hull_index), sample_axis=1)
    res = jax.tree_util.tree_map(lambda x: x[:K], res)
    return dataclasses.replace(res, edges=res.edges[:, :, :P], complete=res.complete[:, :, :P])


def edge_pairs(poly, hull_edges: np.ndarray):
    """Caller vertex indices ``(a, b)`` (two (n,) int64 arrays) of hull edges
    ``hull_edges`` ((n,) ints, :meth:`kernels.Polygon.edge_vertices` for each),
    ``-1`` where the edge is ``-1`` (no edge)."""
    e = np.asarray(hull_edges, np.int64).reshape(-1)
    hull = np.asarray(poly.hull_index, np.int64)
    ok = e >= 0
    safe = np.where(ok, e, 0)
    a = np.where(ok, hull[safe], -1)
    b = np.where(ok, hull[(safe + 1) % len(hull)], -1)
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
    rc, rs, tx, ty = edge_motion(C[:, f, k], C[:, f, kb], C[:, g, ga], C[:, g, gb])
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
    ``(c_a + c_b)/2 - R (q_a + q_b)/2``: :func:`kernels.edge_motion`, the
    kinematics :func:`kernels.tumble.tumble` applies in the world.  The faces
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

    The walk has ``W`` steps (the slips' columns); the plan's ``nom.n_steps``
    come first, the rest are no-ops whose slips are zeroed.  The two sums
    over the slips run over the walk zero-padded to a power of two (>= 16),
    so their bits depend only on the power of two ``W`` falls in, which for
    the draws of a plan's own length is the plan's (XLA sums a row of 256 in
    another order than a row of 208); on draws for a longer plan they can
    differ in the last bits.
    """
    from kernels import tumble_geometry

    geom = jax.vmap(lambda v, c: tumble_geometry(v, c, topology))(nom.V0 + q.dv, nom.com0 + q.dc)
    ec, es, ex, ey = _edge_motions(geom.corners_2d, topology)
    idx = nom.idx
    W = q.slip.shape[1]
    live = jnp.arange(W) < nom.n_steps
    slip = jnp.where(live[None, :, None], q.slip, jnp.zeros((), q.slip.dtype))
    dth = slip[:, :, 2].T                                         # (W, B)
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
        start = nom.start
        q0, phi0 = _frame_offset(geom, nom.origins, nom.xaxes, nom.start_face)
        th0 = start[2] + so[2] - phi0
        R0 = rot2(th0)
        xy = start[:2] + so[:2] - R0 @ q0 + R0 @ jnp.stack([X, Y]) + slip_xy
        th = th0 + jnp.arctan2(S, C)
        qf, phif = _frame_offset(geom, nom.origins, nom.xaxes, nom.final_face)
        xy_ref = xy + rot2(th) @ qf
        return xy_ref[0], xy_ref[1], wrap_angle(th + phif)

    padded = _pad_axis(slip[:, :, :2], _bucket(W, 16))
    x, y, th = jax.vmap(finish)(geom, q.start, jnp.sum(padded, axis=1), C, S, X, Y)
    return TumbleReplay(x=x, y=y, theta=th,
                        slip=jnp.sum(jnp.linalg.norm(padded, axis=-1), axis=1))


@functools.partial(jax.jit, static_argnames=("topology", "check", "slip_series"))
def _tumble_batch(nom, q, merge_tol, topology, check, slip_series):
    out = _blocks(lambda b: _tumble_block(nom, b, topology, slip_series), q, BLOCK)
    if check:   # the perturbed hulls, in float64 (their tolerance can be ~ float32's rounding)
        from kernels import polyhedron_hull_tables, polyhedron_hull_verdict_batch

        changed, undecided = polyhedron_hull_verdict_batch(
            nom.V64 + q.dv64, polyhedron_hull_tables(topology), merge_tol)
        out = dataclasses.replace(out, changed=changed, undecided=undecided)
    return out


def tumble_nominal(plan):
    """The plan's nominal polyhedron (its faces as the planner merged them at
    the plan's ``tau_v``; :meth:`planning.TumblePlan.nominal_part`, built once per part)."""
    return plan.nominal_part()


def _tumble_nominal_of(plan, poly, W: int, dtype) -> tuple:
    """``(TumbleNominal, final face, every step valid)`` of a plan, its walk
    padded to ``W`` steps (no-ops)."""
    topo = poly.topology
    idx, final_face, ok = _tumble_walk(plan, topo)
    seq = np.full(W, topo.n_faces * topo.max_face_size, np.int32)
    seq[:len(idx)] = idx
    nom = TumbleNominal(V0=jnp.asarray(poly.vertices, dtype), com0=jnp.asarray(poly.com, dtype),
                        origins=jnp.asarray(poly.face_origins, dtype),
                        xaxes=jnp.asarray(poly.face_rotations[:, 0, :], dtype),
                        start=jnp.asarray(plan.start[:3], dtype),
                        start_face=jnp.asarray(int(plan.start[3]), jnp.int32),
                        final_face=jnp.asarray(final_face, jnp.int32), idx=jnp.asarray(seq),
                        V64=jnp.asarray(poly.vertices, jnp.float64),
                        n_steps=jnp.asarray(len(idx), jnp.int32))
    return nom, final_face, ok


def _walk_width(draws, n_tumbles: int, chunk: int, plan: str = "the plan") -> int:
    """Steps of the compiled walk for a plan of ``n_tumbles`` (the longest of
    several) on ``draws``.  Up to one ``chunk`` of samples: the power of two
    (>= 16) that holds the plan, so that plans of lengths in one power of two
    share a compiled replay (the slips are padded to it: a copy, small at
    this size).  More samples: the columns of slips the sampler draws for
    the plan (:func:`robustness.samplers.drawn_steps`, >= 16), so that the
    draws of ``Sampler.sample(exact_steps=False)`` go in as they are (padding
    16,384 samples of a 200-tumble plan to 256 steps was an eighth of its
    evaluation) and the walk is no longer than that (208 steps, not 256);
    a compiled replay per drawn width, as the sampler compiles."""
    from robustness.samplers import drawn_steps

    sl, axis = draws.params.execution.tumble_slip, draws.in_axes.execution.tumble_slip
    width = np.shape(sl)[-2] if axis == 0 else 0
    if width and width < n_tumbles:
        raise ValueError(f"draws: carry {width} tumbles, {plan} has {n_tumbles} (draw with "
                         f"n_tumbles={n_tumbles})")
    k = max(n_tumbles, width)
    return _bucket(k, 16) if draws.n <= chunk else max(16, drawn_steps(k))


def _tumble_samples_of(draws, W: int, dtype) -> TumbleSamples:
    """The draws as per-sample :class:`TumbleSamples` rows (slips zero-padded
    to ``W`` steps)."""
    rows_of = draws.rows
    g, e = draws.params.geometry, draws.params.execution
    ga, ea = draws.in_axes.geometry, draws.in_axes.execution
    dv64 = rows_of(g.vertex_offset, ga.vertex_offset).astype(jnp.float64)
    slip = rows_of(e.tumble_slip, ea.tumble_slip)
    if slip.shape[1] < W:   # W >= the draws' columns (_walk_width)
        slip = _pad_axis(slip, W)
    return TumbleSamples(dv=dv64.astype(dtype),
                         dc=rows_of(g.com_offset, ga.com_offset).astype(dtype),
                         start=rows_of(e.start_offset, ea.start_offset).astype(dtype),
                         slip=slip.astype(dtype), dv64=dv64)


def _host_hull_check(poly, changed, undecided, dv64, merge_tol) -> np.ndarray:
    """The compiled hull check's verdict, its undecided samples decided on the host."""
    und = np.asarray(undecided).astype(bool)
    changed = np.asarray(changed).astype(bool).copy()
    if und.any():   # a point the nominal hull dropped pops out by < the merge distance
        V = poly.vertices[None] + np.asarray(dv64)[und]
        changed[und] = polyhedron_combinatorics_changed(V, poly, merge_tol)
    return changed


def run_tumble(plan, draws, dtype, chunk, merge_tol=None, slip_theta=math.inf):
    """Replay a tumble plan on the samples ``draws`` (and, with ``merge_tol``, check
    every perturbed hull); returns ``(poly, TumbleReplay)`` (``face`` and ``ok``
    the same for every sample; ``changed`` all False without the check).
    ``slip_theta``: a bound on the rotational slips (rad; the tolerance)."""
    poly = tumble_nominal(plan)
    topo = poly.topology
    W = _walk_width(draws, plan.n_tumbles, chunk)
    nom, final_face, ok = _tumble_nominal_of(plan, poly, W, dtype)
    n = draws.n
    rows = _tumble_samples_of(draws, W, dtype)
    check = merge_tol is not None
    tol = jnp.asarray(0.0 if merge_tol is None else merge_tol, jnp.float64)
    res = _run_chunks(_tumble_batch, nom, rows, n, chunk, tol, topo, check,
                      bool(slip_theta <= SLIP_SERIES_MAX))
    changed = (_host_hull_check(poly, res.changed, res.undecided, rows.dv64, merge_tol) if check
               else np.zeros(n, bool))
    return poly, dataclasses.replace(res, changed=changed, undecided=None,
                                     face=np.full(n, final_face, np.int64), ok=np.full(n, ok))


@functools.partial(jax.jit, static_argnames=("topology", "slip_series"))
def _tumble_batch_many(noms, q, topology, slip_series):
    return jax.lax.map(lambda nom: _blocks(
        lambda b: _tumble_block(nom, b, topology, slip_series), q, BLOCK), noms)


@functools.partial(jax.jit, static_argnames=("topology",))
def _hull_batch(V64, dv64, merge_tol, topology):
    from kernels import polyhedron_hull_tables, polyhedron_hull_verdict_batch

    return polyhedron_hull_verdict_batch(V64 + dv64, polyhedron_hull_tables(topology), merge_tol)


def run_tumble_many(plans, draws, dtype, chunk: int = 4096, merge_tol=None,
                    slip_theta=math.inf) -> TumbleReplay:
    """Replay ``K`` tumble plans of one part (the same vertices, centre of mass,
    tolerance and start) on the SAME samples ``draws`` (common random numbers)
    in one compiled call per chunk (the plans padded to the longest, mapped
    over inside the call); the perturbed hulls, the same for every plan, are
    checked once.  Tumble ``j`` of every plan sees the sample's slip ``j``, so
    ``draws`` must carry at least the longest plan's tumbles.

    Returns:
      A :class:`TumbleReplay` with a leading plan axis ``(K, n)``; ``face`` and
      ``ok`` ``(K, n)``; ``changed`` ``(K, n)`` (the same row for every plan).
    """
    plans = list(plans)
    if not plans:
        raise ValueError("plans: expected at least one plan")
    ref = plans[0]
    for i, pl in enumerate(plans[1:], 1):
        if (pl.vertices, pl.com, pl.start, pl.tau_v) != (ref.vertices, ref.com, ref.start,
                                                          ref.tau_v):
            raise ValueError(f"plans[{i}]: another part, tolerance or start than plans[0] "
                             "(candidates of one task share them)")
    poly = tumble_nominal(ref)
    topo = poly.topology
    L = max(pl.n_tumbles for pl in plans)
    W = _walk_width(draws, L, chunk, "the longest plan")
    K = len(plans)
    walks = [_tumble_nominal_of(pl, poly, W, dtype) for pl in plans]
    noms = [w[0] for w in walks]
    noms += [noms[0]] * (_bucket(K, 1) - K)
    noms = jax.tree_util.tree_map(lambda *xs: jnp.stack(xs), *noms)
    n = draws.n
    rows = _tumble_samples_of(draws, W, dtype)
    res = _run_chunks(_tumble_batch_many, noms, rows, n, chunk, topo,
                      bool(slip_theta <= SLIP_SERIES_MAX), sample_axis=1)
    res = jax.tree_util.tree_map(lambda x: x[:K], res)
    if merge_tol is not None:
        ch, und = _run_chunks(_hull_batch, walks[0][0].V64, rows.dv64, n, chunk,
                              jnp.asarray(merge_tol, jnp.float64), topo)
        changed = _host_hull_check(poly, ch, und, rows.dv64, merge_tol)
    else:
        changed = np.zeros(n, bool)
    return dataclasses.replace(
        res, changed=np.broadcast_to(changed, (K, n)).copy(), undecided=None,
        face=np.array([[w[1]] * n for w in walks], np.int64),
        ok=np.array([[w[2]] * n for w in walks], bool))
