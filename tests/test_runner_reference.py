"""The study runner against the library, bit for bit.

The runner writes its samples tables straight from arrays
(:func:`robustness.tables.arrow_table`) and merges each task's summary from the
statistics its blocks returned (:func:`sweeps.work.with_stats`); the reference
is the library path it replaced: ``evaluate`` per block with the runner's keys,
``to_arrow(pack_samples(...))`` for the samples (a pandas frame, flat parameter
columns gathered into lists by name) and ``summarise`` over the task's
concatenated samples.  Both files are read back with ``pd.read_parquet`` (as
engineers read them) and compared column for column, dtypes included; runs are
in this process and tiny (a push study with two configurations, two tasks, three
blocks each, and with its tasks' samples in one block, where a configuration is
one unit of work, its samples in one file; a tumble study with a vertex tolerance).
"""
import math

import jax
import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

from robustness import Model, evaluate, model_for, summarise, tables
from sweeps.run import execute
from sweeps.study import Executor, load_design
from sweeps.tasks import plan_task
from sweeps.work import swept_fields

PUSH = """study: ref-push
kind: push
part: nice_stable
tasks:
  - {name: a, start: [0, 0, 0], goal: [0.08, 0.03, 1.0]}
  - {name: b, start: [0, 0, 0], goal: [-0.05, 0.06, -2.0]}
tolerances: {tau_v: 2e-5, tau_com: 1e-4}
friction: {mu_f: [0.5, 0.8], support: any}
execution: {start_xy: 5e-4, start_theta: 0.01, fence_angle: 0.01}
eps: {pos_eps_m: 0.003, theta_eps_rad: 0.05}
model: quasistatic
samples: 20
chunk_samples: 8
seed: 3
report: false
params:
  planner.margin_deg: [5, 9]
"""

TUMBLE = """study: ref-tumble
kind: tumble
part: irregular_polyhedron
tasks:
  - {name: t, start: [0, 0, 0, 0], goal: [0.05, 0.02, 0.5, 3]}
planner: {tumble_eps: 4.0e-3}
tolerances: {tau_v: 1.0e-5}
execution: {tumble_slip_xy: 1.0e-4}
eps: {pos_eps_m: 0.004, theta_eps_rad: 0.05}
samples: 12
chunk_samples: 5
seed: 1
report: false
"""


def _reference_samples(design, cid, ti, lo, n, block):
    """The library's samples frame of one block (the replaced path)."""
    cfg = design.configs[cid]
    part = design.part(cid)
    name, start, goal = design.tasks(cid)[ti]
    plan, _ = plan_task(part, start, goal, cfg.planner, cfg.eps)
    key = jax.random.fold_in(jax.random.fold_in(jax.random.key(cfg.seed), ti), block)
    ev = evaluate(plan, cfg.sampler(), n, key, cfg.eps,
                  model=Model(cfg.model, dtype=cfg.dtype, physics=cfg.physics_run(part)),
                  task=name, bound=False)
    df = tables.pack_samples(ev.samples, ev.param_columns)
    df["sample_id"] = df["sample_id"] + lo
    return plan, df


