"""Pieces shared by nudge's command lines (``sweeps.plan_push``,
``sweeps.plan_tumble``, ``sweeps.certify``): one-line errors with exit
status 2, pose parsing with ``deg`` suffixes, negative values after flags,
warnings on stderr, and a ``__main__`` guard that reports instead of dumping
a traceback.

Units on the command line: metres and radians; an angle may end in ``deg``
(or ``rad``).
"""
from __future__ import annotations

import argparse
import math
import os
import re
import sys
from typing import Callable, Iterable, Sequence

from sweeps.errors import Exit, UserError

#: The push search's effort settings (``planning.plan_pose``'s ``max_reorients`` and
#: ``extra_steps``) that the command line and configs accept: ``(low, high)``.  The
#: planner has no upper bound; these keep its candidate table finite (a plan has at most
#: ``max_reorients`` reorient pushes, so more extra steps change nothing).
EFFORT_BOUNDS = {"max_reorients": (1, 10_000), "extra_steps": (0, 100)}

NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
ANGLE = re.compile(rf"^\s*({NUMBER})\s*(deg|rad)?\s*$")
FACE = re.compile(r"^[Ff]?(\d+)$")


class InputError(UserError):
    """Bad command-line input (exit status 2)."""


class Parser(argparse.ArgumentParser):
    """argparse with a one-line ``error: ...`` and exit status 2 (no usage dump)."""

    def error(self, message):
        sys.stderr.write(f"error: {message} (see --help)\n")
        sys.exit(Exit.INPUT)


def angle_value(text: str) -> float | None:
    """``'1.57'``, ``'90deg'`` or ``'1.57rad'`` -> radians; None if not an angle."""
    m = ANGLE.match(str(text))
    if not m:
        return None
    x = float(m.group(1))
    return math.radians(x) if m.group(2) == "deg" else x


def parse_pose(text: str, field: str, with_face: bool = False) -> tuple:
    """Parse ``x,y,theta`` (or ``x,y,theta,face`` with ``with_face``): metres,
    radians (``theta`` may end in ``deg``), a face number (``3`` or ``F3``).

    Raises:
      InputError: the message names ``field`` and shows the expected form.
    """
    if with_face:
        want = 4
        form = ("expected x,y,theta,face in metres, radians and a face number "
                "(e.g. 0.2,-0.05,1.57,3 or 0.2,-0.05,90deg,3)")
    else:
        want = 3
        form = "expected x,y,theta in metres and radians (e.g. 0.1,-0.05,1.57 or 0.1,-0.05,90deg)"
    parts = [p.strip() for p in str(text).split(",")]
    if len(parts) != want:
        raise InputError(f"{field}: {form}, got {text!r} ({len(parts)} value"
                         f"{'s' if len(parts) != 1 else ''})")
    out: list = []
    for name, p in zip(("x", "y"), parts[:2]):
        if not re.fullmatch(NUMBER, p):
            raise InputError(f"{field}: {name} must be a number in metres, got {p!r}; {form}")
        out.append(float(p))
    theta = angle_value(parts[2])
    if theta is None:
        raise InputError(f"{field}: theta must be a number in radians or degrees with a 'deg' "
                         f"suffix, got {parts[2]!r}; {form}")
    out.append(theta)
    if not all(math.isfinite(v) for v in out):
        raise InputError(f"{field}: values must be finite, got {text!r}")
    if with_face:
        fm = FACE.match(parts[3])
        if not fm:
            raise InputError(f"{field}: face must be a non-negative face number, got "
                             f"{parts[3]!r}; {form}")
        out.append(int(fm.group(1)))
    return tuple(out)


def join_negative_values(argv: Sequence[str], flags: Iterable[str]) -> list[str]:
    """``--start -0.1,0,0`` -> ``--start=-0.1,0,0`` for the given value flags
    (argparse would otherwise take the value for an option)."""
    flags = set(flags)
    out, i = [], 0
    argv = list(argv)
    while i < len(argv):
        tok = argv[i]
        if tok in flags and i + 1 < len(argv) and argv[i + 1].startswith("-") \
                and not argv[i + 1].startswith("--"):
            out.append(f"{tok}={argv[i + 1]}")
            i += 2
            continue
        out.append(tok)
        i += 1
    return out


def check_figure_path(path: str, flag: str) -> None:
    """Refuse a figure's file before any work: its folder must exist and its
    suffix name a file type matplotlib writes (``.png``, ``.pdf``, ``.svg``, ...).

    Raises:
      InputError: the message names ``flag`` and the fix.
    """
    if not os.path.isdir(os.path.dirname(os.path.abspath(path))):
        raise InputError(f"{flag}: the folder of {path!r} does not exist")
    from matplotlib.backend_bases import FigureCanvasBase

    types = FigureCanvasBase.get_supported_filetypes()
    suffix = os.path.splitext(path)[1].lower()
    if suffix[1:] not in types:
        got = f"the suffix {suffix!r}" if suffix else "no suffix"
        raise InputError(f"{flag}: {path!r} has {got}, not a figure file type; give a file name "
                         "ending in .png, .pdf or .svg")


