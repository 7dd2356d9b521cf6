"""Result tables: schemas, provenance metadata, atomic writes, the run-folder layout."""
import os
import pathlib

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robustness import SuccessCriterion, tables
from robustness.tables import (CERTIFICATES_SCHEMA, PLANS_SCHEMA, SAMPLES_SCHEMA, SUMMARY_SCHEMA,
                               pack_samples, with_design)
from sweeps import parquet
from sweeps.parquet import read_metadata, write_table
from sweeps.store import RunError, RunStore, check_writable

CONFIG = "part: x.yaml\nseed: 7\n"


def _samples(n, task="t", start=0, schema=SAMPLES_SCHEMA):
    data = {}
    for f in schema:
        if pa.types.is_string(f.type):
            data[f.name] = [task if f.name == "task" else "push" if f.name == "kind" else "none"] * n
        elif pa.types.is_boolean(f.type):
            data[f.name] = [True] * n
        elif pa.types.is_integer(f.type):
            data[f.name] = np.arange(start, start + n, dtype=np.int64)
        elif pa.types.is_list(f.type):
            data[f.name] = [np.arange(3.0)] * n
        else:
            data[f.name] = np.linspace(0.0, 1.0, n)
    for k, v in (("model", "exact"), ("dtype", "float64"), ("run_id", "r0")):
        data[k] = [v] * n
    return pd.DataFrame(data)


def test_metadata_present(tmp_path):
    path = write_table(_samples(5), tmp_path / "samples.parquet", SAMPLES_SCHEMA, CONFIG, 7)
    md = read_metadata(path)
    assert md["table"] == "samples"
    assert md["config"] == CONFIG and md["seed"] == "7"
    assert md["version"] == "0.1.0"
    assert len(md["git_commit"]) == 40 or md["git_commit"] == "unknown"
    for pkg in ("jax", "numpy", "pandas", "pyarrow", "scipy"):
        assert pkg in md["packages"]
    back = pq.read_table(path)
    assert back.schema.remove_metadata() == SAMPLES_SCHEMA
    assert back.num_rows == 5
    # readable by others: the umask decides, not mkstemp's 0600
    mask = os.umask(0)
    os.umask(mask)
    assert (path.stat().st_mode & 0o777) == 0o666 & ~mask


def test_text_columns_are_dictionary_encoded_numbers_plain(tmp_path):
    df = _samples(50)
    path = write_table(df, tmp_path / "samples.parquet", SAMPLES_SCHEMA, CONFIG, 7)
    rg = pq.ParquetFile(path).metadata.row_group(0)
    enc = {rg.column(i).path_in_schema: rg.column(i).encodings for i in range(rg.num_columns)}
    for f in SAMPLES_SCHEMA:
        e = next(v for k, v in enc.items() if k == f.name or k.startswith(f.name + "."))
        dictionary = any("DICTIONARY" in x for x in e)
        assert dictionary == pa.types.is_string(f.type), (f.name, e)
    back = pd.read_parquet(path)   # an encoding only: the same values come back
    pd.testing.assert_frame_equal(back[df.columns[:12]], df[df.columns[:12]], check_dtype=False)
    assert back["task"].tolist() == df["task"].tolist()


def test_column_mismatch_names_the_column(tmp_path):
    df = _samples(3)
    with pytest.raises(ValueError, match="c_m"):
        write_table(df.drop(columns=["c_m"]), tmp_path / "a.parquet", SAMPLES_SCHEMA, CONFIG, 0)
    with pytest.raises(ValueError, match="bogus"):
        write_table(df.assign(bogus=1.0), tmp_path / "a.parquet", SAMPLES_SCHEMA, CONFIG, 0)
    with pytest.raises(ValueError, match="run_id"):
        write_table(df.assign(run_id=None), tmp_path / "a.parquet", SAMPLES_SCHEMA, CONFIG, 0)
    assert list(tmp_path.iterdir()) == []


