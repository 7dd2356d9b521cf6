"""A run folder: tables in chunks, a manifest, and resuming.

Layout (``../shared/DESIGN.md``)::

    <run>/manifest.json                      what the run is (config as run, design, tables)
    <run>/chunks.jsonl                       one line per finished unit of work
    <run>/<table>/config_id=<k>/part-<unit>.parquet

``k`` is written with five digits (``config_id=00003``): Hive partition
discovery reads it as the integer 3 (pandas shows it as a categorical column
whose categories are integers, in order), and the folders list in numeric
order.  Every file is written atomically (:func:`sweeps.parquet.atomic_write`)
under a deterministic name, so a unit that runs twice (a rerun after a crash,
a Dask worker that died) replaces its files with identical ones: no row is
lost or duplicated.  A unit counts as done when its line is in
``chunks.jsonl`` and its files exist; the line is appended only after the
files are in place (on disk: fsync'ed).  A study's run appends its lines
without syncing each and syncs the log once as it ends (:meth:`RunStore.sync_log`):
a line lost to a power cut only makes its unit run again; a line that
survives names files that were on disk before it was written.
"""
from __future__ import annotations

import hashlib
import json
import os
import pathlib
from typing import Iterable, Optional

import pandas as pd
import pyarrow as pa

from sweeps.errors import UserError
from sweeps.parquet import atomic_write, git_commit, write_table


def run_id(doc: dict, leave_out: Iterable[str] = ()) -> str:
    """A run's identity: ``r`` and 10 hex digits of the sha256 of the resolved
    config ``doc`` without its ``leave_out`` keys (where and how it runs: the same
    study resumes on another executor).  The same config gives the same run, so
    the same command resumes it; the one formula of studies and certifications."""
    ident = {k: v for k, v in doc.items() if k not in set(leave_out)}
    return "r" + hashlib.sha256(json.dumps(ident, sort_keys=True, default=str).encode()).hexdigest()[:10]

MANIFEST = "manifest.json"
LOG = "chunks.jsonl"


class RunError(UserError):
    """A run folder that cannot be used for this run (one line: what and the fix)."""


def finished_units(root: pathlib.Path) -> dict:
    """``{unit key: log record}`` of the units an earlier run into ``root``
    finished (:meth:`RunStore.done`; ``{}`` for a new folder): a resumed run's
    estimate counts only what is left."""
    root = pathlib.Path(root)
    return RunStore(root, {}).done() if (root / LOG).is_file() else {}


def check_writable(folder: pathlib.Path) -> None:
    """Create ``folder`` and check that files can be written there, before any work.

    Raises:
      RunError: naming the folder and the reason.
    """
    folder = pathlib.Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        probe = folder / f".nudge-write-test-{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        raise RunError(f"{folder}: cannot write results there ({exc.strerror or exc}); "
                       "choose another folder with --out") from None


