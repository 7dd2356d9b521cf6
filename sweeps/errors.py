"""What the edge answers with: one error type for bad input and one table of
exit statuses, shared by every command (``nudge``, ``python -m sweeps.run``).

Bad input is a :class:`UserError` (or one of the edge's named subclasses:
``InputError``, ``ConfigError``, ``YamlError``, ``PartFileError``, ``RunError``,
``PlanInputError``): one ``error: ...`` line naming the field and the fix,
before any work, and exit status :attr:`Exit.INPUT`.
"""
from __future__ import annotations

import enum
from typing import Optional


class Exit(enum.IntEnum):
    """Exit statuses of every command (the README's table)."""

    OK = 0            #: the command did what was asked (a plan, solved, every task certified, a run)
    NEGATIVE = 1      #: a valid answer that is no: no plan, not solvable, some task not certified
    INPUT = 2         #: bad input, reported before any work
    INTERNAL = 3      #: a bug: one line, ``NUDGE_DEBUG=1`` for the traceback
    RESOURCES = 4     #: the machine could not: out of memory or memory maps, a native crash;
    #: one line, finished chunks kept, a rerun resumes
    INTERRUPTED = 130  #: Ctrl-C; finished chunks are kept and a rerun resumes


class UserError(ValueError):
    """Bad input at the edge (exit status 2); the message names the field and
    the fix.  ``lines`` holds one message per mistake (a config can have
    several); ``str()`` is the first."""

    def __init__(self, message: str, lines: Optional[list] = None):
        super().__init__(message)
        self.lines = list(lines) if lines else [message]

    def within(self, where) -> "UserError":
        """The same mistakes, of the same type, each line prefixed with
        ``where: `` (the file or option they were found in)."""
        return type(self)(f"{where}: {self.lines[0]}", [f"{where}: {ln}" for ln in self.lines])


__all__ = ["Exit", "UserError"]
