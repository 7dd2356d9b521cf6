"""Result tables: every Parquet schema of nudge, declared here and only here.

Tables (long format, snake_case, units in the column names where not
radians or metres; see ``results/README.md`` for every column):

* ``samples``: one row per (task, Monte-Carlo sample): the sampled parameters
  (flattened; their columns depend on the part's vertex count and the plan's
  length, so the schema is built by :func:`samples_schema` from the list of
  parameter columns, always float64), the final pose, the errors, the edge or
  face reached, success and failure mode.
* ``summary``: one row per task: success rate, Clopper-Pearson interval, error
  quantiles, worst case, the analytic bound beside the empirical maximum.
* ``certificates``: one row per task: the verdict and why.

Every file carries in its Parquet key-value metadata: ``nudge.table`` (the
table's name), ``nudge.config`` (the YAML text of the config), ``nudge.seed``,
``nudge.version``, ``nudge.git_commit`` and ``nudge.packages`` (JSON: versions
of jax, numpy, pandas, pyarrow, scipy, cvxpy, sympy, mujoco when installed).
:func:`write_table` writes atomically (a hidden temporary file in the same
folder, then ``os.replace``): a failed write leaves no partial file, and
``pd.read_parquet`` / pyarrow datasets ignore the hidden temporary name
anyway.  Column types never depend on the data (a column that is all NaN is
still float64, an integer column never becomes float), so
``pd.read_parquet(folder)`` over files of one table gives a consistent frame;
:func:`read_results` does that and also unifies files whose parameter columns
differ.
"""
from __future__ import annotations

import functools
import importlib.metadata
import json
import os
import pathlib
import subprocess
import tempfile
from typing import Iterable, Optional, Sequence, Union

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

FAILURE_MODES = ("none", "incomplete_reorientation", "wrong_edge", "slip", "hull_changed",
                 "wrong_face", "combinatorics_changed", "position", "orientation")

VERDICTS = ("certified (analytic bound)", "certified (empirical)", "not certified")

PACKAGES = ("jax", "jaxlib", "numpy", "pandas", "pyarrow", "scipy", "cvxpy", "sympy", "pydantic",
            "mujoco")

META_PREFIX = "nudge."

# --------------------------------------------------------------------------
# Schemas
# --------------------------------------------------------------------------
F64, I64, STR, BOOL = pa.float64(), pa.int64(), pa.string(), pa.bool_()

#: Columns before the sampled parameters in ``samples``.
SAMPLES_KEY_FIELDS = [
    pa.field("task", STR, nullable=False),
    pa.field("kind", STR, nullable=False),          # "push" | "tumble"
    pa.field("model", STR, nullable=False),         # "quasistatic" | "exact"
    pa.field("dtype", STR, nullable=False),         # "float64" | "float32"
    pa.field("sample_id", I64, nullable=False),
]

#: Columns after the sampled parameters in ``samples``.
SAMPLES_RESULT_FIELDS = [
    pa.field("final_x_m", F64),
    pa.field("final_y_m", F64),
    pa.field("final_theta_rad", F64),
    pa.field("final_edge_a", I64),
    pa.field("final_edge_b", I64),
    pa.field("planned_edge_a", I64),
    pa.field("planned_edge_b", I64),
    pa.field("final_face", I64),
    pa.field("planned_face", I64),
    pa.field("err_x_m", F64),
    pa.field("err_y_m", F64),
    pa.field("err_pos_m", F64),
    pa.field("err_theta_rad", F64),
    pa.field("slip_m", F64),
    pa.field("n_incomplete", I64),
    pa.field("first_wrong_step", I64),
    pa.field("hull_changed", BOOL),
    pa.field("model_valid", BOOL),
    pa.field("in_bound_model", BOOL),
    pa.field("success", BOOL),
    pa.field("failure_mode", STR),
]

SAMPLES_FIXED = {f.name for f in SAMPLES_KEY_FIELDS + SAMPLES_RESULT_FIELDS}


def samples_schema(param_columns: Sequence[str]) -> pa.Schema:
    """Schema of ``samples`` with the given sampled-parameter columns (float64,
    in the given order) between the key and the result columns."""
    clash = [c for c in param_columns if c in SAMPLES_FIXED]
    if clash:
        raise ValueError(f"parameter columns {clash} clash with fixed sample columns")
    return pa.schema(SAMPLES_KEY_FIELDS + [pa.field(c, F64) for c in param_columns]
                     + SAMPLES_RESULT_FIELDS)


def _quantile_fields(stem: str) -> list:
    return [pa.field(f"{stem}_{q}", F64) for q in ("q50", "q90", "q99", "max")]


