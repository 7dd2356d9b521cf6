"""One block of a task's Monte-Carlo samples, and a task's summary from its blocks.

The block runner shared by a study's units (:mod:`sweeps.work`) and a
certification's growing sample schedule (:mod:`sweeps.certify`):

* :func:`sample_block` evaluates a plan on one block of ``n`` samples drawn with
  its key, builds the block's ``samples`` table straight from the evaluation's
  arrays (:func:`robustness.tables.arrow_table`) and returns it with the
  block's statistics (:data:`robustness.STAT_COLUMNS`: the per-sample values a
  summary needs, a few columns);
* :func:`block_stats` reads those statistics back from a block's file (a block
  finished by an earlier, interrupted run);
* :func:`summarise_blocks` merges the blocks' statistics into the task's
  ``summary`` row (:func:`robustness.summarise`): the samples are never read back
  from disk to be summarised.
"""
from __future__ import annotations

import dataclasses
import pathlib
from typing import Mapping, Optional, Sequence

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from robustness import arrow_table, evaluate, model_for, samples_columns, STAT_COLUMNS, summarise


@dataclasses.dataclass(frozen=True)
class Block:
    """A finished block: its ``samples`` table and its statistics
    (``{column: (n,) array}`` of :data:`robustness.STAT_COLUMNS`)."""

    table: pa.Table
    stats: dict

    @property
    def n(self) -> int:
        return self.table.num_rows

    @property
    def n_success(self) -> int:
        return int(np.sum(self.stats["success"]))


def block_stem(task_index: int, block: int) -> str:
    """The file stem (and unit key) of a task's sample block: ``t<task>-b<block>``."""
    return f"t{task_index:04d}-b{block:04d}"


def sample_block(plan, cfg, physics, task: str, n: int, key, *, lo: int, run_id: str,
                 schema: pa.Schema, columns: Mapping = (), model: Optional[str] = None) -> Block:
    """Evaluate ``plan`` on one block of ``n`` samples of ``cfg``'s sampler.

    Args:
      plan: the task's plan; cfg: the validated configuration (a study's or a
        certification's: sampler, model, dtype, eps, confidence, physics);
      physics: the :class:`~robustness.physics.PhysicsRun` of ``model: mujoco``
        with the part's material (``cfg.physics_run(part)`` for a study; a
        certification's config holds the material already), else None;
        task: the task's name.
      n: samples in the block; key: the block's ``jax.random`` key;
        lo: its first sample's id.
      run_id, columns: the ``run_id`` and a study's swept columns (constant);
        schema: the ``samples`` schema with those columns.
      model: the model (default ``cfg.model``).

    Returns:
      :class:`Block`.
    """
    ev = evaluate(plan, cfg.sampler(), n, key, cfg.eps, cfg.model_spec(model, physics), task=task)
    data = {"run_id": run_id, **dict(columns), **samples_columns(ev, lo)}
    return Block(arrow_table(data, schema, n),
                 {c: np.asarray(data[c]) for c in STAT_COLUMNS})


def block_stats(path: pathlib.Path) -> dict:
    """The statistics (:data:`robustness.STAT_COLUMNS`) of a block's ``samples`` file."""
    t = pq.read_table(path, columns=list(STAT_COLUMNS))
    return {c: t.column(c).to_numpy(zero_copy_only=False) for c in STAT_COLUMNS}


def summarise_blocks(stats: Sequence[dict], plan, cfg, task: str, *, model: Optional[str] = None,
                     bound: bool = True) -> dict:
    """The ``summary`` row of a task from its blocks' statistics (any order: the
    summary sorts by ``sample_id``), as :func:`robustness.summarise` gives it for
    the concatenated samples."""
    import pandas as pd

    kind = plan.kind
    df = pd.DataFrame({c: np.concatenate([s[c] for s in stats]) for c in STAT_COLUMNS})
    return summarise(df, plan, cfg.sampler(), kind=kind, model=model_for(model or cfg.model, kind),
                     dtype=cfg.dtype, criterion=cfg.eps, confidence=cfg.required.confidence,
                     task=task, bound=bound)
