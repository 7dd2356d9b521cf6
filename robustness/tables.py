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

Column types never depend on the data (a column that is all NaN is still
float64, an integer column never becomes float), so files of one table read
back as one consistent frame.  The edge (:mod:`sweeps.parquet`) writes them,
with provenance metadata, atomically.
"""
from __future__ import annotations

from typing import Iterable, Sequence, Union

import pandas as pd
import pyarrow as pa

FAILURE_MODES = ("none", "incomplete_reorientation", "wrong_edge", "slip", "hull_changed",
                 "wrong_face", "combinatorics_changed", "position", "orientation")

VERDICTS = ("certified (analytic bound)", "certified (empirical)", "not certified")



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
# Conforming data to a schema
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


def frame(rows: Iterable[dict], schema: pa.Schema) -> pd.DataFrame:
    """A DataFrame with the schema's columns in order from a list of row dicts
    (a key missing in a row is null)."""
    rows = list(rows)
    return pd.DataFrame({f.name: [r.get(f.name) for r in rows] for f in schema})
