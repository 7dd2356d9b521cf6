"""A plan's Monte-Carlo samples in blocks, and its summary from the blocks'
statistics: the pure half of the one block runner.

Block ``b`` of a task's samples is drawn with ``fold_in(key, b)``, so growing
the count keeps the samples drawn before (a certification's looks, a resumed
run).  The pieces:

* :func:`sample_block` evaluates a plan on one block and keeps the block's
  statistics (:data:`robustness.STAT_COLUMNS`: the per-sample values a summary
  needs) and the samples table's columns (:func:`robustness.samples_columns`);
* :class:`BlockRun` grows a task's blocks to a total (:meth:`BlockRun.extend`,
  what :func:`robustness.grow` calls look by look) and merges their statistics
  into the summary row (:meth:`BlockRun.summary`); a caller that keeps blocks
  on disk overrides its hooks (:meth:`~BlockRun.stored`,
  :meth:`~BlockRun.finished`, :meth:`~BlockRun.stopped`);
* :func:`summarise_stats` is that merge (any order of blocks: the summary
  sorts by ``sample_id``), equal to :func:`robustness.summarise` of the
  concatenated samples.

:func:`robustness.certify` runs a :class:`BlockRun` in memory; the command
line's certifications and studies (:mod:`sweeps.blocks`, :mod:`sweeps.certify`,
:mod:`sweeps.work`) add the files and the resume.
"""
from __future__ import annotations

import dataclasses
from typing import Optional, Sequence

import numpy as np

from robustness.evaluation import Evaluation, evaluate
from robustness.summary import STAT_COLUMNS, summarise
from robustness.tables import samples_columns


@dataclasses.dataclass(frozen=True)
class Block:
    """One finished block of samples.

    Attributes:
      evaluation: its :class:`~robustness.Evaluation` (``sample_id`` from 0).
      first: its first sample's id in the task.
      columns: the ``samples`` table's columns but ``run_id`` and a study's
        swept ones (:func:`robustness.samples_columns`), ``sample_id`` counted
        from the block's first sample.
      stats: ``{column: (n,) array}`` of :data:`robustness.STAT_COLUMNS`.
    """

    evaluation: Evaluation
    first: int
    columns: dict
    stats: dict

    @property
    def n(self) -> int:
        return len(self.stats["success"])

    @property
    def n_success(self) -> int:
        return int(np.sum(self.stats["success"]))


def sample_block(plan, sampler, n: int, key, criterion, model, *, first: int = 0,
                 task: str = "task") -> Block:
    """Evaluate ``plan`` on one block of ``n`` samples of ``sampler`` drawn with
    ``key`` (:func:`robustness.evaluate` with ``criterion`` and ``model``, a
    :class:`~robustness.Model` or a name); ``first``: the block's first
    sample's id; ``task``: the task's name in the tables."""
    ev = evaluate(plan, sampler, n, key, criterion, model, task=task, bound=False)
    cols = samples_columns(ev, first)
    return Block(ev, first, cols, {c: np.asarray(cols[c]) for c in STAT_COLUMNS})


def summarise_stats(stats: Sequence[dict], plan, sampler, *, kind: str, model: str, dtype: str,
                    criterion, confidence: float, task: str, bound: bool = True) -> dict:
    """The summary row of a task from its blocks' statistics (any order), as
    :func:`robustness.summarise` gives it for the concatenated samples (its
    arguments but the samples)."""
    import pandas as pd

    df = pd.DataFrame({c: np.concatenate([s[c] for s in stats]) for c in STAT_COLUMNS})
    return summarise(df, plan, sampler, kind=kind, model=model, dtype=dtype, criterion=criterion,
                     confidence=confidence, task=task, bound=bound)


class BlockRun:
    """A task's samples in blocks of ``size``, block ``b`` drawn with
    ``fold_in(key, b)`` and evaluated by :func:`sample_block`; ``n`` and ``k``
    count the samples and successes so far, ``stats`` holds each block's
    statistics in order and, with ``keep``, ``blocks`` the blocks themselves
    (:meth:`samples`).

    A caller that keeps blocks (files, resume) overrides the hooks:
    :meth:`stored` (a finished block's statistics, from an earlier run),
    :meth:`finished` (a block just evaluated) and :meth:`stopped` (stop
    growing: Ctrl-C).
    """

    def __init__(self, plan, sampler, key, size: int, criterion, model, task: str = "task",
                 keep: bool = False):
        if not (isinstance(size, (int, np.integer)) and size >= 1):
            raise ValueError(f"size: expected an integer >= 1, got {size!r}")
        self.plan, self.sampler, self.key, self.size = plan, sampler, key, int(size)
        self.criterion, self.model, self.task = criterion, model, task
        self.n = self.k = 0
        self.stats: list = []
        self.keep, self.blocks = keep, []

    def stored(self, b: int, m: int) -> Optional[dict]:
        """The statistics of block ``b`` (``m`` samples) if an earlier run
        finished it, else None (in memory: never)."""
        return None

    def finished(self, b: int, block: Block) -> None:
        """Block ``b`` was just evaluated (in memory: nothing to do)."""

    def stopped(self) -> bool:
        """Whether to stop growing before the next block (in memory: never)."""
        return False

    def extend(self, total: int) -> tuple[int, int]:
        """Draw blocks until ``total`` samples (the last block cut to fit) or
        :meth:`stopped`; returns ``(n, k)``."""
        import jax

        while self.n < total and not self.stopped():
            b, m = len(self.stats), min(self.size, total - self.n)
            st = self.stored(b, m)
            if st is None:
                block = sample_block(self.plan, self.sampler, m, jax.random.fold_in(self.key, b),
                                     self.criterion, self.model, first=self.n, task=self.task)
                self.finished(b, block)
                if self.keep:
                    self.blocks.append(block)
                st = block.stats
            self.stats.append(st)
            self.n += len(st["success"])
            self.k += int(np.sum(st["success"]))
        return self.n, self.k

    def samples(self):
        """The kept blocks' per-sample frames (:attr:`Evaluation.samples`) in
        one, ``sample_id`` counted over the task (needs ``keep``)."""
        import pandas as pd

        if not self.keep:
            raise ValueError("samples: this run keeps no blocks (BlockRun(..., keep=True))")
        frames = []
        for block in self.blocks:
            df = block.evaluation.samples.copy()
            df["sample_id"] += block.first
            frames.append(df)
        return pd.concat(frames, ignore_index=True)

    def summary(self, *, kind: str, model: str, dtype: str, confidence: float,
                bound: bool = True) -> dict:
        """The summary row of the blocks so far (:func:`summarise_stats`)."""
        return summarise_stats(self.stats, self.plan, self.sampler, kind=kind, model=model,
                               dtype=dtype, criterion=self.criterion, confidence=confidence,
                               task=self.task, bound=bound)


__all__ = ["Block", "BlockRun", "sample_block", "summarise_stats"]