def test_atomic_write_leaves_nothing_on_error(tmp_path, monkeypatch):
    df = _samples(4)
    target = tmp_path / "samples.parquet"
    write_table(df, target, SAMPLES_SCHEMA, CONFIG, 0)
    before = target.read_bytes()

    def boom(table, where, **kw):
        where.write(b"PAR1 partial")  # a partial file, then a failure
        raise OSError("disk full")

    monkeypatch.setattr(parquet.pq, "write_table", boom)
    with pytest.raises(OSError, match="disk full"):
        write_table(df, target, SAMPLES_SCHEMA, CONFIG, 1)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["samples.parquet"]
    assert target.read_bytes() == before  # the old file is untouched
    monkeypatch.undo()
    bad = df.assign(sample_id=["x"] * 4)
    with pytest.raises(ValueError, match="sample_id"):
        write_table(bad, tmp_path / "other.parquet", SAMPLES_SCHEMA, CONFIG, 0)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["samples.parquet"]


def test_write_behind_writes_on_its_thread_and_raises_a_failed_write_when_waited_on(tmp_path,
                                                                                  monkeypatch):
    df = _samples(4)
    write_table(df, tmp_path / "direct.parquet", SAMPLES_SCHEMA, CONFIG, 0)
    real = parquet.pq.write_table
    threads = []

    def spy(table, where, **kw):
        import threading

        threads.append(threading.current_thread().name)
        if len(threads) == 2:
            where.write(b"PAR1 partial")
            raise OSError("disk full")
        return real(table, where, **kw)

    monkeypatch.setattr(parquet.pq, "write_table", spy)
    with parquet.write_behind() as w:
        with w.deferring():
            write_table(df, tmp_path / "later.parquet", SAMPLES_SCHEMA, CONFIG, 0)
        ok = w.take()
        w.wait(ok)
        with w.deferring():
            write_table(df, tmp_path / "bad.parquet", SAMPLES_SCHEMA, CONFIG, 0)
        bad = w.take()
        with pytest.raises(OSError, match="disk full"):
            w.wait(bad)
        write_table(df, tmp_path / "now.parquet", SAMPLES_SCHEMA, CONFIG, 0)   # outside: at once
    assert threads[0].startswith("nudge-writer") and threads[1].startswith("nudge-writer")
    assert not threads[2].startswith("nudge-writer")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["direct.parquet", "later.parquet",
                                                          "now.parquet"]
    a, b = (pq.read_table(tmp_path / f) for f in ("direct.parquet", "later.parquet"))
    assert a.equals(b)


def test_local_executor_yields_a_unit_only_once_its_files_are_written_and_keeps_the_one_before_a_failure(
        tmp_path):
    from sweeps.executors import LocalExecutor

    df = _samples(4)
    seen = []

    def unit(ctx, u):
        if u == 2:
            raise RuntimeError("unit 2 fails")
        path = tmp_path / f"u{u}.parquet"
        write_table(df, path, SAMPLES_SCHEMA, CONFIG, 0)
        return path

    runs = LocalExecutor().run(unit, None, [0, 1, 2, 3])
    with pytest.raises(RuntimeError, match="unit 2 fails"):
        for u, path in runs:
            assert path.is_file()          # written before the unit is handed over
            seen.append(u)
    assert seen == [0, 1]                  # unit 1, computed before the failure, still counts


def test_run_folder_layout_reads_as_one_frame_with_right_dtypes(tmp_path):
    swept = [pa.field("planner_margin_deg", pa.float64())]
    store = RunStore.open(tmp_path / "run", {"run_id": "r1", "config": CONFIG, "seed": 7})
    schema = with_design(SUMMARY_SCHEMA, swept)
    for cid in (0, 2, 10):   # folder names sort in numeric order
        ints = {f.name: 0 for f in schema if f.type == pa.int64()}
        rows = [{**ints, "run_id": "r1", "planner_margin_deg": 3.0 + cid, "task": "a",
                 "kind": "push", "model": "exact", "dtype": "float64", "n": 4, "n_success": 4,
                 "bound_violated": None if cid else True}]
        store.write("summary", cid, "t0000", tables.frame(rows, schema), schema)
    df = pd.read_parquet(tmp_path / "run" / "summary")
    assert df["config_id"].astype(int).tolist() == [0, 2, 10]
    assert df["n"].dtype == np.int64 and df["planner_margin_deg"].dtype == np.float64
    assert str(df["bound_violated"].dtype) == "boolean"   # nullable, not object
    assert df["bound_violated"].isna().tolist() == [False, True, True]
    # the run folder holds no Parquet file of its own (pd.read_parquet(run) would mix tables)
    assert not list((tmp_path / "run").glob("*.parquet"))


