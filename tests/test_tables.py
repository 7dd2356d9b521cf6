"""Result tables: schemas, provenance metadata, atomic writes, reading folders."""
import json

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from robustness import tables
from robustness.tables import CERTIFICATES_SCHEMA, SUMMARY_SCHEMA, samples_schema
from sweeps import parquet
from sweeps.parquet import read_metadata, read_results, write_table

CONFIG = "part: x.yaml\nseed: 7\n"


def _samples(n, params, task="t", start=0):
    schema = samples_schema(params)
    data = {}
    for f in schema:
        if pa.types.is_string(f.type):
            data[f.name] = [task if f.name == "task" else "push" if f.name == "kind" else "none"] * n
        elif pa.types.is_boolean(f.type):
            data[f.name] = [True] * n
        elif pa.types.is_integer(f.type):
            data[f.name] = np.arange(start, start + n, dtype=np.int64)
        else:
            data[f.name] = np.linspace(0.0, 1.0, n)
    for k, v in (("model", "exact"), ("dtype", "float64")):
        data[k] = [v] * n
    return pd.DataFrame(data), schema


def test_metadata_present(tmp_path):
    df, schema = _samples(5, ["dv0_x_m", "c_m"])
    path = write_table(df, tmp_path / "samples.parquet", schema, CONFIG, 7)
    md = read_metadata(path)
    assert md["table"] == "samples"
    assert md["config"] == CONFIG and md["seed"] == "7"
    assert md["version"] == "0.1.0"
    assert len(md["git_commit"]) == 40 or md["git_commit"] == "unknown"
    for pkg in ("jax", "numpy", "pandas", "pyarrow", "scipy"):
        assert pkg in md["packages"]
    back = pq.read_table(path)
    assert back.schema.remove_metadata() == schema
    assert back.num_rows == 5


def test_column_mismatch_names_the_column(tmp_path):
    df, schema = _samples(3, ["c_m"])
    with pytest.raises(ValueError, match="c_m"):
        write_table(df.drop(columns=["c_m"]), tmp_path / "a.parquet", schema, CONFIG, 0)
    with pytest.raises(ValueError, match="bogus"):
        write_table(df.assign(bogus=1.0), tmp_path / "a.parquet", schema, CONFIG, 0)
    assert list(tmp_path.iterdir()) == []


def test_atomic_write_leaves_nothing_on_error(tmp_path, monkeypatch):
    df, schema = _samples(4, ["c_m"])
    target = tmp_path / "samples.parquet"
    write_table(df, target, schema, CONFIG, 0)
    before = target.read_bytes()

    def boom(table, where, **kw):
        with open(where, "wb") as fh:  # a partial file, then a failure
            fh.write(b"PAR1 partial")
        raise OSError("disk full")

    monkeypatch.setattr(parquet.pq, "write_table", boom)
    with pytest.raises(OSError, match="disk full"):
        write_table(df, target, schema, CONFIG, 1)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["samples.parquet"]
    assert target.read_bytes() == before  # the old file is untouched
    # a frame that cannot be converted never creates a file either
    monkeypatch.undo()
    bad = df.assign(sample_id=["x"] * 4)
    with pytest.raises(ValueError, match="sample_id"):
        write_table(bad, tmp_path / "other.parquet", schema, CONFIG, 0)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["samples.parquet"]


def test_read_results_concatenates(tmp_path):
    a, sa = _samples(3, ["dv0_x_m", "fence_angle_err_rad_p0"], task="a")
    b, sb = _samples(4, ["dv0_x_m", "fence_angle_err_rad_p0", "fence_angle_err_rad_p1"],
                     task="b", start=3)
    write_table(a, tmp_path / "run1" / "samples.parquet", sa, CONFIG, 0)
    write_table(b, tmp_path / "run2" / "samples.parquet", sb, CONFIG, 0)
    df = read_results(tmp_path)
    assert len(df) == 7 and df["task"].tolist() == ["a"] * 3 + ["b"] * 4
    assert df["sample_id"].dtype == np.int64 and df["success"].dtype == bool
    assert df["fence_angle_err_rad_p1"].isna().sum() == 3  # absent in run1
    # files of one schema: pandas reads the folder directly, with the same types
    write_table(a, tmp_path / "same" / "part-0.parquet", sa, CONFIG, 0, table="samples")
    write_table(a, tmp_path / "same" / "part-1.parquet", sa, CONFIG, 0, table="samples")
    direct = pd.read_parquet(tmp_path / "same")
    assert len(direct) == 6 and direct["sample_id"].dtype == np.int64
    # several tables in one folder: ask for one
    s = tables.frame([{"task": "a", "kind": "push", "model": "exact", "dtype": "float64", "n": 3,
                       "bound_violated": None}], SUMMARY_SCHEMA)
    write_table(s, tmp_path / "run1" / "summary.parquet", SUMMARY_SCHEMA, CONFIG, 0)
    with pytest.raises(ValueError, match="several tables"):
        read_results(tmp_path)
    summ = read_results(tmp_path, table="summary")
    assert len(summ) == 1 and summ["n"].dtype == np.int64
    assert summ["bound_violated"].isna().all()


def test_schemas_are_declared_once():
    assert "verdict" in CERTIFICATES_SCHEMA.names and "ci_low" in SUMMARY_SCHEMA.names
    assert tables.schema_for("summary") is SUMMARY_SCHEMA
    s = tables.schema_for("samples", ["c_m"])
    assert s.field("c_m").type == pa.float64() and s.field("sample_id").type == pa.int64()
    with pytest.raises(ValueError, match="clash"):
        samples_schema(["success"])
    # every column is documented in results/README.md
    import pathlib
    readme = (pathlib.Path(__file__).resolve().parents[1] / "results" / "README.md").read_text()
    for schema in (SUMMARY_SCHEMA, CERTIFICATES_SCHEMA, samples_schema([])):
        for name in schema.names:
            stem = name
            for q in ("_q50", "_q90", "_q99", "_max"):
                if name.endswith(q) and not name.startswith("n_"):
                    stem = name[: -len(q)] + "_{q50,q90,q99,max}"
            if name.startswith("n_") and name[2:] in tables.FAILURE_MODES:
                stem = "n_<mode>"
            assert f"`{stem}`" in readme, name
    json.dumps(parquet.package_versions())
