"""Run the ``nudge`` console script as a user types it: in a subprocess
(:func:`nudge`), or in this process by the console script's own dispatcher
(:func:`nudge_here`, :func:`in_process`, :func:`call`).

A subprocess costs 3-4 s before the command does anything (Python, JAX, pandas
and scipy start; every kernel traced again): a test of what a command computes,
writes and says runs it in this process, where the kernels an earlier test
traced are shared.  What only a process shows stays in one: the console script
itself, exit on a signal, what libraries print to the real stderr, a process's
own environment and JAX settings, a cold start.  Every command keeps at least
one test through the subprocess."""
import os
import pathlib
import shutil
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]


def nudge_executable() -> str:
    """The installed ``nudge`` console script (next to this Python, else on PATH)."""
    here = pathlib.Path(sys.executable).parent / "nudge"
    if here.exists():
        return str(here)
    found = shutil.which("nudge")
    if found is None:
        raise RuntimeError("the nudge console script is not installed: pip install -e .")
    return found


def nudge(*args, timeout=600, cwd=ROOT, env=None, **kw):
    """``nudge ARGS...`` in a subprocess; returns the CompletedProcess."""
    e = dict(os.environ)
    e.pop("NUDGE_DEBUG", None)
    e.setdefault("JAX_PLATFORMS", "cpu")
    e.update(env or {})
    return subprocess.run([nudge_executable(), *map(str, args)], cwd=cwd, capture_output=True,
                          text=True, timeout=timeout, env=e, **kw)


def call(main, *args, debug=False):
    """``main(ARGS)`` in this process, as the console script runs it
    (:func:`sweeps.terminal.run_main`: an unexpected exception is one ``error:``
    line and exit status 3, re-raised with ``debug``, i.e. ``NUDGE_DEBUG=1``).

    Returns:
      ``(exit status, stdout, stderr)``.
    """
    import contextlib
    import io

    from sweeps.terminal import run_main

    out, err = io.StringIO(), io.StringIO()
    old = os.environ.pop("NUDGE_DEBUG", None)
    if debug:
        os.environ["NUDGE_DEBUG"] = "1"
    code = 0
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                run_main(lambda: main([str(a) for a in args]))
            except SystemExit as exc:
                code = 0 if exc.code is None else exc.code
    finally:
        os.environ.pop("NUDGE_DEBUG", None)
        if old is not None:
            os.environ["NUDGE_DEBUG"] = old
    return code, out.getvalue(), err.getvalue()


def in_process(main, *args, cwd=None):
    """:func:`call` of ``main(ARGS)``, returned as :func:`nudge` returns a run
    (a ``CompletedProcess``: ``returncode``, ``stdout``, ``stderr``).  ``cwd``:
    the working folder during the command (restored after)."""
    import contextlib

    with contextlib.chdir(cwd) if cwd is not None else contextlib.nullcontext():
        return subprocess.CompletedProcess([str(a) for a in args], *call(main, *args))


def nudge_here(*args, cwd=None):
    """``nudge ARGS`` in this process (:func:`in_process` on the console script's
    dispatcher, ``sweeps.cli.main``)."""
    from sweeps import cli

    return in_process(cli.main, *args, cwd=cwd)