SUMMARY_SCHEMA = pa.schema(
    [
        pa.field("task", STR, nullable=False),
        pa.field("kind", STR, nullable=False),
        pa.field("model", STR, nullable=False),
        pa.field("dtype", STR, nullable=False),
        pa.field("n", I64, nullable=False),
        pa.field("n_success", I64),
        pa.field("success_rate", F64),
        pa.field("confidence", F64),
        pa.field("ci_low", F64),
        pa.field("ci_high", F64),
        pa.field("pos_eps_m", F64),
        pa.field("theta_eps_rad", F64),
    ]
    + _quantile_fields("err_pos_m")
    + _quantile_fields("err_x_abs_m")
    + _quantile_fields("err_y_abs_m")
    + _quantile_fields("err_theta_abs_rad")
    + _quantile_fields("slip_m")
    + [
        pa.field("worst_sample_id", I64),
        pa.field("worst_err_pos_m", F64),
        pa.field("worst_err_theta_abs_rad", F64),
        pa.field("bound_position_m", F64),
        pa.field("bound_theta_rad", F64),
        pa.field("n_in_bound_model", I64),
        pa.field("emp_max_pos_in_model_m", F64),
        pa.field("emp_max_theta_in_model_rad", F64),
        pa.field("bound_violated", BOOL),
        pa.field("paper_bound_position_m", F64),
        pa.field("paper_bound_theta_rad", F64),
        pa.field("paper_bound_violated", BOOL),
    ]
    + [pa.field(f"n_{m}", I64) for m in FAILURE_MODES]
    + [
        pa.field("dominant_failure_mode", STR),
    ]
)

CERTIFICATES_SCHEMA = pa.schema([
    pa.field("task", STR, nullable=False),
    pa.field("kind", STR, nullable=False),
    pa.field("part", STR),
    pa.field("model", STR),
    pa.field("start_x_m", F64),
    pa.field("start_y_m", F64),
    pa.field("start_theta_rad", F64),
    pa.field("start_face", I64),
    pa.field("goal_x_m", F64),
    pa.field("goal_y_m", F64),
    pa.field("goal_theta_rad", F64),
    pa.field("goal_face", I64),
    pa.field("plan_steps", I64),
    pa.field("plan_distance_m", F64),
    pa.field("plan_verdict", STR),
    pa.field("margin_deg", F64),
    pa.field("safety_factor", F64),
    pa.field("pos_eps_m", F64),
    pa.field("theta_eps_rad", F64),
    pa.field("required_probability", F64),
    pa.field("confidence", F64),
    pa.field("n_samples", I64),
    pa.field("success_rate", F64),
    pa.field("ci_low", F64),
    pa.field("ci_high", F64),
    pa.field("bound_position_m", F64),
    pa.field("bound_theta_rad", F64),
    pa.field("bound_within_eps", BOOL),
    pa.field("bound_violated", BOOL),
    pa.field("verdict", STR, nullable=False),
    pa.field("dominant_failure_mode", STR),
    pa.field("recommended_margin_deg", F64),
    pa.field("recommended_safety_factor", F64),
    pa.field("note", STR),
])

TABLES = {"summary": SUMMARY_SCHEMA, "certificates": CERTIFICATES_SCHEMA}


def schema_for(table: str, param_columns: Sequence[str] = ()) -> pa.Schema:
    """The schema of a named table (``samples`` needs its parameter columns)."""
    if table == "samples":
        return samples_schema(param_columns)
    try:
        return TABLES[table]
    except KeyError:
        raise ValueError(f"table: expected one of samples, {', '.join(TABLES)}; got {table!r}") from None


# --------------------------------------------------------------------------
# Provenance
# --------------------------------------------------------------------------
@functools.lru_cache(maxsize=1)
def git_commit() -> str:
    """``git rev-parse HEAD`` of the repository holding this package, or ``"unknown"``."""
    root = pathlib.Path(__file__).resolve().parents[1]
    try:
        r = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True,
                           timeout=10)
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    out = r.stdout.strip()
    return out if r.returncode == 0 and out else "unknown"


def _version(name: str) -> Optional[str]:
    try:
        return importlib.metadata.version(name)
    except importlib.metadata.PackageNotFoundError:
        return None


@functools.lru_cache(maxsize=1)
def package_versions() -> dict:
    """Versions of the packages results depend on (installed ones only)."""
    out = {}
    for p in PACKAGES:
        v = _version(p)
        if v is not None:
            out[p] = v
    return out


def provenance(config_text: str, seed, table: str) -> dict:
    """The key-value metadata written into every file (str -> str)."""
    return {
        META_PREFIX + "table": str(table),
        META_PREFIX + "config": "" if config_text is None else str(config_text),
        META_PREFIX + "seed": "" if seed is None else str(seed),
        META_PREFIX + "version": _version("nudge") or "unknown",
        META_PREFIX + "git_commit": git_commit(),
        META_PREFIX + "packages": json.dumps(package_versions(), sort_keys=True),
    }


def read_metadata(path) -> dict:
    """The ``nudge.*`` metadata of a Parquet file (keys without the prefix;
    ``packages`` decoded from JSON)."""
    md = pq.read_schema(path).metadata or {}
    out = {}
    for k, v in md.items():
        k = k.decode()
        if k.startswith(META_PREFIX):
            out[k[len(META_PREFIX):]] = v.decode()
    if "packages" in out:
        out["packages"] = json.loads(out["packages"])
    return out


