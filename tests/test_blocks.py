"""The block runner's pure half (:mod:`robustness.blocks`): a task's blocks
grown look by look are the blocks drawn at once, the summary merged from the
blocks' statistics (any order) is ``summarise`` of the concatenated samples,
and a runner that keeps blocks elsewhere (the hooks: ``stored``, ``finished``,
``stopped``) resumes to the same samples and summary."""
import jax
import numpy as np
import pandas as pd
import pytest

from planning import plan_pose
from robustness import (BlockRun, ExecutionTolerance, GeometryTolerance, Sampler,
                        SuccessCriterion, evaluate, sample_block, summarise, summarise_stats)

TRIANGLE = np.array([[0.0, 0.0], [0.1, 0.0], [0.03, 0.06]])
SAMPLER = Sampler(GeometryTolerance(tau_v=2e-4), execution=ExecutionTolerance(start_xy=2e-4))
CRIT = SuccessCriterion(pos_eps_m=1e-3, theta_eps_rad=0.02)
SUMMARY = dict(kind="push", model="exact", dtype="float64", confidence=0.95)


@pytest.fixture(scope="module")
def plan():
    return plan_pose(TRIANGLE, (0.0, 0.0, 0.0), (0.08, 0.03, 0.0))


def _same(a: dict, b: dict):
    assert a.keys() == b.keys()
    for k in a:
        if isinstance(a[k], float) and np.isnan(a[k]):
            assert isinstance(b[k], float) and np.isnan(b[k]), k
        else:
            assert a[k] == b[k], k


def test_a_block_is_evaluate_on_its_key_with_ids_from_its_first(plan):
    key = jax.random.key(1)
    block = sample_block(plan, SAMPLER, 12, key, CRIT, "exact", first=30, task="t")
    ev = evaluate(plan, SAMPLER, 12, key, CRIT, "exact", task="t")
    assert block.n == 12 and block.first == 30
    np.testing.assert_array_equal(block.stats["sample_id"], np.arange(30, 42))
    np.testing.assert_array_equal(block.stats["final_x_m"], ev.samples["final_x_m"])
    assert block.n_success == int(ev.samples["success"].sum())


def test_grown_look_by_look_equals_drawn_at_once_and_the_merge_equals_summarise(plan):
    key = jax.random.key(2)
    grown = BlockRun(plan, SAMPLER, key, 8, CRIT, "exact", "t", keep=True)
    assert grown.extend(5) == (5, grown.k) and grown.extend(20)[0] == 20
    once = BlockRun(plan, SAMPLER, key, 8, CRIT, "exact", "t", keep=True)
    once.extend(20)
    # blocks 5 + 8 + 7 against 8 + 8 + 4: the same keys draw other samples, so
    # only the block layout decides; what is compared is each run to itself
    assert [len(s["success"]) for s in grown.stats] == [5, 8, 7]
    assert [len(s["success"]) for s in once.stats] == [8, 8, 4]
    for run in (grown, once):
        frame = run.samples()
        np.testing.assert_array_equal(frame["sample_id"], np.arange(20))
        assert run.k == int(frame["success"].sum())
        whole = summarise(frame, plan, SAMPLER, criterion=CRIT, task="t", **SUMMARY)
        _same(run.summary(**SUMMARY), whole)
        shuffled = summarise_stats(run.stats[::-1], plan, SAMPLER, criterion=CRIT, task="t",
                                   **SUMMARY)
        _same(shuffled, whole)
    # block b is drawn with fold_in(key, b) whatever came before it
    again = sample_block(plan, SAMPLER, 8, jax.random.fold_in(key, 1), CRIT, "exact", first=8)
    np.testing.assert_array_equal(once.stats[1]["final_x_m"], again.stats["final_x_m"])


def test_a_runner_that_stores_blocks_resumes_to_the_same_samples(plan):
    """The hooks a caller with files overrides: a run stopped after two blocks,
    then resumed from what it stored, ends with the uninterrupted run's
    statistics, evaluating only the blocks it had not stored."""
    key = jax.random.key(5)
    store: dict = {}

    class Stored(BlockRun):
        def __init__(self, stop_after=None):
            super().__init__(plan, SAMPLER, key, 6, CRIT, "exact", "t")
            self.stop_after, self.evaluated = stop_after, []

        def stored(self, b, m):
            return store.get(b)

        def finished(self, b, block):
            store[b] = block.stats
            self.evaluated.append(b)

        def stopped(self):
            return self.stop_after is not None and len(self.stats) >= self.stop_after

    first = Stored(stop_after=2)
    assert first.extend(16)[0] == 12 and first.evaluated == [0, 1]
    resumed = Stored()
    resumed.extend(16)
    assert resumed.evaluated == [2]
    plain = BlockRun(plan, SAMPLER, key, 6, CRIT, "exact", "t")
    plain.extend(16)
    for a, b in zip(resumed.stats, plain.stats, strict=True):
        for c in a:
            np.testing.assert_array_equal(a[c], b[c])
    with pytest.raises(ValueError, match="^samples: this run keeps no blocks"):
        plain.samples()
    with pytest.raises(ValueError, match="^size: expected an integer >= 1"):
        BlockRun(plan, SAMPLER, key, 0, CRIT, "exact")


def test_certify_is_a_block_run(plan):
    """robustness.certify's samples and summary are a BlockRun's of its
    schedule's first look as block size."""
    from robustness import Requirement, certify

    key = jax.random.key(7)
    cert, frame, summary = certify(plan, SAMPLER, key, Requirement(0.5, 0.95, CRIT), samples=24,
                                   model="exact", task="t")
    run = BlockRun(plan, SAMPLER, key, 24, CRIT, "exact", "t", keep=True)
    run.extend(24)
    pd.testing.assert_frame_equal(frame, run.samples())
    _same(summary, run.summary(kind="push", model="exact", dtype="float64", confidence=0.95))