def fail(message: str, code: int = Exit.INPUT) -> int:
    """Write ``error: <message>`` as one line on stderr; return ``code``."""
    sys.stderr.write(f"error: {' '.join(str(message).split())}\n")
    return code


def report_warnings(caught) -> None:
    """Write each distinct caught warning as one ``warning: ...`` line on stderr."""
    seen = set()
    for w in caught:
        msg = " ".join(str(w.message).split())
        if msg not in seen:
            seen.add(msg)
            sys.stderr.write(f"warning: {msg}\n")


def disk_full(exc: BaseException) -> bool:
    """Whether ``exc`` says the disk (or the user's quota) is full; pyarrow's
    writers say it in the message and leave ``errno`` unset."""
    import errno

    return isinstance(exc, OSError) and (
        exc.errno in (errno.ENOSPC, errno.EDQUOT) or "No space left on device" in str(exc))


def free_space(path=None) -> str:
    """``"N MB free"`` on the disk holding ``path`` (its nearest existing folder;
    None: the working folder), or ``"free space unknown"``."""
    import pathlib
    import shutil

    p = pathlib.Path(path or ".").absolute()
    while not p.exists() and p != p.parent:
        p = p.parent
    try:
        return f"{shutil.disk_usage(p).free / 1e6:.0f} MB free"
    except OSError:
        return "free space unknown"


#: set in the environment of the child a supervised command runs in (:func:`supervise`)
CHILD_ENV = "NUDGE_SUPERVISED"
#: what follows every line about a run the machine could not finish
RESUME = ("finished chunks are kept: run the same command again to resume (on a machine with "
          "more memory, or a study with a lower chunk_samples)")
#: signals a supervisor passes on to its child (Ctrl-C, a polite kill, a closed terminal)
FORWARDED = ("SIGINT", "SIGTERM", "SIGHUP")


def out_of_memory(exc: BaseException) -> bool:
    """Whether ``exc`` says the process ran out of memory (Python's
    ``MemoryError``, XLA's ``RESOURCE_EXHAUSTED`` or a failed allocation)."""
    text = str(exc)
    return isinstance(exc, MemoryError) or "RESOURCE_EXHAUSTED" in text or \
        "Cannot allocate memory" in text or "Out of memory" in text


def death_line(signum: int) -> tuple[str, int]:
    """The one ``error:`` line and the exit status (:class:`~sweeps.errors.Exit`)
    of a supervised command whose process died by signal ``signum``."""
    import signal

    try:
        name = signal.Signals(signum).name
    except ValueError:
        name = f"signal {signum}"
    if signum == signal.SIGINT:
        return ("stopped: finished chunks are kept; run the same command again to resume",
                Exit.INTERRUPTED)
    if signum in (signal.SIGTERM, signal.SIGHUP):
        return (f"stopped by {name}: finished chunks are kept; run the same command again to "
                "resume", 128 + signum)
    if signum == signal.SIGKILL:
        return (f"the run was killed ({name}), most often by the kernel when the machine is out "
                f"of memory; {RESUME}", Exit.RESOURCES)
    return (f"the run died in native code ({name}), most often out of memory or of memory maps "
            f"(vm.max_map_count) in a compiler or the physics engine; {RESUME}", Exit.RESOURCES)


def _die_with_parent(parent: int):
    """A ``preexec_fn`` that has the child killed when its supervisor dies (a
    ``kill -9`` of the command kills the run, as it did before supervision):
    Linux's ``PR_SET_PDEATHSIG``; elsewhere nothing."""
    def setup():
        import ctypes
        import signal

        try:
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, int(signal.SIGKILL), 0, 0, 0)   # PR_SET_PDEATHSIG
        except (OSError, AttributeError):   # pragma: no cover - not Linux
            return
        if os.getppid() != parent:   # the supervisor died before prctl took effect
            os._exit(Exit.INTERRUPTED)

    return setup


def supervise() -> "int | None":
    """Run this command line again in a child process and answer for how it ends.

    What a process cannot do itself (memory, memory maps, a crash in native
    code: XLA's compiler, the MuJoCo engine) kills it by a signal, with no line
    and no exit status of the table.  The supervisor, a process that imports
    nothing heavy, runs the command in a child (its own process group, so that
    Ctrl-C reaches it once, passed on by the supervisor) and turns a death by
    signal into one ``error:`` line and an exit status (:func:`death_line`);
    the finished chunks are on disk and the same command resumes.

    Returns the child's exit status, or None in the child itself (and under
    ``NUDGE_DEBUG``, which runs in one process for the traceback): run the
    command here.
    """
    import signal
    import subprocess

    if os.environ.get(CHILD_ENV) or os.environ.get("NUDGE_DEBUG"):
        return None
    argv = [sys.executable, *list(getattr(sys, "orig_argv", sys.argv))[1:]]
    children: list = []
    pending: list = []   # signals that came before the child was started

    def forward(signum, _frame):
        if not children:
            pending.append(signum)
            return
        try:
            children[0].send_signal(signum)
        except ProcessLookupError:   # gone already
            pass

    for name in FORWARDED:
        signal.signal(getattr(signal, name), forward)
    children.append(subprocess.Popen(argv, env={**os.environ, CHILD_ENV: "1"}, process_group=0,
                                     preexec_fn=_die_with_parent(os.getpid())))
    for signum in pending:
        forward(signum, None)
    rc = children[0].wait()
    if rc >= 0:
        return rc
    line, code = death_line(-rc)
    sys.stderr.write(f"error: {line}\n")
    return code


