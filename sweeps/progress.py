"""Progress of a run on stderr: a tqdm bar with rate and time left, the JAX
compilation shown as its own phase, and clean stopping on Ctrl-C.

When stderr is not a terminal (CI, a log file) the bar is ASCII and updates at
most every 30 s, so logs stay short.
"""
from __future__ import annotations

import os
import signal
import sys
import time

from tqdm import tqdm


class Progress:
    """A bar over the samples of a run (``quiet``: no bar; notes, which are
    warnings, are printed all the same)."""

    def __init__(self, total: int, quiet: bool = False, desc: str = "samples"):
        tty = sys.stderr.isatty()
        self.quiet = quiet
        self.bar = tqdm(total=total, unit="sample", desc="compile", disable=quiet, ascii=not tty,
                        mininterval=0.2 if tty else 30.0, file=sys.stderr, dynamic_ncols=tty,
                        smoothing=0.1)
        self._desc = desc
        self._first = True
        self.t0 = time.perf_counter()

    def note(self, text: str) -> None:
        """A line above the bar (a warning: shown under ``quiet`` too)."""
        if self.quiet:
            print(text, file=sys.stderr)
        else:
            self.bar.write(text, file=sys.stderr)

    def advance(self, n: int) -> None:
        """``n`` more samples done (the first finished unit ends the compile phase)."""
        if self._first:
            self._first = False
            self.bar.set_description(self._desc)
        self.bar.update(n)

    def close(self) -> None:
        self.bar.close()


class StopFlag:
    """Ctrl-C handling for a run: the first SIGINT asks to stop after the units
    running now (finished units are on disk already); a second one leaves at once
    with status 130 (``os._exit``: no interpreter teardown while JAX threads run)."""

    def __init__(self, message: str):
        self.stop = False
        self.message = message
        self._old = None

    def __enter__(self):
        try:
            self._old = signal.signal(signal.SIGINT, self._handle)
        except ValueError:  # not the main thread: leave Ctrl-C alone
            self._old = None
        return self

    def __exit__(self, *exc):
        if self._old is not None:
            signal.signal(signal.SIGINT, self._old)
        return False

    def _handle(self, signum, frame):
        if self.stop:
            sys.stderr.write(f"\ninterrupted again: stopping now. {self.message}\n")
            sys.stderr.flush()
            os._exit(130)
        self.stop = True
        sys.stderr.write("\nCtrl-C: stopping after the running chunk (press Ctrl-C again to stop "
                         "now; finished chunks are kept either way)\n")
        sys.stderr.flush()
