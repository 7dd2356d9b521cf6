"""The evaluation models and which one applies to a plan.

* ``"limit_surface"`` (:data:`DEFAULT_MODEL`): push plans under the
  quasi-static pushing model on the exact limit surface of the sample's
  support points (its family's corners or feet and their loads,
  :mod:`kernels.quasistatic_points`); it predicts the slip a part on 3-4
  corners shows in MuJoCo where the ellipsoid of the same ``c`` predicts none.
  Some 7,700 samples/s of a 7-push plan on rigid corners, 1,300 on ``any``
  (2 CPU cores, ``bench/robustness.py``; :data:`THROUGHPUT` for whole studies).
* ``"quasistatic"``: the fast approximation, the same pushing model on the
  ellipsoidal limit surface of one ratio ``c`` (:mod:`kernels.quasistatic`:
  sticking / sliding fence contact): 30-140 times faster, and wrong where
  a part rests on a few corners.
* ``"exact"``: the papers' kinematics (push: :mod:`kernels.push`; tumble:
  :mod:`kernels.tumble`, the only non-physical model of a tumble).
* ``"mujoco"``: the plan rolled out in MuJoCo (:mod:`robustness.physics`).

A plan's kind and the model that applies to it: :mod:`robustness.kinds` (the
dispatch table), re-exported here.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Any, Optional

import jax.numpy as jnp

# their home: the dispatch table of plan kinds
from robustness.kinds import MODELS, PUSH_KINEMATIC, model_for, plan_kind  # noqa: F401

#: the model every decision is made with unless a config or a caller names another
#: (studies, certification, robust synthesis, margin search, tolerance design): the
#: exact limit surface, whose success agrees with MuJoCo on 0.95 of runs on rigid
#: corners where the ellipsoidal ``quasistatic`` model agrees on 0.66
#: (``bench/fidelity.py``); ``quasistatic`` stays, named, as the fast approximation
DEFAULT_MODEL = "limit_surface"


#: samples per compiled call of a kinematic replay (bounds memory; the last, partial
#: chunk is padded to a power of two, so sample counts share compilations)
CHUNK = 4096
#: polyhedra: the face-merging tolerance factor of the combinatorics check
#: (:func:`robustness.samplers.face_merge_tol`)
MERGE_FACTOR = 8.0


@dataclasses.dataclass(frozen=True)
class Model:
    """How samples are replayed: the model and how it runs (what every call that
    evaluates samples takes as one value, ``model=``; a bare name stands for
    ``Model(name)``, :meth:`of`).

    Attributes:
      name: one of :data:`MODELS` (``"quasistatic"``, ``"limit_surface"``,
        ``"exact"``, ``"mujoco"``; module docstring).
      dtype: the kinematic kernels' float dtype, ``float64`` or ``float32`` (the
        perturbations are drawn in float64 and cast, so both see the same samples).
        MuJoCo: float64 on the C engine, float32 under MJX, whatever ``dtype``.
      physics: read by ``"mujoco"`` only: a :class:`robustness.physics.PhysicsRun`
        (backend, stroke, cell settings); None: ``PhysicsRun()``.
      chunk: samples per compiled call of a kinematic replay (:data:`CHUNK`).
      merge_factor: polyhedra: the face-merging tolerance factor of the
        combinatorics check (:data:`MERGE_FACTOR`).

    A bad field is refused when the value is made, in one line naming it.
    """

    name: str
    dtype: Any = jnp.float64
    physics: Optional[Any] = None
    chunk: int = CHUNK
    merge_factor: float = MERGE_FACTOR

    def __post_init__(self):
        if self.name not in MODELS:
            raise ValueError(f"model: expected one of {MODELS}, got {self.name!r}")
        try:
            dt = jnp.dtype(self.dtype)
        except TypeError:
            dt = None
        if dt not in (jnp.dtype(jnp.float32), jnp.dtype(jnp.float64)):
            raise ValueError(f"dtype: expected float64 or float32, got {self.dtype!r}")
        object.__setattr__(self, "dtype", dt)
        if not (isinstance(self.chunk, int) and not isinstance(self.chunk, bool)
                and self.chunk >= 1):
            raise ValueError(f"chunk: expected an integer >= 1, got {self.chunk!r}")
        if not (isinstance(self.merge_factor, (int, float)) and math.isfinite(self.merge_factor)
                and self.merge_factor > 0):
            raise ValueError(f"merge_factor: expected a finite number > 0, "
                             f"got {self.merge_factor!r}")

    @classmethod
    def of(cls, model, **fields) -> "Model":
        """``model`` as a :class:`Model`: a Model as it is (``fields`` replaced),
        a name as ``Model(name, **fields)``."""
        if isinstance(model, cls):
            return dataclasses.replace(model, **fields) if fields else model
        if isinstance(model, str):
            return cls(model, **fields)
        raise ValueError(f"model: expected one of {MODELS} or a robustness.Model, got {model!r}")

    def for_kind(self, kind: str) -> "Model":
        """The model a plan of ``kind`` is evaluated under (:func:`model_for`:
        tumbles have only ``exact`` and ``mujoco``)."""
        name = model_for(self.name, kind)
        return self if name == self.name else dataclasses.replace(self, name=name, physics=None)


def decision_model(model: str, kind: str) -> str:
    """The kinematic model that makes a choice (robust synthesis, margin search,
    tolerance design) for a configuration of ``model``: the model itself, or
    under ``"mujoco"`` (physics certifies; its rollouts are too slow to search
    with) :data:`DEFAULT_MODEL` for pushes, the exact kinematics for tumbles."""
    if model == "mujoco":
        return DEFAULT_MODEL if kind == "push" else "exact"
    return model_for(model, kind)


#: Measured throughput of a whole study, samples per second on 2 CPU cores once
#: compiled (sampling, replay or rollout, summaries and Parquet writes), by (plan
#: kind, model, support family); ``"*"`` stands for every family not listed.  For the
#: commands' estimates (the line before a run, ``--dry-run``, the budget) and the
#: block size (:func:`block_samples`).  Push rows: ``bench/throughput.py`` (the
#: nice-stable pentagon, 4 random tasks 5-15 cm away, the extra samples' time
#: between two counts, each run in a new folder with its compilations warm):
#: ``RESULT quasistatic_any=5.22e+03 exact_any=8.19e+04 limit_surface_rigid=28.5
#: limit_surface_any=10.2 mujoco_rigid=6.23 mujoco_any=1.86``; after the limit
#: surface's new motion solver (December 2026) ``limit_surface_rigid=73.9
#: limit_surface_any=82.8``, taken here as 70 and 60 (``bench/robustness.py``'s
#: 7-push plan: 175 and 60 samples/s of the replay alone); after its warm-started
#: node solves (December 2026, measured while the machine ran other work)
#: ``limit_surface_rigid=364 limit_surface_any=52.4``, taken as 300 and 50 (the
#: replay alone: 2,050-2,200 and 165 samples/s); after ``any``'s batches were split
#: by point count (December 2026, quiet machine) ``limit_surface_rigid=1e+03
#: limit_surface_any=336``, taken as 800 and 250 (the replay alone: 2,200 and 458); after 8
#: quadrature panels (December 2026, quiet machine) ``limit_surface_rigid=2.48e+03
#: limit_surface_any=489``, taken as 2,000 and 400 (the replay alone: 3,900 and 760); with a
#: batch's calls on both cores (December 2026, quiet machine) ``limit_surface_rigid=4.29e+03
#: limit_surface_any=656``, taken as 4,000 and 600 (the replay alone: 7,700 and 1,300); after
#: the warm sliding polish halved its overshooting steps (December 2026, quiet machine)
#: ``limit_surface_rigid=9.46e+03 limit_surface_any=572``, taken as 8,000 and 600 (the
#: replay alone: 11,000-16,000 and 3,200-4,400; ``any``'s row is what a short run sees: a
#: run of 4 x 576 samples spent 7.5 s in its calls (cProfile), most of it tracing and
#: loading each family group's compiled shapes in the fresh process, where one warm
#: process runs those 576 samples at 2,700/s); with a batch's calls one after the other
#: (:func:`robustness.replay._map_calls`: on two threads they deadlocked now and then,
#: December 2026) ``limit_surface_rigid=6.07e+03 limit_surface_any=597``, taken as 6,000 and
#: 600; with a batch's calls spread over a CPU device per core (the cause of the deadlock,
#: LAPACK's batched LU in the support kernels, removed: :mod:`kernels.linsolve`; December
#: 2026) ``limit_surface_rigid=1.19e+04 limit_surface_any=697 quasistatic_any=1.44e+04``,
#: taken as 10,000, 600 and 12,000 (the replay alone: 17,000 and 4,500).  (The table before
#: December 2026 took a cold whole run for the extra samples' time: quasistatic 800,
#: limit_surface 8 and 0.85, 6-90 times too slow.)  Families not measured (tripod,
#: uniform, ring) take the ``"*"`` row.  Tumble rows: the same bench's ``tumble-``
#: rows (the irregular polyhedron, 2 random tasks of ``examples/studies/tolerances.yaml``):
#: ``RESULT tumble_exact_any=1.04e+05`` (2 tasks), ``tumble_mujoco_any=1.03`` (2 tasks).
THROUGHPUT = {
    ("push", "exact", "*"): 80_000.0,
    ("push", "quasistatic", "*"): 12_000.0,
    ("push", "limit_surface", "rigid"): 10_000.0,
    ("push", "limit_surface", "*"): 600.0,
    ("push", "mujoco", "rigid"): 6.0,
    ("push", "mujoco", "*"): 1.9,
    # a sensorless plan replays its pushes as a push plan does (not measured apart)
    ("sensorless", "exact", "*"): 80_000.0,
    ("sensorless", "quasistatic", "*"): 5_000.0,
    ("sensorless", "limit_surface", "*"): 600.0,
    # one rollout a sample from its own start (the rectangle of
    # examples/certify_sensorless.yaml: 8 fence pushes, some 2 m of travel)
    ("sensorless", "mujoco", "*"): 0.1,
    ("tumble", "exact", "*"): 100_000.0,
    ("tumble", "mujoco", "*"): 1.0,
}


def samples_per_second(kind: str, model: str, support: object = "any") -> float:
    """Measured samples/s (2 CPU cores, compiled) of ``model`` on plans of
    ``kind`` for a part on ``support`` (a family name; anything else counts as
    ``"*"``): :data:`THROUGHPUT`."""
    model = model_for(model, kind)
    fam = support if isinstance(support, str) else "*"
    return THROUGHPUT.get((kind, model, fam), THROUGHPUT[(kind, model, "*")])


#: the wall time (s, 2 CPU cores) a block of samples is sized to: what Ctrl-C waits
#: for ("stopping after the running chunk") and what a crash loses
BLOCK_SECONDS = 30.0
#: the fewest and the most samples of a block (a power of two between them)
BLOCK_MIN, BLOCK_MAX = 8, 65_536


def block_samples(kind: str, model: str, support: object = "any") -> int:
    """Samples per block of a run whose own block size is not set: the largest
    power of two that ``model`` evaluates in about :data:`BLOCK_SECONDS`
    (:func:`samples_per_second`), within [:data:`BLOCK_MIN`, :data:`BLOCK_MAX`].

    A block is the unit that is written, resumed and held in memory at once:
    a 10^5-sample MuJoCo run builds 32-128 models at a time, not 10^5 (which grew
    to 4 GB before the first sample ran)."""
    r = samples_per_second(kind, model, support) * BLOCK_SECONDS
    return int(min(BLOCK_MAX, max(BLOCK_MIN, 2 ** math.floor(math.log2(max(r, 1.0))))))


#: Peak resident memory (bytes) of a process that samples, before its block:
#: Python, JAX, MuJoCo and the compiled kernels.  Measured (ru_maxrss, 2 CPU cores,
#: ``nudge certify`` of the triangle): 0.75-0.93 GB whatever the sample count.
MEMORY_BASE = 1.0e9
#: Resident bytes per sample of the block a process holds at once, measured the same
#: way: kinematic models 3.4-4 kB (quasistatic 500 -> 16,384 samples: +64 MB; exact
#: 500 -> 65,536: +222 MB); MuJoCo 1.7 MB (a model per sample and every step's
#: states: 4 -> 48 samples, +74 MB).
SAMPLE_BYTES = {"mujoco": 1.7e6, "*": 4.0e3}


def peak_bytes(model: str, block: int) -> float:
    """Estimated peak resident memory (bytes) of a process that evaluates
    blocks of ``block`` samples under ``model``: :data:`MEMORY_BASE` plus
    :data:`SAMPLE_BYTES` per sample."""
    return MEMORY_BASE + int(block) * SAMPLE_BYTES.get(model, SAMPLE_BYTES["*"])


__all__ = ["Model", "CHUNK", "MERGE_FACTOR", "plan_kind", "BLOCK_MAX", "BLOCK_MIN", "BLOCK_SECONDS", "MEMORY_BASE", "MODELS", "PUSH_KINEMATIC",
           "SAMPLE_BYTES", "THROUGHPUT", "block_samples", "model_for", "peak_bytes",
           "samples_per_second"]
