"""A task's sample blocks on disk: the files half of the block runner.

The pure half (evaluating a block, growing a task's blocks, merging their
statistics into the summary) is :mod:`robustness.blocks`; a study's units
(:mod:`sweeps.work`) and a certification's growing sample schedule
(:mod:`sweeps.certify`) add the files:

* :func:`sample_block` evaluates a plan on one block of ``n`` samples drawn with
  its key (:func:`robustness.sample_block`) and builds the block's ``samples``
  table straight from the evaluation's arrays
  (:func:`robustness.tables.arrow_table`), returned with the block's
  statistics (:data:`robustness.STAT_COLUMNS`: the per-sample values a summary
  needs, a few columns);
* :func:`block_stats` reads those statistics back from a block's file (a block
  finished by an earlier, interrupted run);
* :func:`summarise_blocks` merges the blocks' statistics into the task's
  ``summary`` row (:func:`robustness.summarise_stats`): the samples are never
  read back from disk to be summarised;
* :class:`StoredBlocks` grows a certification's task block by block
  (:class:`robustness.BlockRun` with these files, resume and Ctrl-C).
"""
from __future__ import annotations

import dataclasses
import pathlib
import warnings
from typing import Mapping, Optional, Sequence

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from robustness import (BlockRun, SAMPLES_SCHEMA, STAT_COLUMNS, arrow_table, model_for,
                        sample_block as evaluate_block, summarise_stats)


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
    block = evaluate_block(plan, cfg.sampler(), n, key, cfg.eps, cfg.model_spec(model, physics),
                           first=lo, task=task)
    return Block(block_table(block, run_id, schema, columns), block.stats)


def block_table(block, run_id: str, schema: pa.Schema, columns: Mapping = ()) -> pa.Table:
    """The ``samples`` table of a :class:`robustness.Block`: its columns with
    the ``run_id`` and a study's swept ``columns`` (constant) in ``schema``."""
    return arrow_table({"run_id": run_id, **dict(columns), **block.columns}, schema, block.n)


def block_stats(path: pathlib.Path) -> dict:
    """The statistics (:data:`robustness.STAT_COLUMNS`) of a block's ``samples`` file."""
    t = pq.read_table(path, columns=list(STAT_COLUMNS))
    return {c: t.column(c).to_numpy(zero_copy_only=False) for c in STAT_COLUMNS}


def summarise_blocks(stats: Sequence[dict], plan, cfg, task: str, *, model: Optional[str] = None,
                     bound: bool = True) -> dict:
    """The ``summary`` row of a task from its blocks' statistics (any order: the
    summary sorts by ``sample_id``), as :func:`robustness.summarise` gives it for
    the concatenated samples."""
    kind = plan.kind
    return summarise_stats(stats, plan, cfg.sampler(), kind=kind,
                           model=model_for(model or cfg.model, kind), dtype=cfg.dtype,
                           criterion=cfg.eps, confidence=cfg.required.confidence, task=task,
                           bound=bound)


class StoredBlocks(BlockRun):
    """A certification's task's samples as resumable blocks of ``size`` (the
    pure runner, :class:`robustness.BlockRun`, with files; ``cfg`` the
    certification's config, ``store`` its run folder, ``ti`` the task's index,
    ``done`` the units an earlier run finished, ``flag.stop`` set by Ctrl-C):
    each block written to the run's ``samples`` table and marked done; a block
    an earlier run finished is read back (its statistics); Ctrl-C stops before
    the next block."""

    def __init__(self, cfg, store, plan, name, ti, key, size, model, done, flag):
        super().__init__(plan, cfg.sampler(), key, size, cfg.eps,
                         cfg.model_spec(model, cfg.physics_run()), name)
        self.cfg, self.store, self.ti, self.model_name = cfg, store, ti, model
        self.done, self.flag = done, flag

    def stopped(self) -> bool:
        """Ctrl-C was pressed."""
        return self.flag.stop

    def stored(self, b: int, m: int):
        """Block ``b``'s statistics read back from its file when an earlier run
        finished it; a file of another size is refused (another version)."""
        unit = block_stem(self.ti, b)
        if unit not in self.done:
            return None
        path = self.store.table_path("samples", 0, unit)
        st = block_stats(path)
        if len(st["success"]) != m:
            from sweeps.store import RunError

            raise RunError(f"{path}: holds {len(st['success'])} samples, the schedule of "
                           f"this run draws {m} in this block (drawn by another version of"
                           f" nudge?): certify into a new --out folder")
        return st

    def extend(self, total: int) -> tuple[int, int]:
        """:meth:`robustness.BlockRun.extend`, the blocks' warnings reported."""
        from sweeps.terminal import report_warnings

        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            out = super().extend(total)
        report_warnings(caught)
        return out

    def finished(self, b: int, block) -> None:
        """Block ``b`` written to the run's ``samples`` table and marked done."""
        unit = block_stem(self.ti, b)
        path = self.store.table_path("samples", 0, unit)
        self.store.write("samples", 0, unit, block_table(block, self.store.run_id, SAMPLES_SCHEMA),
                         SAMPLES_SCHEMA)
        self.store.mark_done(unit, [path], rows=block.n)

    def task_summary(self) -> dict:
        """The task's summary row (:func:`summarise_blocks` under the config),
        its warnings reported."""
        from sweeps.terminal import report_warnings

        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            s = summarise_blocks(self.stats, self.plan, self.cfg, self.task,
                                 model=self.model_name)
        report_warnings(caught)
        return s
