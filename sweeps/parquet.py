"""Parquet files of nudge: provenance metadata, atomic writes, reading back.

The schemas live in :mod:`robustness.tables`; this module (the edge) writes
them.  Every file carries in its Parquet key-value metadata ``nudge.table``,
``nudge.config`` (the YAML text of the config as run), ``nudge.seed``,
``nudge.version``, ``nudge.git_commit`` and ``nudge.packages`` (JSON).
Writes are atomic (a hidden temporary file in the same folder, then
``os.replace``): a failed write leaves no partial file, and readers ignore the
hidden temporary name.
"""
from __future__ import annotations

import functools
import importlib.metadata
import json
import os
import pathlib
import subprocess
import tempfile
from typing import Optional

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from robustness.tables import to_arrow

PACKAGES = ("jax", "jaxlib", "numpy", "pandas", "pyarrow", "scipy", "cvxpy", "sympy", "pydantic",
            "mujoco", "mujoco-mjx")

META_PREFIX = "nudge."


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