def run_main(main: Callable[[], int], supervised: bool = False) -> None:
    """``sys.exit(main())``; a :class:`~sweeps.errors.UserError` that reaches it
    is one ``error:`` line and exit status 2, so is a full disk (the line names
    the folder and the free space; the run resumes), running out of memory one
    line and exit status 4, any other exception one line and exit status 3
    (``NUDGE_DEBUG=1`` re-raises it for the traceback).

    ``supervised``: the console entry points run ``main`` in a child process
    (:func:`supervise`), so that a death by signal is one line too.  A bad
    ``$NUDGE_THREADS`` is refused before any work (:func:`robustness.cpu_threads`,
    which imports no JAX).  ``$JAX_NUM_CPU_DEVICES`` defaults to its count
    (``$NUDGE_THREADS`` or the cores this process may run on): JAX's CPU then
    has a device per core, over which a batch's compiled replays spread
    (:func:`robustness.replay.replay_devices`)."""
    from robustness import cpu_threads

    try:
        threads = cpu_threads()
    except ValueError as exc:
        sys.exit(fail(str(exc)))
    # one CPU device per core before JAX starts, so that a batch's compiled replays
    # spread over them (robustness.replay.replay_devices); a value the caller set is kept
    os.environ.setdefault("JAX_NUM_CPU_DEVICES", str(threads))
    if supervised:
        rc = supervise()
        if rc is not None:
            sys.exit(rc)
    try:
        sys.exit(main())
    except KeyboardInterrupt:
        sys.exit(Exit.INTERRUPTED)
    except UserError as exc:
        if os.environ.get("NUDGE_DEBUG"):
            raise
        sys.exit(fail(str(exc)))
    except Exception as exc:  # noqa: BLE001 - a CLI reports, it does not dump a traceback
        if os.environ.get("NUDGE_DEBUG"):
            raise
        if disk_full(exc):   # not a bug: one line, the run resumes once there is space
            where, free = exc.filename or "the results folder", free_space(exc.filename)
            sys.exit(fail(f"no space left on the disk holding {where} ({free}): "
                          "free some space or give --out on another disk, then run the same "
                          "command again to resume (finished chunks are kept)"))
        if out_of_memory(exc):
            sys.exit(fail(f"out of memory ({type(exc).__name__}: "
                          f"{' '.join(str(exc).split())[:200]}); {RESUME}", Exit.RESOURCES))
        sys.stderr.write(f"error: internal error ({type(exc).__name__}: "
                         f"{' '.join(str(exc).split())}); rerun with NUDGE_DEBUG=1 for the "
                         "traceback\n")
        sys.exit(Exit.INTERNAL)


def load_part_of_kind(path, kind: str, other_tool: str, units=None, face=None):
    """Read a part file (:func:`sweeps.partfile.load_part`; a bundled part's
    name works too, e.g. ``cube``), or a CAD file given directly (a mesh, its
    ``footprint`` on ``face`` for a polygon; ``units``: ``--units``), and check
    that it holds a ``kind`` part (``polygon`` or ``polyhedron``).

    Raises:
      UserError: a bad file (a ``PartFileError``: the message names the field),
        or the other kind (the message names ``other_tool``, the command for
        that kind).
    """
    from sweeps.catalog import find_part
    from sweeps.partfile import load_part

    try:
        path = find_part(path)
    except FileNotFoundError as exc:
        if not str(path).endswith((".yaml", ".yml")) and "/" not in str(path):
            raise InputError(f"{path}: {exc}") from None
    part = load_part(path, kind=kind, units=units, face=face, units_field="--units")
    if part.kind != kind:
        raise InputError(f"{part.path}: kind: this planner takes {kind} parts, this file holds a "
                         f"{part.kind} (use {other_tool})")
    return part


def report_part(part) -> None:
    """On stderr: where a CAD part's geometry came from and its unit (one
    ``part:`` line), then what reading it found (``warning:`` lines)."""
    if part.cad is None and part.units == "m":
        return
    sys.stderr.write(f"part: {part.name}: {part.source_text}\n")
    for w in part.warnings:
        sys.stderr.write(f"warning: {w}\n")
