"""The MJX backend: the same per-sample scenes, batched with ``jax.vmap`` (float32).

The per-sample models (:mod:`robustness.physics.scene`, compiled by the C
compiler so that both backends simulate exactly the same parts) are turned
into ONE ``mjx.Model`` whose differing fields carry a leading sample axis:
every traced field of ``mjx.put_model(models[0])`` that differs between the
samples is stacked (masses, inertias, centres of mass, the mesh geom's frame,
feet positions, pair frictions, ...) and the mesh's convex collision data
(``mesh_convex``: vertices, face corners, face normals; the index arrays are
the nominal ones) is rebuilt per sample from each model's mesh vertices.
``jax.vmap`` over the samples with those axes and ``lax.scan`` over a chunk
of steps; compiled once per (samples, chunk).

MJX runs with ``jax_enable_x64`` OFF (it fails inside ``lax.scan`` when x64
is on globally; here it is switched off in a scope, so a caller inside a
``@float64`` function is safe).  ``mujoco.mjx`` is imported lazily, with its
"Failed to import warp" lines kept out of the user's output.

Soft-friction creep (MJX has no noslip solver; neither has MuJoCo Warp):
measured by ``bench/physics.py`` on the rectangle's 15 cm reorient push at
mu_f 1.5, where the quasi-static model sticks, as the slip of the contact
along the fence: C engine with noslip 20 (the default there) 0.058 mm; C
without noslip, impratio 1: 7.99 mm; C without noslip, impratio 100:
0.23 mm; MJX (float32, impratio 100, this backend's setting): 0.50-0.60 mm
(0.18-0.47 mm of final pose error).  impratio makes friction stiffer than
the normal force (``R_friction = R_normal / impratio``), which is what
remains of MuJoCo's noslip remedy without it; higher values stiffen the
problem (impratio 1000 flipped a part in the C engine).

float32 noise, per sample (issue 37): on a part rocking on its corners (rigid
support) MJX's final heading is decided by rounding.  Eight copies of one
sample whose starts differ by at most 1e-7 m and 1e-6 rad end within 0.02-0.05
deg of each other in the C engine and span 0.45-1.9 deg in MJX (mostly
+-0.25 deg, one copy in 8-16 near 1.7 deg); a new jaxlib (0.10.1, 0.10.2)
changes which copy lands where.  Compare MJX with the C engine over samples
(medians, rates), never one sample's heading to a tenth of a degree
(``tests/test_physics_mjx.py``).

Speed (2 CPU cores, float32): the compilation takes 30-60 s, then 1,500-
3,200 world-steps/s for 2-4 worlds, against 35,000-49,000 steps/s per
thread for the C engine on the same scene: on a CPU machine the C engine
is the backend (``"auto"`` picks it).
"""
from __future__ import annotations

import contextlib
import functools
import io

import jax
import jax.numpy as jnp
import numpy as np


@functools.lru_cache(maxsize=1)
def mjx():
    """``mujoco.mjx``, imported once with its optional-backend noise silenced."""
    with contextlib.redirect_stdout(io.StringIO()):
        from mujoco import mjx as _mjx
    return _mjx