# --------------------------------------------------------------------------
# Writing and reading
# --------------------------------------------------------------------------
def to_arrow(df_or_table: Union[pd.DataFrame, pa.Table], schema: pa.Schema) -> pa.Table:
    """Conform a frame or table to ``schema``: same columns (a missing or an
    unexpected column is an error naming it), in the schema's order, cast to
    its types."""
    if isinstance(df_or_table, pa.Table):
        cols = list(df_or_table.column_names)
    elif isinstance(df_or_table, pd.DataFrame):
        cols = [str(c) for c in df_or_table.columns]
    else:
        raise TypeError(f"expected a pandas DataFrame or a pyarrow Table, got "
                        f"{type(df_or_table).__name__}")
    missing = [f.name for f in schema if f.name not in cols]
    extra = [c for c in cols if c not in schema.names]
    if missing or extra:
        raise ValueError(f"columns do not match the schema: missing {missing}, unexpected {extra}")
    if isinstance(df_or_table, pd.DataFrame):
        df = df_or_table.reset_index(drop=True)
        arrays = []
        for f in schema:
            try:
                arrays.append(pa.array(df[f.name], type=f.type, from_pandas=True))
            except (pa.ArrowInvalid, pa.ArrowTypeError, TypeError, ValueError) as exc:
                raise ValueError(f"column {f.name!r}: cannot be stored as {f.type} ({exc})") from None
        return pa.Table.from_arrays(arrays, schema=schema)
    t = df_or_table.select(schema.names)
    return t.cast(schema)


def write_table(df_or_table, path, schema: pa.Schema, config_text: str, seed,
                table: Optional[str] = None) -> pathlib.Path:
    """Write one table to Parquet, atomically, with provenance metadata.

    Args:
      df_or_table: a pandas DataFrame or pyarrow Table with exactly the
        schema's columns (any order).
      path: the ``.parquet`` file to write (its folder is created).
      schema: the table's schema (from this module).
      config_text: the YAML text of the run's config.
      seed: the run's seed.
      table: the table's name for the metadata (default: the file's stem).

    Returns:
      The path written.  On any error no file (partial or temporary) is left.
    """
    path = pathlib.Path(path)
    name = table or path.stem
    t = to_arrow(df_or_table, schema)
    meta = {k.encode(): v.encode() for k, v in provenance(config_text, seed, name).items()}
    t = t.replace_schema_metadata({**(t.schema.metadata or {}), **meta})
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        pq.write_table(t, tmp)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    return path


def _parquet_files(folder: pathlib.Path) -> list[pathlib.Path]:
    return sorted(p for p in folder.rglob("*.parquet")
                  if not any(part.startswith((".", "_")) for part in p.relative_to(folder).parts))


def read_results(folder, table: Optional[str] = None) -> pd.DataFrame:
    """Read every Parquet file of one table under ``folder`` into one frame.

    Args:
      folder: a results folder (searched recursively; hidden and ``_`` files
        skipped), or a single ``.parquet`` file.
      table: which table (``samples``, ``summary``, ``certificates``, ...),
        by the files' ``nudge.table`` metadata; may be omitted when the folder
        holds one table only.

    Returns:
      A DataFrame: the files concatenated in path order, with columns unified
      (a parameter column absent from a file is NaN / null there); types come
      from the schemas, so they agree across files.

    Raises:
      FileNotFoundError: no Parquet file; ValueError: several tables and no
      ``table`` given (the message lists them), or the named one is absent.
    """
    folder = pathlib.Path(folder)
    if folder.is_file():
        files = [folder]
    elif folder.is_dir():
        files = _parquet_files(folder)
    else:
        raise FileNotFoundError(f"{folder}: no such results folder")
    if not files:
        raise FileNotFoundError(f"{folder}: holds no Parquet file")
    kinds: dict = {}
    for f in files:
        md = pq.read_schema(f).metadata or {}
        kinds.setdefault(md.get(b"nudge.table", f.stem.encode()).decode(), []).append(f)
    if table is None:
        if len(kinds) > 1:
            raise ValueError(f"{folder}: holds several tables ({', '.join(sorted(kinds))}); "
                             "pass table=... to choose one")
        table = next(iter(kinds))
    if table not in kinds:
        raise ValueError(f"{folder}: no file of table {table!r}; found {', '.join(sorted(kinds))}")
    tables = [pq.read_table(f) for f in kinds[table]]
    if len(tables) == 1:
        return tables[0].to_pandas()
    schema = pa.unify_schemas([t.schema.remove_metadata() for t in tables],
                              promote_options="permissive")
    aligned = []
    for t in tables:
        t = t.replace_schema_metadata(None)
        for f in schema:
            if f.name not in t.column_names:
                t = t.append_column(f, pa.nulls(len(t), type=f.type))
        aligned.append(t.select(schema.names).cast(schema))
    return pa.concat_tables(aligned).to_pandas()


def frame(rows: Iterable[dict], schema: pa.Schema) -> pd.DataFrame:
    """A DataFrame with the schema's columns in order from a list of row dicts
    (a key missing in a row is null)."""
    rows = list(rows)
    return pd.DataFrame({f.name: [r.get(f.name) for r in rows] for f in schema})
