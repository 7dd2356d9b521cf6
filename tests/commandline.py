"""Run the ``nudge`` console script as a user types it (a subprocess)."""
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
