"""Result tables: every Parquet schema of nudge, declared here and only here.

Tables (long format, snake_case, units in the column names where not radians
or metres; ``results/README.md`` documents every column):

* ``samples``: one row per (configuration, task, Monte-Carlo sample): the
  sampled parameters, the final pose, the errors, the edge or face reached,
  success and failure mode.  Scalars are columns; per-vertex and per-push
  draws are list columns (``dv_m``, ``fence_angle_err_rad``...), so the schema
  is the same for every part and plan length.
* ``summary``: one row per (configuration, task): success rate,
  Clopper-Pearson bounds, error quantiles, worst case, the analytic bound
  beside the empirical maximum.
* ``plans``: one row per (configuration, task): the plan (or why there is
  none), its length and distance, and the plan itself as JSON.
* ``certificates``: one row per task of a certification: what was shown.

Every table starts with ``run_id``; a study's swept parameters follow as
ordinary columns (:func:`with_design`); the integer ``config_id`` is the Hive
partition of the folder the file lies in.  Column types never depend on the
data (a column that is all NaN is still float64, an integer column never
becomes float: every int64 column is declared not null, so a missing count or
index is refused when the file is written; without samples a count is 0 and an
index -1), so the files of one table read back as one consistent frame.
The edge (:mod:`sweeps.store`) writes them, atomically, with provenance.
"""
from __future__ import annotations

import functools
import math
import re
from typing import Any, Iterable, Mapping, Optional, Sequence, Union

import numpy as np
import pandas as pd
import pyarrow as pa

from robustness import failure_modes

#: every failure mode's name, in table order (their home: :mod:`robustness.failure_modes`)
FAILURE_MODES = failure_modes.NAMES

#: What a certificate can say (:mod:`robustness.certificates`).
VERDICTS = ("certified", "not certified", "no plan")

# --------------------------------------------------------------------------
# Schemas
# --------------------------------------------------------------------------
F64, I64, STR, BOOL = pa.float64(), pa.int64(), pa.string(), pa.bool_()
F64_LIST = pa.list_(pa.float64())

#: The first column of every table.
RUN_FIELD = pa.field("run_id", STR, nullable=False)

#: Columns that identify a sample, after ``run_id`` and the swept parameters.
SAMPLES_KEY_FIELDS = [
    pa.field("task", STR, nullable=False),
    pa.field("kind", STR, nullable=False),          # "push" | "tumble"
    pa.field("model", STR, nullable=False),         # "quasistatic" | "exact" | "mujoco"
    pa.field("dtype", STR, nullable=False),         # "float64" | "float32"
    pa.field("sample_id", I64, nullable=False),
]

#: Sampled parameters (see :func:`robustness.samplers.parameter_columns`):
#: scalars, then per-vertex / per-push draws as lists.
SAMPLED_FIELDS = [
    pa.field("dcom_x_m", F64), pa.field("dcom_y_m", F64), pa.field("dcom_z_m", F64),
    pa.field("mu_f", F64), pa.field("mu_s", F64), pa.field("c_m", F64), pa.field("support", STR),
    pa.field("start_dx_m", F64), pa.field("start_dy_m", F64), pa.field("start_dtheta_rad", F64),
    pa.field("slip_sum_dx_m", F64), pa.field("slip_sum_dy_m", F64),
    pa.field("slip_sum_dtheta_rad", F64),
    pa.field("dv_m", F64_LIST),                     # per caller vertex: x, y (, z), flattened
    pa.field("fence_angle_err_rad", F64_LIST),      # per push
    pa.field("push_dist_rel_err", F64_LIST),        # per push
    pa.field("push_dist_abs_err_m", F64_LIST),      # per push
]

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
    pa.field("hull_changed", BOOL, nullable=False),
    pa.field("model_valid", BOOL, nullable=False),
    pa.field("in_bound_model", BOOL, nullable=False),
    pa.field("success", BOOL, nullable=False),
    pa.field("failure_mode", STR),
    pa.field("max_tilt_rad", F64),
    pa.field("c_physical_m", F64),                  # mujoco push rows: c of the settled loads
    pa.field("support_ok", BOOL),                   # mujoco push rows: com inside the loaded contacts
    pa.field("dpos_vs_quasistatic_m", F64),
    pa.field("dtheta_vs_quasistatic_rad", F64),
    pa.field("success_quasistatic", BOOL),
    pa.field("dpos_vs_exact_m", F64),
    pa.field("dtheta_vs_exact_rad", F64),
    pa.field("success_exact", BOOL),
]