class RunStore:
    """The files of one run (``root`` = ``results/<study>/<run-id>`` or ``--out``)."""

    def __init__(self, root: pathlib.Path, manifest: dict):
        self.root = pathlib.Path(root)
        self.manifest = manifest

    # ---------------------------------------------------------------- opening
    @classmethod
    def open(cls, root, manifest: dict) -> "RunStore":
        """Open (resume) or create the run folder for ``manifest``.

        The manifest's ``config`` (the run's identity: the resolved config text
        less where and how it runs) must equal the one already in the folder, if
        any: a changed config on an existing run is refused, since mixing rows of
        two configs would silently corrupt it.  Files written now carry this
        invocation's ``config_as_run`` in their metadata.

        Raises:
          RunError: not writable, or another config's run is there.
        """
        root = pathlib.Path(root)
        check_writable(root)
        path = root / MANIFEST
        if path.exists():
            try:
                old = json.loads(path.read_text())
            except (OSError, ValueError) as exc:
                raise RunError(f"{path}: unreadable manifest ({exc}); delete the folder or choose "
                               "another --out") from None
            if old.get("config") != manifest.get("config"):
                diff = _first_difference(old.get("config", ""), manifest.get("config", ""))
                raise RunError(f"{root}: holds run {old.get('run_id', '?')} of another config "
                               f"({diff}); choose another --out, or delete the folder to start "
                               "over")
            return cls(root, {**old, "config_as_run": manifest.get("config_as_run",
                                                                    manifest["config"])})
        body = json.dumps(manifest, indent=1, sort_keys=False) + "\n"
        atomic_write(path, lambda fh: fh.write(body), mode="w")
        return cls(root, manifest)

    @property
    def run_id(self) -> str:
        return self.manifest["run_id"]

    # ---------------------------------------------------------------- units of work
    def done(self) -> dict:
        """``{unit key: log record}`` of the finished units whose files all exist."""
        out = {}
        path = self.root / LOG
        if not path.exists():
            return out
        for line in path.read_text().splitlines():
            try:
                rec = json.loads(line)
            except ValueError:  # a line cut by a crash: that unit reruns
                continue
            if all((self.root / f).exists() for f in rec.get("files", ())):
                out[rec["key"]] = rec
        return out

    def mark_done(self, key: str, files: Iterable, *, sync: bool = True, **info) -> None:
        """Record a finished unit (after its files are on disk).  ``sync=False``:
        the line is not fsync'ed now (the caller calls :meth:`sync_log` when its
        run ends)."""
        rel = [str(pathlib.Path(f).relative_to(self.root)) for f in files]
        line = json.dumps({"key": key, "files": rel, **info}, sort_keys=True) + "\n"
        fd = os.open(self.root / LOG, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o666)
        try:
            os.write(fd, line.encode())
            if sync:
                os.fsync(fd)
        finally:
            os.close(fd)

    def sync_log(self) -> None:
        """fsync the log of finished units (if there is one).  Best effort: it
        runs as a run ends, also on Ctrl-C or an error, which it must not hide;
        a log that did not reach the disk only makes its units run again."""
        try:
            fd = os.open(self.root / LOG, os.O_RDONLY)
        except OSError:
            return
        try:
            os.fsync(fd)
        except OSError:
            pass
        finally:
            os.close(fd)

    # ---------------------------------------------------------------- tables
    def table_path(self, table: str, config_id: int, unit: str) -> pathlib.Path:
        """Where a unit's file of ``table`` for configuration ``config_id`` goes."""
        return self.root / table / f"config_id={int(config_id):05d}" / f"part-{unit}.parquet"

    def write(self, table: str, config_id: int, unit: str, df: pd.DataFrame,
              schema: pa.Schema) -> pathlib.Path:
        """Write one unit's rows of ``table`` (schema-checked: a column missing or
        extra is an error, never a silently dropped column)."""
        path = self.table_path(table, config_id, unit)
        text = self.manifest.get("config_as_run", self.manifest["config"])
        write_table(df, path, schema, text, self.manifest["seed"], table)
        return path

    def read(self, table: str, config_id: Optional[int] = None,
             columns: Optional[list] = None) -> pd.DataFrame:
        """A table (or one configuration's part of it) as one frame (only
        ``columns``, the partition's ``config_id`` among them, if given)."""
        folder = self.root / table
        if config_id is not None:
            folder = folder / f"config_id={int(config_id):05d}"
        if not folder.exists():
            return pd.DataFrame()
        return pd.read_parquet(folder, columns=columns)


def manifest_for(run_id: str, study: str, config_text: str, seed: int, design: dict,
                 config_as_run: Optional[str] = None) -> dict:
    """The manifest of a new run (no wall times: a rerun compares equal).
    ``config_text`` is the run's identity; ``config_as_run`` the full text of
    this invocation (default the same)."""
    return {"run_id": run_id, "study": study, "config": config_text,
            "config_as_run": config_as_run or config_text, "seed": int(seed),
            "git_commit": git_commit(), "design": design}


def _first_difference(a: str, b: str) -> str:
    for la, lb in zip(a.splitlines(), b.splitlines()):
        if la != lb:
            return f"it has '{la.strip()}' where this run has '{lb.strip()}'"
    return "the configs differ in length"
