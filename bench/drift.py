"""Drift: the newest releases pyproject.toml allows, against the lock.

Run by hand from the repository root (network: the package index)::

    python bench/drift.py                 # newest allowed releases, the fast tier
    python bench/drift.py --all           # the whole suite (about 11 minutes on 2 cores)
    python bench/drift.py --python python3.12 --keep

Makes a scratch virtual environment in a temporary folder, installs nudge there
as a library user would (``pip install -e ".[test]"``: the newest release of
every dependency that ``pyproject.toml``'s ranges allow, no lock), prints every
package whose version differs from ``requirements.lock`` (and those only one
side has), then runs the fast tier (``-m "not slow"``; ``--all``: every test)
in that environment and prints what failed.  Nothing of the project's own
environment is touched.  Ends with
``RESULT changed=N added=N removed=N passed=N failed=N errors=N skipped=N
install_s=S tests_s=S``.
"""
from __future__ import annotations

import argparse
import pathlib
import re
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
LOCK = ROOT / "requirements.lock"


def _canon(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def read_pins(text: str) -> dict[str, str]:
    """``name==version`` lines of a lock or of ``pip freeze`` (names canonical;
    comments, options, markers and editable lines ignored)."""
    pins = {}
    for line in text.splitlines():
        line = line.split("#", 1)[0].split(";", 1)[0].strip()
        m = re.fullmatch(r"([A-Za-z0-9][A-Za-z0-9._-]*)(\[[^\]]*\])?==([^\s]+)", line)
        if m:
            pins[_canon(m.group(1))] = m.group(3)
    return pins


#: what ``pip freeze`` never lists (the installer's own packages)
NOT_FROZEN = {"pip", "setuptools", "wheel", "distribute"}


def compare(locked: dict[str, str], newest: dict[str, str]):
    """(changed, added, removed): [(name, locked, newest)], [(name, newest)], [(name, locked)];
    the installer's own packages, which ``pip freeze`` leaves out, are not compared."""
    locked = {k: v for k, v in locked.items() if k not in NOT_FROZEN}
    changed = [(k, locked[k], newest[k]) for k in sorted(locked.keys() & newest.keys())
               if locked[k] != newest[k]]
    added = [(k, newest[k]) for k in sorted(newest.keys() - locked.keys()) if k != "nudge"]
    removed = [(k, locked[k]) for k in sorted(locked.keys() - newest.keys())]
    return changed, added, removed


def summary_counts(output: str) -> dict[str, int]:
    """pytest's closing counts (passed, failed, errors, skipped) from its output."""
    tail = output.strip().splitlines()[-1] if output.strip() else ""
    out = {}
    for key, pat in (("passed", r"(\d+) passed"), ("failed", r"(\d+) failed"),
                     ("errors", r"(\d+) errors?"), ("skipped", r"(\d+) skipped")):
        m = re.search(pat, tail)
        out[key] = int(m.group(1)) if m else 0
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--python", default=sys.executable,
                    help="interpreter of the scratch environment (default: this one)")
    ap.add_argument("--all", action="store_true", help="the whole suite, not the fast tier")
    ap.add_argument("--keep", action="store_true", help="keep the scratch environment")
    ap.add_argument("pytest_args", nargs="*", help="more pytest arguments (after --)")
    a = ap.parse_args(argv)
    scratch = pathlib.Path(tempfile.mkdtemp(prefix="nudge-drift-"))
    venv = scratch / "venv"
    try:
        subprocess.run([a.python, "-m", "venv", str(venv)], check=True)
        py = str(venv / "bin" / "python")
        t0 = time.perf_counter()
        subprocess.run([py, "-m", "pip", "install", "-q", "-e", ".[test]"], cwd=ROOT, check=True)
        install_s = time.perf_counter() - t0
        freeze = subprocess.run([py, "-m", "pip", "freeze"], capture_output=True, text=True,
                                check=True).stdout
        changed, added, removed = compare(read_pins(LOCK.read_text()), read_pins(freeze))
        version = subprocess.run([py, "--version"], capture_output=True, text=True).stdout.strip()
        print(f"newest releases allowed by pyproject.toml ({version}) against requirements.lock:")
        if not (changed or added or removed):
            print("  none differ")
        width = max([len(r[0]) for r in changed + added + removed] + [7])
        for name, old, new in changed:
            print(f"  {name:<{width}}  {old:>12} -> {new}")
        for name, new in added:
            print(f"  {name:<{width}}  {'(not locked)':>12} -> {new}")
        for name, old in removed:
            print(f"  {name:<{width}}  {old:>12} -> (not installed)")
        tier = [] if a.all else ["-m", "not slow"]
        cmd = [py, "-m", "pytest", "-q", "-n", "2", "--dist", "loadfile", "-p", "no:cacheprovider",
               *tier, *a.pytest_args]
        print("running:", " ".join(cmd[2:]), flush=True)
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
        tests_s = time.perf_counter() - t0
        counts = summary_counts(proc.stdout)
        broke = [ln for ln in proc.stdout.splitlines() if ln.startswith(("FAILED ", "ERROR "))]
        print(f"{'what broke:' if broke else 'nothing broke'} ({proc.stdout.strip().splitlines()[-1] if proc.stdout.strip() else 'no output'})")
        for ln in broke:
            print("  " + ln)
        if proc.returncode not in (0, 1):
            print(proc.stdout[-3000:], proc.stderr[-3000:], sep="\n")
        print(f"RESULT changed={len(changed)} added={len(added)} removed={len(removed)} "
              f"passed={counts['passed']} failed={counts['failed']} errors={counts['errors']} "
              f"skipped={counts['skipped']} install_s={install_s:.0f} tests_s={tests_s:.0f}")
        return 0
    finally:
        if a.keep:
            print(f"scratch environment kept: {venv}")
        else:
            shutil.rmtree(scratch, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