SAMPLES_SCHEMA = pa.schema([RUN_FIELD] + SAMPLES_KEY_FIELDS + SAMPLED_FIELDS + SAMPLES_RESULT_FIELDS)


def _ints_not_null(schema: pa.Schema) -> pa.Schema:
    """``schema`` with every int64 field declared not null (a null would make pandas
    read the whole column back as float64: its type would depend on the data)."""
    return pa.schema([f.with_nullable(False) if f.type == I64 else f for f in schema],
                     metadata=schema.metadata)


SAMPLES_SCHEMA = _ints_not_null(SAMPLES_SCHEMA)


def _quantile_fields(stem: str) -> list:
    return [pa.field(f"{stem}_{q}", F64) for q in ("q50", "q90", "q99", "max")]


SUMMARY_SCHEMA = pa.schema(
    [
        RUN_FIELD,
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
        pa.field("ci_low_one_sided", F64),
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

PLANS_SCHEMA = pa.schema([
    RUN_FIELD,
    pa.field("task", STR, nullable=False),
    pa.field("kind", STR, nullable=False),
    pa.field("part", STR),
    pa.field("part_source", STR),                   # the geometry's file (CAD or part file)
    pa.field("part_units", STR),                    # the unit that file was read in
    pa.field("start_x_m", F64), pa.field("start_y_m", F64), pa.field("start_theta_rad", F64),
    pa.field("start_face", I64),
    pa.field("goal_x_m", F64), pa.field("goal_y_m", F64), pa.field("goal_theta_rad", F64),
    pa.field("goal_face", I64),
    pa.field("planned", BOOL, nullable=False),      # a verified plan exists
    pa.field("verdict", STR),                       # solved | not_solvable | no_plan ...
    pa.field("reason", STR),
    pa.field("plan_class", STR),                    # push plans
    pa.field("distance_rule", STR),                 # push plans: peshkin | quasi-static
    pa.field("support", STR),                       # push plans: the support the distances assume
    pa.field("n_steps", I64),                       # pushes or tumbles (0 without a plan)
    pa.field("total_distance_m", F64),              # push plans: total fence travel
    pa.field("straight_distance_m", F64),           # |goal - start| of the position
    pa.field("length_ratio", F64),                  # total_distance_m / straight_distance_m
    pa.field("n_tumbles_paper", I64),               # tumble plans: the paper's construction
    pa.field("plan_error", F64),                    # replayed error (m / rad, paper's metric)
    pa.field("plan_json", STR),                     # the plan, PushPlan/TumblePlan.to_dict()
])

CERTIFICATES_SCHEMA = pa.schema([
    RUN_FIELD,
    pa.field("task", STR, nullable=False),
    pa.field("kind", STR, nullable=False),
    pa.field("part", STR),
    pa.field("part_source", STR),
    pa.field("part_units", STR),
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
    pa.field("n_success", I64),
    pa.field("success_rate", F64),
    pa.field("ci_low_one_sided", F64),
    pa.field("samples_needed", I64),
    pa.field("procedure", STR),                     # fixed | sequential_bonferroni
    pa.field("look_confidence", F64),               # confidence of each look's bounds
    pa.field("n_looks", I64),                       # looks of the schedule
    pa.field("look", I64),                          # the look the verdict was taken at (0: none)
    pa.field("look_counts", pa.list_(I64)),         # the schedule's sample counts
    pa.field("nothing_perturbed", BOOL),
    pa.field("bound_position_m", F64),
    pa.field("bound_theta_rad", F64),
    pa.field("bound_model", STR),
    pa.field("bound_within_eps", BOOL),
    pa.field("bound_violated", BOOL),
    pa.field("verdict", STR, nullable=False),
    pa.field("reason", STR),
    pa.field("claim", STR),
    pa.field("dominant_failure_mode", STR),
    pa.field("recommended_margin_deg", F64),
    pa.field("recommended_safety_factor", F64),
    pa.field("selection", STR),                     # "default plan" or how it was synthesized
    pa.field("n_candidates", I64),                  # candidates scored (0: the default plan)
    pa.field("selection_n_samples", I64),           # selection draws (independent of n_samples)
    pa.field("selection_ci_low", F64),              # chosen plan's bound on them (optimistic)
    pa.field("default_selection_ci_low", F64),      # the default plan's on the same draws
    pa.field("physics_n_samples", I64),             # MuJoCo rollouts of the chosen plan (0: none)
    pa.field("physics_n_success", I64),
    pa.field("physics_ci_low", F64),                # their one-sided lower bound
    pa.field("physics_agrees", BOOL),               # physics and the model agree (None: not run)
    pa.field("note", STR),
])

CANDIDATES_SCHEMA = pa.schema([
    RUN_FIELD,
    pa.field("task", STR, nullable=False),
    pa.field("candidate", I64),                     # 0: the default plan
    pa.field("label", STR),                         # setting and plan, one line
    pa.field("margin_deg", F64),
    pa.field("safety_factor", F64),
    pa.field("strategy", STR),
    pa.field("distance_rule", STR),                 # peshkin | quasi-static
    pa.field("support", STR),                       # what the distances are valid for
    pa.field("min_fence_mu", F64),                  # slip-aware bound (NaN: none)
    pa.field("tumble_eps", F64),                    # tumble candidates: the planner's eps
    pa.field("alternative", I64),                   # 0: that setting's own plan
    pa.field("n_steps", I64),                       # pushes or tumbles
    pa.field("total_distance_m", F64),              # push plans (NaN for tumbles)
    pa.field("bound_position_m", F64),              # first-order bound over the tolerance box
    pa.field("bound_theta_rad", F64),
    pa.field("model", STR),                         # the model the selection draws ran
    pa.field("n_samples", I64),                     # selection draws (common to every candidate)
    pa.field("n_success", I64),
    pa.field("ci_low_one_sided", F64),              # at `confidence`, on the selection draws
    pa.field("confidence", F64),
    pa.field("objective", STR),
    pa.field("chosen", BOOL),
    pa.field("plan_json", STR),
])

DESIGN_SCHEMA = pa.schema([
    RUN_FIELD,
    pa.field("task", STR, nullable=False),
    pa.field("axis", STR, nullable=False),          # tau_v, tau_com, start, fence_angle, ...
    pa.field("fields", STR),                        # the config fields it moves
    pa.field("configured", F64_LIST),               # their configured values (SI)
    pa.field("loosest", F64_LIST),                  # the loosest that certifies, the rest as configured
    pa.field("scale", F64),                         # loosest / configured (NaN: friction, or 0 configured)
    pa.field("certified_at_configured", BOOL),
    pa.field("ci_low_at_loosest", F64),             # on the design draws
    pa.field("limit", STR),                         # "", no_limit, none_certifies
    pa.field("failure_rate", F64),                  # every axis as configured
    pa.field("failure_rate_without", F64),          # this axis perfect
    pa.field("failure_rate_alone", F64),            # only this axis perturbed
    pa.field("failures_removed", F64),              # failure_rate - failure_rate_without
    pa.field("failure_rate_all_perfect", F64),      # every axis perfect
    pa.field("rank", I64),                          # 1: removes most failures
    pa.field("joint", F64_LIST),                    # the joint design's values of this axis
    pa.field("joint_t", F64),                       # its fraction of the way to the one-axis limits
    pa.field("joint_basis", STR),                   # where the way starts: configured | perfect
    pa.field("joint_ci_low_design", F64),
    pa.field("joint_n_fresh", I64),
    pa.field("joint_k_fresh", I64),
    pa.field("joint_ci_low_fresh", F64),            # the joint design's claim
    pa.field("joint_certified", BOOL),
    pa.field("drawing", STR),                       # the joint design in words, with its claim
    pa.field("model", STR),
    pa.field("n_samples", I64),                     # design draws (common to every evaluation)
    pa.field("evaluations", I64),                   # evaluations of this axis's search
    pa.field("confidence", F64),
    pa.field("required_probability", F64),
])

SUMMARY_SCHEMA, PLANS_SCHEMA, CERTIFICATES_SCHEMA, CANDIDATES_SCHEMA, DESIGN_SCHEMA = (
    _ints_not_null(s) for s in (SUMMARY_SCHEMA, PLANS_SCHEMA, CERTIFICATES_SCHEMA,
                                CANDIDATES_SCHEMA, DESIGN_SCHEMA))

TABLES = {"samples": SAMPLES_SCHEMA, "summary": SUMMARY_SCHEMA, "plans": PLANS_SCHEMA,
          "certificates": CERTIFICATES_SCHEMA, "candidates": CANDIDATES_SCHEMA,
          "design": DESIGN_SCHEMA}


def schema_for(table: str) -> pa.Schema:
    """The schema of a named table (before the swept columns, :func:`with_design`)."""
    try:
        return TABLES[table]
    except KeyError:
        raise ValueError(f"table: expected one of {', '.join(TABLES)}; got {table!r}") from None


def with_design(schema: pa.Schema, swept: Sequence[pa.Field]) -> pa.Schema:
    """``schema`` with a study's swept-parameter columns after ``run_id``.

    Raises:
      ValueError: a swept column's name clashes with a column of the table.
    """
    clash = [f.name for f in swept if f.name in schema.names]
    if clash:
        raise ValueError(f"swept columns {clash} clash with columns of the table")
    fields = list(schema)
    return pa.schema(fields[:1] + list(swept) + fields[1:], metadata=schema.metadata)


def pack_samples(samples: pd.DataFrame, param_columns: Sequence[str]) -> pd.DataFrame:
    """An evaluation's per-sample frame (flat parameter columns ``dv{i}_{x,y,z}_m``,
    ``fence_angle_err_rad_p{k}``...) in the table layout: scalars as they are,
    per-vertex and per-push draws gathered into list columns (in vertex / push
    order), missing scalars (``dcom_z_m`` of a polygon) NaN.  For a caller that
    holds only the frame; the runner builds its tables from the evaluation's
    arrays (:func:`samples_columns`), and a test holds the two to the same
    files."""
    n = len(samples)
    out = {c: samples[c] for c in samples.columns if c not in set(param_columns)}
    for f in SAMPLED_FIELDS:
        if f.type == F64:
            out[f.name] = samples[f.name] if f.name in samples else np.full(n, np.nan)
        elif f.type == STR:
            out[f.name] = samples[f.name] if f.name in samples else np.full(n, None, object)

    def gather(cols):
        if not cols:
            return [np.zeros(0)] * n
        block = samples[cols].to_numpy(np.float64)
        return list(block)

    dv = [c for c in param_columns if re.fullmatch(r"dv\d+_[xyz]_m", c)]
    dv.sort(key=lambda c: (int(re.match(r"dv(\d+)_", c).group(1)), c[-3]))
    out["dv_m"] = gather(dv)
    for stem in ("fence_angle_err_rad", "push_dist_rel_err", "push_dist_abs_err_m"):
        cols = sorted((c for c in param_columns if re.fullmatch(rf"{stem}_p\d+", c)),
                      key=lambda c: int(c.rsplit("_p", 1)[1]))
        out[stem] = gather(cols)
    return pd.DataFrame(out)


# --------------------------------------------------------------------------
# Conforming data to a schema
# --------------------------------------------------------------------------
def _check_columns(cols: Iterable[str], schema: pa.Schema) -> None:
    """Refuse column names that are not the schema's (any order): the error
    names the missing ones (schema order) and the unexpected ones."""
    names, have = schema.names, set(cols)
    known = set(names)
    if have != known:
        missing = [c for c in names if c not in have]
        extra = [c for c in cols if c not in known]
        raise ValueError(f"columns do not match the schema: missing {missing}, unexpected {extra}")


def to_arrow(df_or_table: Union[pd.DataFrame, pa.Table], schema: pa.Schema) -> pa.Table:
    """Conform a frame or table to ``schema``: the same columns (a missing or an
    unexpected column is an error naming it), in the schema's order, cast to
    its types.  From a frame, pandas metadata is kept so that ``pd.read_parquet``
    gives back the same dtypes (a nullable boolean column reads as ``boolean``,
    not ``object``)."""
    if isinstance(df_or_table, pa.Table):
        cols = list(df_or_table.column_names)
    elif isinstance(df_or_table, pd.DataFrame):
        cols = [str(c) for c in df_or_table.columns]
    else:
        raise TypeError(f"expected a pandas DataFrame or a pyarrow Table, got "
                        f"{type(df_or_table).__name__}")
    _check_columns(cols, schema)
    if isinstance(df_or_table, pa.Table):
        t = df_or_table.select(schema.names)
        if t.schema.equals(schema, check_metadata=False):
            return t          # as built (arrow_table: with its pandas metadata)
        return t.cast(schema)
    df = df_or_table.reset_index(drop=True)[schema.names].copy()
    required = [f.name for f in schema if not f.nullable]
    nulls = df[required].isna().any().to_numpy()
    if nulls.any():
        f = schema.field(required[int(np.argmax(nulls))])
        raise ValueError(f"column {f.name!r}: holds nulls but may not (schema {f.type} not null)")
    for f in schema:
        try:
            if f.type == BOOL and f.nullable:
                df[f.name] = pd.array(df[f.name].astype(object).where(df[f.name].notna(), None),
                                      dtype="boolean")
            elif f.type == F64_LIST and not all(isinstance(v, np.ndarray) and v.dtype == np.float64
                                                and v.ndim == 1 for v in df[f.name]):
                df[f.name] = [np.asarray(v, np.float64) for v in df[f.name]]
        except (TypeError, ValueError) as exc:
            raise ValueError(f"column {f.name!r}: cannot be stored as {f.type} ({exc})") from None
    try:
        return pa.Table.from_pandas(df, schema=schema, preserve_index=False)
    except (pa.ArrowInvalid, pa.ArrowTypeError, TypeError, ValueError) as exc:
        bad = next((f.name for f in schema if not _fits(df[f.name], f)), "?")
        raise ValueError(f"column {bad!r}: cannot be stored as {schema.field(bad).type if bad != '?' else 'its type'} "
                         f"({exc})") from None


def _fits(col: pd.Series, f: pa.Field) -> bool:
    try:
        pa.array(col, type=f.type, from_pandas=True)
        return True
    except (pa.ArrowInvalid, pa.ArrowTypeError, TypeError, ValueError):
        return False


def frame(rows: Iterable[dict], schema: pa.Schema) -> pd.DataFrame:
    """A DataFrame with the schema's columns in order from a list of row dicts
    (a key missing in a row is null)."""
    rows = list(rows)
    return pd.DataFrame({f.name: [r.get(f.name) for r in rows] for f in schema})


# --------------------------------------------------------------------------
# Tables built from arrays (the runner's path: no pandas frame)
# --------------------------------------------------------------------------
def _prototype_value(f: pa.Field):
    return {F64: 0.0, I64: 0, STR: "x", BOOL: False}.get(f.type, None)


@functools.lru_cache(maxsize=64)
def _pandas_metadata(schema: pa.Schema) -> dict:
    """The pandas metadata :func:`to_arrow` writes for a frame of ``schema``
    (from a one-row prototype), so that ``pd.read_parquet`` reads a table built by
    :func:`arrow_table` back with the same dtypes (nullable booleans as
    ``boolean``)."""
    proto = pd.DataFrame({f.name: ([np.zeros(1)] if f.type == F64_LIST else [_prototype_value(f)])
                          for f in schema})
    return dict(to_arrow(proto, schema).schema.metadata or {})


def _whole_numbers(v, f: pa.Field) -> None:
    """Refuse a Python float with a fraction for an integer field, as the pandas
    path does (pyarrow truncates one from a list or a scalar, 1.5 -> 1)."""
    if pa.types.is_integer(f.type) and not isinstance(v, np.ndarray):
        for x in (v if isinstance(v, (list, tuple)) else (v,)):
            if isinstance(x, float) and math.isfinite(x) and not x.is_integer():
                raise pa.ArrowInvalid(f"Float value {x:f} was truncated converting to {f.type}")


def _column(v, f: pa.Field, n: int) -> pa.Array:
    _whole_numbers(v, f)
    if f.type == F64_LIST:
        if isinstance(v, (list, tuple)) and len({np.size(x) for x in v}) > 1:   # ragged rows
            return pa.array([None if x is None else [float(y) for y in x] for x in v], F64_LIST)
        a = np.asarray(v, np.float64)
        if a.ndim != 2 or a.shape[0] != n:
            raise ValueError(f"column {f.name!r}: expected an (n, k) float array for a list "
                             f"column, got shape {a.shape}")
        offsets = np.arange(n + 1, dtype=np.int32) * a.shape[1]
        return pa.ListArray.from_arrays(pa.array(offsets, pa.int32()), pa.array(a.reshape(-1), F64))
    if not isinstance(v, (list, tuple, np.ndarray)) and np.ndim(v) == 0:   # a constant
        if n == 0:
            return pa.array([], type=f.type)
        if v is None or v is pd.NA or (isinstance(v, float) and v != v):  # as from_pandas
            return pa.nulls(n, f.type)
        return pa.repeat(pa.scalar(v, type=f.type), n)     # no list of n values
    arr = pa.array(v, type=f.type, from_pandas=True)      # NaN / None / pd.NA are null
    if len(arr) != n:
        raise ValueError(f"column {f.name!r}: {len(arr)} values for {n} rows")
    return arr


@functools.lru_cache(maxsize=64)
def _stored_schema(schema: pa.Schema) -> pa.Schema:
    """``schema`` with the pandas metadata of :func:`_pandas_metadata` added."""
    return schema.with_metadata({**(schema.metadata or {}), **_pandas_metadata(schema)})


def arrow_table(columns: Mapping[str, Any], schema: pa.Schema, n: Optional[int] = None) -> pa.Table:
    """A table of ``schema`` built directly from arrays (no pandas frame).

    Args:
      columns: one entry per field of the schema (a missing or an unexpected
        name is an error naming it): a 1-d array or list of ``n`` values, a
        scalar (repeated), or for a list field (``dv_m``...) an ``(n, k)``
        float array (row i is sample i's list).  NaN in a non-float column is
        null.
      schema: the table's schema; n: the row count (default: from the first
        sized column).

    Returns:
      The table, with the pandas metadata :func:`to_arrow` gives the same
      data: the file reads back with ``pd.read_parquet`` to the same frame.

    Raises:
      ValueError: a column that does not fit its type, or a null in a
        not-null field.
    """
    _check_columns(columns, schema)
    if n is None:
        n = next((len(v) for v in columns.values() if np.ndim(v) >= 1 or isinstance(v, (list, tuple))), 1)
    arrays = []
    for f in schema:
        try:
            arr = _column(columns[f.name], f, n)
        except (pa.ArrowInvalid, pa.ArrowTypeError, TypeError) as exc:
            raise ValueError(f"column {f.name!r}: cannot be stored as {f.type} ({exc})") from None
        if not f.nullable and arr.null_count:
            raise ValueError(f"column {f.name!r}: holds nulls but may not (schema {f.type} not null)")
        arrays.append(arr)
    return pa.Table.from_arrays(arrays, schema=_stored_schema(schema))


def samples_columns(ev, sample_offset: int = 0) -> dict:
    """The ``samples`` table's columns of an :class:`~robustness.Evaluation`
    (every field but ``run_id`` and a study's swept columns) as arrays for
    :func:`arrow_table`: the per-sample results and scalar draws from its
    columns (no pandas frame),
    ``sample_id`` shifted by ``sample_offset`` (a block's first sample), the
    per-vertex / per-push draws from ``ev.lists``; scalars a part does not
    have (``dcom_z_m`` of a polygon) NaN.  The same table as
    ``to_arrow(pack_samples(ev.samples, ev.param_columns))``."""
    data = ev.columns
    n = ev.n
    out = {}
    for f in SAMPLES_SCHEMA:
        if f.name == "run_id":
            continue
        if f.type == F64_LIST:
            out[f.name] = ev.lists[f.name]
        elif f.name in data:
            out[f.name] = data[f.name]
        else:
            out[f.name] = np.full(n, np.nan) if f.type == F64 else [None] * n
    out["sample_id"] = out["sample_id"] + sample_offset
    return out


def rows_table(rows: Iterable[dict], schema: pa.Schema) -> pa.Table:
    """:func:`arrow_table` of a list of row dicts (a key missing in a row is null)."""
    rows = list(rows)
    return arrow_table({f.name: [r.get(f.name) for r in rows] for f in schema}, schema, len(rows))