def _compare(tmp_path, text):
    study = tmp_path / "study.yaml"
    study.write_text(text)
    design = load_design(str(study))
    out = tmp_path / "out"
    assert execute(design, out, Executor(), quiet=True, report=False) == 0
    swept = swept_fields(design)
    for cid, cfg in enumerate(design.configs):
        point = design.points[cid]
        cols = {f.name: point[p] for p, f in zip(design.paths, swept)}
        run_id = pq.read_table(next((out / "summary").rglob("*.parquet"))).column("run_id")[0].as_py()
        size = cfg.chunk_samples or cfg.samples
        folder = out / "samples" / f"config_id={cid:05d}"
        whole = size >= cfg.samples
        names = sorted(f.name for f in folder.iterdir())
        assert names == (["part-tasks.parquet"] if whole else [
            f"part-t{ti:04d}-b{b:04d}.parquet" for ti in range(len(design.tasks(cid)))
            for b in range(-(-cfg.samples // size))])
        every = pd.read_parquet(folder / names[0]) if whole else None   # a task after the other
        for ti, (name, _, _) in enumerate(design.tasks(cid)):
            frames = []
            for b, lo in enumerate(range(0, cfg.samples, size)):
                n = min(size, cfg.samples - lo)
                plan, ref = _reference_samples(design, cid, ti, lo, n, b)
                frames.append(ref)
                ref.insert(0, "run_id", run_id)
                for c, v in cols.items():
                    ref[c] = v
                schema = tables.with_design(tables.SAMPLES_SCHEMA, swept)
                ref_path = tmp_path / f"ref-{cid}-{ti}-{b}.parquet"
                pq.write_table(tables.to_arrow(ref[schema.names], schema), ref_path)
                at = ti * cfg.samples + lo
                got = (every.iloc[at:at + n].reset_index(drop=True) if whole else
                       pd.read_parquet(folder / f"part-t{ti:04d}-b{b:04d}.parquet"))
                want = pd.read_parquet(ref_path)
                assert list(got.dtypes.astype(str)) == list(want.dtypes.astype(str))
                pd.testing.assert_frame_equal(got, want, check_exact=True)
            s = summarise(pd.concat(frames, ignore_index=True), plan, cfg.sampler(), kind=cfg.kind,
                          model=model_for(cfg.model, cfg.kind), dtype=cfg.dtype,
                          criterion=cfg.eps, confidence=cfg.required.confidence,
                          task=name, bound=cfg.bounds)
            rows = pd.read_parquet(out / "summary" / f"config_id={cid:05d}" / "part-tasks.parquet")
            assert rows["task"].tolist() == [t[0] for t in design.tasks(cid)]   # in task order
            row = rows.iloc[ti]
            for k, v in s.items():
                w = row[k]
                if isinstance(v, float) and math.isnan(v):
                    assert isinstance(w, float) and math.isnan(w), k
                elif v is None:
                    assert pd.isna(w), k
                else:
                    assert w == v, (k, w, v)
    return design


@pytest.mark.slow
@pytest.mark.parametrize("blocks", ["blocks", "one unit"])
def test_push_study_equals_the_library(tmp_path, blocks):
    _compare(tmp_path, PUSH if blocks == "blocks" else PUSH.replace("chunk_samples: 8\n", ""))


@pytest.mark.slow
def test_tumble_study_equals_the_library(tmp_path):
    _compare(tmp_path, TUMBLE)


def test_arrow_table_refuses_what_to_arrow_refuses():
    s = tables.SUMMARY_SCHEMA
    row = {f.name: None for f in s}
    with pytest.raises(ValueError, match="holds nulls"):
        tables.rows_table([row], s)
    with pytest.raises(ValueError, match="missing"):
        tables.arrow_table({"run_id": ["r"]}, s)
    good = {f.name: [1.0] if f.type == tables.F64 else [0] if f.type == tables.I64 else ["x"]
            if f.type == tables.STR else [True] for f in s}
    good["n"] = ["not a number"]
    with pytest.raises(ValueError, match="'n'"):
        tables.arrow_table(good, s)
    # a fraction in an integer column: refused as the pandas path refuses it (pyarrow
    # alone truncates a Python float, 1.5 -> 1); a whole float is the integer
    for v in ([1.5], 1.5):
        with pytest.raises(ValueError, match="'n': cannot be stored as int64 .*truncated"):
            tables.arrow_table({**good, "n": v}, s, 1)
    with pytest.raises(ValueError, match="'n': cannot be stored as int64 .*truncated"):
        tables.to_arrow(pd.DataFrame({k: v for k, v in {**good, "n": [1.5]}.items()}), s)
    assert tables.arrow_table({**good, "n": [2.0]}, s, 1).column("n").to_pylist() == [2]
    lists = {f.name: np.zeros((2, 3)) if f.type == tables.F64_LIST else ["rigid", None]
             if f.type == tables.STR else [0.0, 0.0] for f in tables.SAMPLED_FIELDS}
    t = tables.arrow_table(lists, pa_schema := tables.pa.schema(tables.SAMPLED_FIELDS), 2)
    assert t.schema.equals(pa_schema, check_metadata=False)
    assert t.column("dv_m").to_pylist() == [[0.0] * 3] * 2