def test_integer_columns_never_read_back_as_float(tmp_path):
    # a task without samples (no plan) has every summary field, counts 0: its file reads
    # back with the dtypes of the schema, like any other task's
    from robustness.summary import empty_summary

    row = {"run_id": "r1", **empty_summary("a", "tumble", "exact", "float64",
                                                 SuccessCriterion(1e-3, 1e-2), 0.95)}
    assert set(row) == set(SUMMARY_SCHEMA.names)
    assert row["n_none"] == row["n_in_bound_model"] == 0 and row["worst_sample_id"] == -1
    path = write_table(tables.frame([row], SUMMARY_SCHEMA), tmp_path / "s.parquet",
                       SUMMARY_SCHEMA, CONFIG, 0)
    back = pd.read_parquet(path)
    for f in SUMMARY_SCHEMA:
        if f.type == pa.int64():
            assert back[f.name].dtype == np.int64, f.name
    assert np.isnan(back["ci_low"].iloc[0]) and back["dominant_failure_mode"].iloc[0] == "no_plan"
    # a missing integer is refused, naming the column, not stored as a float NaN
    for schema in tables.TABLES.values():
        assert not [f.name for f in schema if f.type == pa.int64() and f.nullable]
    with pytest.raises(ValueError, match="'n_none'.*not null"):
        write_table(tables.frame([{**row, "n_none": None}], SUMMARY_SCHEMA),
                    tmp_path / "t.parquet", SUMMARY_SCHEMA, CONFIG, 0)


def test_schema_drift_is_an_error(tmp_path):
    store = RunStore.open(tmp_path / "run", {"run_id": "r1", "config": CONFIG, "seed": 7})
    df = _samples(2)
    store.write("samples", 0, "a", df, SAMPLES_SCHEMA)
    with pytest.raises(ValueError, match="unexpected"):
        store.write("samples", 0, "b", df.assign(extra=1.0), SAMPLES_SCHEMA)


def test_changed_config_is_refused_and_unwritable_folder_reported(tmp_path):
    RunStore.open(tmp_path / "run", {"run_id": "r1", "config": "a: 1\n", "seed": 0})
    with pytest.raises(RunError, match="another config.*a: 1.*a: 2"):
        RunStore.open(tmp_path / "run", {"run_id": "r2", "config": "a: 2\n", "seed": 0})
    blocker = tmp_path / "file"
    blocker.write_text("")
    with pytest.raises(RunError, match="cannot write"):
        check_writable(blocker / "sub")


def test_done_needs_the_log_line_and_the_files(tmp_path):
    store = RunStore.open(tmp_path / "run", {"run_id": "r1", "config": CONFIG, "seed": 7})
    p = store.write("samples", 0, "t0000-b0000", _samples(2), SAMPLES_SCHEMA)
    assert store.done() == {}               # written but not logged: it reruns
    store.mark_done("c0-t0-b0", [p], rows=2)
    assert set(store.done()) == {"c0-t0-b0"}
    with open(tmp_path / "run" / "chunks.jsonl", "a") as fh:
        fh.write('{"key": "cut')             # a line cut by a crash is ignored
    assert set(store.done()) == {"c0-t0-b0"}
    p.unlink()                               # a logged unit whose file is gone reruns
    assert store.done() == {}


def test_the_log_is_synced_per_line_or_once(tmp_path, monkeypatch):
    """``mark_done`` fsyncs its line unless told not to (a study's run syncs the
    log once as it ends, :meth:`RunStore.sync_log`)."""
    import os

    store = RunStore.open(tmp_path / "run", {"run_id": "r1", "config": CONFIG, "seed": 7})
    store.sync_log()                                   # no log yet: nothing to do
    p = store.write("samples", 0, "t0000-b0000", _samples(2), SAMPLES_SCHEMA)
    synced, real = [], os.fsync
    monkeypatch.setattr(os, "fsync", lambda fd: synced.append(os.fstat(fd).st_ino) or real(fd))
    store.mark_done("c0-t0-b0", [p], rows=2)
    store.mark_done("c0-t0-b1", [p], rows=2, sync=False)
    log = (tmp_path / "run" / "chunks.jsonl").stat().st_ino
    assert synced == [log]
    store.sync_log()
    assert synced == [log, log]
    assert set(store.done()) == {"c0-t0-b0", "c0-t0-b1"}

    def broken(fd):
        raise OSError(5, "Input/output error")

    monkeypatch.setattr(os, "fsync", broken)
    store.sync_log()                                   # best effort: it never raises