def _newell(corners: np.ndarray) -> np.ndarray:
    """Unit Newell normals of polygons (..., k, 3)."""
    nxt = np.roll(corners, -1, axis=-2)
    n = np.cross(corners, nxt).sum(axis=-2)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def _nearest(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Index in ``b`` of the nearest row to each row of ``a``."""
    return np.argmin(np.linalg.norm(a[:, None, :] - b[None, :, :], axis=-1), axis=1)


def _convex_batch(cm, models, mesh_id: int):
    """Per-sample ``mesh_convex`` arrays (vert, face, face_normal) from each
    model's mesh vertices (in its own mesh frame), with the nominal indices."""
    m0 = models[0]
    adr, num = int(m0.mesh_vertadr[mesh_id]), int(m0.mesh_vertnum[mesh_id])
    vert0 = np.asarray(cm.vert, np.float64)
    vmap_idx = _nearest(vert0, np.asarray(m0.mesh_vert[adr:adr + num], np.float64))
    face0 = np.asarray(cm.face, np.float64)
    face_idx = _nearest(face0.reshape(-1, 3), vert0).reshape(face0.shape[:2])
    normal0 = np.asarray(cm.face_normal, np.float64)
    verts, faces, normals = [], [], []
    for m in models:
        v = np.asarray(m.mesh_vert[adr:adr + num], np.float64)[vmap_idx]
        f = v[face_idx]
        nrm = _newell(f)
        same = np.einsum("fi,fi->f", nrm, normal0) >= 0
        verts.append(v)
        faces.append(f)
        normals.append(np.where(same[:, None], nrm, -nrm))
    return np.stack(verts), np.stack(faces), np.stack(normals)


def _chunk_one(m, d0, qpos, qvel, time, ctrl):
    """One sample: ``ctrl.shape[0]`` MJX steps from ``(qpos, qvel, time)``."""
    step = mjx().step
    d = d0.replace(qpos=qpos, qvel=qvel, time=time)

    def body(d, u):
        d = step(m, d.replace(ctrl=u))
        return d, (d.time, d.qpos, d.qvel, d.sensordata)

    _, out = jax.lax.scan(body, d, ctrl)
    return out


_CHUNK_FNS: dict = {}


def _chunk_fn(batched: tuple, convex: tuple, axes, structure: tuple):
    """The jitted, vmapped chunk function for one batching pattern and model
    structure (sizes: scenes with other feet counts differ), kept so that later
    engines with the same pattern reuse its compilation instead of compiling
    again (~1 minute on a CPU)."""
    key = (batched, convex, structure)
    if key not in _CHUNK_FNS:
        _CHUNK_FNS[key] = jax.jit(jax.vmap(_chunk_one, in_axes=(axes, None, 0, 0, 0, 0)))
    return _CHUNK_FNS[key]


class MJXEngine:
    """Runs chunks of steps for a batch of per-sample models with MJX.

    Args:
      models: the per-sample C models (same structure; MJX-compatible).
      chunk: steps per compiled call (shorter calls are padded with their
        last control and cut).
    """

    name = "mjx"

    def __init__(self, models, chunk: int):
        self.models = list(models)
        self.n = len(self.models)
        self.chunk = int(chunk)
        m0 = self.models[0]
        self.nq, self.nv = m0.nq, m0.nv
        with jax.enable_x64(False):
            mx = mjx().put_model(m0)
            self._build(mx)

    def _build(self, mx) -> None:
        axes = jax.tree_util.tree_map(lambda x: None, mx)
        batched, ax = {}, {}
        for name in (f.name for f in mx.fields() if f.name != "_impl"):
            val = getattr(mx, name)
            if not isinstance(val, jax.Array) or not hasattr(self.models[0], name):
                continue
            stack = np.stack([np.asarray(getattr(m, name)) for m in self.models])
            if name == "pair_friction" or np.any(stack != stack[:1]):
                batched[name] = jnp.asarray(stack.reshape((self.n,) + tuple(val.shape)), val.dtype)
                ax[name] = 0
        impl = mx._impl
        convex = list(impl.mesh_convex)
        convex_axes = list(axes._impl.mesh_convex)
        for mid, cm in enumerate(convex):
            if cm is None:
                continue
            v, f, nrm = _convex_batch(cm, self.models, mid)
            convex[mid] = cm.replace(vert=jnp.asarray(v, jnp.float32),
                                     face=jnp.asarray(f, jnp.float32),
                                     face_normal=jnp.asarray(nrm, jnp.float32))
            convex_axes[mid] = convex_axes[mid].replace(vert=0, face=0, face_normal=0)
        self.model = mx.replace(**batched, _impl=impl.replace(mesh_convex=tuple(convex)))
        self.axes = axes.replace(**ax, _impl=axes._impl.replace(mesh_convex=tuple(convex_axes)))
        self.batched_fields = tuple(sorted(batched))
        self._d0 = mjx().make_data(mx)
        convex_key = tuple(i for i, cm in enumerate(convex) if cm is not None)
        # the model's static part (sizes, mesh faces, ...) is in its tree structure
        structure = jax.tree_util.tree_structure(self.model)
        self._run = _chunk_fn(self.batched_fields, convex_key, self.axes, structure)

    def run(self, state: np.ndarray, controls: np.ndarray):
        """Same contract as :meth:`robustness.physics.c_engine.CEngine.run`
        (float32 inside, float64 out)."""
        n, K, _ = controls.shape
        if K > self.chunk:
            raise ValueError(f"controls: at most {self.chunk} steps per call, got {K}")
        ctrl = controls
        if K < self.chunk:
            ctrl = np.concatenate([controls, np.repeat(controls[:, -1:], self.chunk - K, axis=1)],
                                  axis=1)
        nq = self.nq
        with jax.enable_x64(False):
            t, q, v, s = self._run(self.model, self._d0,
                                   jnp.asarray(state[:, 1:1 + nq], jnp.float32),
                                   jnp.asarray(state[:, 1 + nq:1 + nq + self.nv], jnp.float32),
                                   jnp.asarray(state[:, 0], jnp.float32),
                                   jnp.asarray(ctrl, jnp.float32))
            t, q, v, s = (np.asarray(a, np.float64)[:, :K] for a in jax.device_get((t, q, v, s)))
        st = np.concatenate([t[..., None], q, v, np.zeros((n, K, state.shape[1] - 1 - nq - self.nv))],
                            axis=-1)
        return st, s

    def set_pair_friction(self, pair_ids, mu: np.ndarray) -> None:
        """As :meth:`robustness.physics.c_engine.CEngine.set_pair_friction`."""
        ids = np.asarray(pair_ids, np.int64)
        mu = np.asarray(mu, np.float64)
        if mu.ndim == 2:
            mu = np.stack([mu, mu], axis=-1)
        with jax.enable_x64(False):
            pf = np.asarray(self.model.pair_friction, np.float64).copy()
            pf[:, ids, :2] = mu
            self.model = self.model.replace(pair_friction=jnp.asarray(pf, jnp.float32))

    def close(self) -> None:
        """Nothing to release."""
