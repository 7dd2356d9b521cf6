"""Parquet files of nudge: provenance metadata, atomic writes, reading back.

The schemas live in :mod:`robustness.tables`; this module (the edge) writes
them.  Every file carries in its Parquet key-value metadata ``nudge.table``,
``nudge.config`` (the YAML text of the config as run), ``nudge.seed``,
``nudge.version``, ``nudge.git_commit`` and ``nudge.packages`` (JSON).
Writes are atomic (a hidden temporary file in the same folder, then
``os.replace``): a failed write leaves no partial file, and readers ignore the
hidden temporary name.

Inside :func:`write_behind` (the local executor runs each unit in one) the
writes go to one background thread instead, so a sweep encodes and syncs a
unit's files while it computes the next one; the caller waits for a unit's
writes (:meth:`WriteBehind.wait`) before it records the unit as done.
"""
from __future__ import annotations

import concurrent.futures
import contextlib
import contextvars
import functools
import importlib.metadata
import json
import os
import pathlib
import subprocess
import tempfile
from typing import Optional

import pyarrow as pa
import pyarrow.parquet as pq

from robustness import to_arrow

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


@functools.lru_cache(maxsize=None)
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


@functools.lru_cache(maxsize=1)
def _umask() -> int:
    """The process's umask, read once: reading it means setting it (to 0, then
    back), which must not happen while the writer thread creates files or
    folders (they would get mode 0666 / 0777).  The first write of a run (its
    manifest) reads it on the main thread, before any writer exists."""
    mask = os.umask(0)
    os.umask(mask)
    return mask


class WriteBehind:
    """One background thread that performs :func:`atomic_write` calls made
    inside :meth:`deferring`; :meth:`take` hands over the futures of the writes
    submitted so far, :meth:`wait` blocks on them and raises a failed write's
    error.  Closing waits for every write still running (no temporary file is
    left behind by an interrupted run)."""

    def __init__(self):
        self._pool = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="nudge-writer")
        self._pending: list = []

    def submit(self, fn) -> None:
        self._pending.append(self._pool.submit(fn))

    def take(self) -> list:
        """The futures of the writes submitted since the last call."""
        out, self._pending = self._pending, []
        return out

    @staticmethod
    def wait(futures) -> None:
        """Block until ``futures`` are done; a failed write raises its error here."""
        for f in futures:
            f.result()

    @contextlib.contextmanager
    def deferring(self):
        """:func:`atomic_write` calls in this block (this thread only) go to the writer."""
        token = _WRITER.set(self)
        try:
            yield self
        finally:
            _WRITER.reset(token)

    def close(self) -> None:
        concurrent.futures.wait(self._pending)
        self._pool.shutdown(wait=True)


_WRITER: contextvars.ContextVar = contextvars.ContextVar("nudge_write_behind", default=None)


@contextlib.contextmanager
def write_behind():
    """A :class:`WriteBehind`, closed (its writes finished) on exit."""
    w = WriteBehind()
    try:
        yield w
    finally:
        w.close()


def atomic_write(path, write, mode: str = "wb") -> pathlib.Path:
    """Write ``path`` atomically: ``write(file)`` fills a hidden temporary file
    in the same folder, which is then renamed over ``path`` (readers never see a
    partial file, a failed write leaves the previous one).  The file gets the
    permissions of an ordinary new file (0666 less the umask, so other users can
    read results), not ``mkstemp``'s 0600.  Inside :meth:`WriteBehind.deferring`
    the write runs on the writer's thread and this returns at once."""
    _umask()      # read on the caller's thread (see there)
    w = _WRITER.get()
    if w is not None:
        w.submit(lambda: _atomic_write(path, write, mode))
        return pathlib.Path(path)
    return _atomic_write(path, write, mode)


def _atomic_write(path, write, mode: str) -> pathlib.Path:
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, mode) as fh:
            write(fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    return path


def write_table(df_or_table, path, schema: pa.Schema, config_text: str, seed,
                table: Optional[str] = None) -> pathlib.Path:
    """Write one table to Parquet, atomically (:func:`atomic_write`), with
    provenance metadata.

    Args:
      df_or_table: a pandas DataFrame or pyarrow Table with exactly the
        schema's columns (any order).
      path: the ``.parquet`` file to write (its folder is created).
      schema: the table's schema (:mod:`robustness.tables`).
      config_text: the YAML text of the run's config, as run.
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

    def write(fh):
        # encoded into memory by Arrow (without the GIL), then one write: a Python
        # file object given to Parquet would take the GIL for every page it writes
        sink = pa.BufferOutputStream()
        pq.write_table(t, sink, use_dictionary=dictionary_columns(t.schema))
        fh.write(sink.getvalue())

    return atomic_write(path, write)


def dictionary_columns(schema: pa.Schema) -> list:
    """The columns Parquet stores dictionary-encoded: the text ones (a run id, a
    task, a failure mode: few distinct values).  Numbers are stored plain: trying
    a dictionary on them (pyarrow's default for every column) is most of the
    time of writing a samples file and makes it larger (4,000 samples: 7.7 ms and
    1.73 MB against 20.7 ms and 2.10 MB).  An encoding only: the values read
    back are the same."""
    return [f.name for f in schema
            if pa.types.is_string(f.type) or pa.types.is_large_string(f.type)
            or pa.types.is_dictionary(f.type)]