def test_pack_samples_gathers_lists_in_order():
    flat = pd.DataFrame({"task": ["a", "a"], "dv10_x_m": [10.0, 11.0], "dv2_x_m": [2.0, 3.0],
                         "dv2_y_m": [2.5, 3.5], "dv10_y_m": [10.5, 11.5],
                         "fence_angle_err_rad_p1": [0.1, 0.2], "fence_angle_err_rad_p0": [0.0, 0.3],
                         "mu_f": [0.5, 0.6], "dcom_x_m": [0.0, 0.0], "dcom_y_m": [0.0, 0.0]})
    params = [c for c in flat.columns if c != "task"]
    out = pack_samples(flat, params)
    assert out["dv_m"].iloc[0].tolist() == [2.0, 2.5, 10.0, 10.5]
    assert out["fence_angle_err_rad"].iloc[1].tolist() == [0.3, 0.2]
    assert out["push_dist_rel_err"].iloc[0].tolist() == []
    assert np.isnan(out["dcom_z_m"]).all() and out["mu_f"].tolist() == [0.5, 0.6]


def test_schemas_are_declared_once_and_documented():
    assert "verdict" in CERTIFICATES_SCHEMA.names and "ci_low_one_sided" in SUMMARY_SCHEMA.names
    assert tables.schema_for("summary") is SUMMARY_SCHEMA
    assert tables.schema_for("plans") is PLANS_SCHEMA
    with pytest.raises(ValueError, match="clash"):
        with_design(SAMPLES_SCHEMA, [pa.field("success", pa.float64())])
    for s in tables.TABLES.values():
        assert s.names[0] == "run_id"
    readme = (pathlib.Path(__file__).resolve().parents[1] / "results" / "README.md").read_text()
    for schema in tables.TABLES.values():
        for name in schema.names:
            stem = name
            for q in ("_q50", "_q90", "_q99", "_max"):
                if name.endswith(q) and not name.startswith("n_"):
                    stem = name[: -len(q)] + "_{q50,q90,q99,max}"
            if name.startswith("n_") and name[2:] in tables.FAILURE_MODES:
                stem = "n_<mode>"
            assert f"`{stem}`" in readme, name


_SCALARS = st.one_of(st.none(), st.floats(allow_nan=True, allow_infinity=True),
                     st.floats(width=32).map(np.float32), st.floats().map(np.float64),
                     st.integers(-2**62, 2**62), st.integers(-2**62, 2**62).map(np.int64),
                     st.booleans(), st.booleans().map(np.bool_), st.text(max_size=5),
                     st.just(pd.NA))


@settings(max_examples=300, deadline=None, derandomize=True)
@given(value=_SCALARS, typ=st.sampled_from([tables.F64, tables.I64, tables.STR, tables.BOOL]),
       n=st.integers(0, 5))
def test_a_constant_column_is_the_column_of_its_repeated_value(value, typ, n):
    """arrow_table repeats a scalar without a Python list: the same column (a null
    where pa.array(from_pandas) makes one, NaN kept where it keeps it), or the
    same refusal, as the list [value] * n."""
    schema = pa.schema([pa.field("c", typ)])
    try:
        want = tables.arrow_table({"c": [value] * n}, schema, n)
    except ValueError:
        with pytest.raises(ValueError, match="column 'c'"):
            tables.arrow_table({"c": value}, schema, n)
        return
    got = tables.arrow_table({"c": value}, schema, n)
    assert got.schema.equals(want.schema, check_metadata=True)
    assert got.column("c").null_count == want.column("c").null_count
    assert repr(got.column("c").to_pylist()) == repr(want.column("c").to_pylist())
