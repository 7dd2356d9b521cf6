"""Effort budgets of the tumble planner: every call returns in bounded time.

A plan call gets an :class:`Effort`: a deterministic **operation count** (the
budget proper) and a **wall-clock cap** (a backstop against a slow machine or a
stage whose count underestimates its time).  One operation is about the cost
of composing one tumble in Python (~1 microsecond); vectorised numpy work is
charged per element divided by a constant (``VECTOR_OPS``).

Counting is independent of caching, so a call's answer does not depend on what
earlier calls left in the caches: a structure the planner keeps between calls
(walk tables, rotation tables, lattice tables) records what it cost to build
(``cost``), and the first use in every call is charged that cost
(:meth:`Effort.charge_once`), whether it was built in this call or found in
the cache.  A builder checks the budget while
it works (:meth:`Effort.check`) and is abandoned, and not cached, when the
budget would run out; its cost is then exactly what a cached copy would have
been charged, so the answer is the same either way.

Running out raises :class:`BudgetExhausted`; the planner catches it at stage
boundaries and returns the best plan found so far with a verdict that says the
budget ran out (``"budget_exhausted"``) unless that plan already solves the
problem.
"""
from __future__ import annotations

import math
import time
from typing import Optional

__all__ = ["Effort", "BudgetExhausted", "DEFAULT_EFFORT", "DEFAULT_TIME_LIMIT_S", "VECTOR_OPS"]

#: Default operation budget of one ``plan_tumble`` call: about 4-10 s on one
#: core; the hardest goals of ``bench/tumble_planning.py`` (25 parts) use at
#: most 3.5 million.
DEFAULT_EFFORT = 10_000_000
#: Default wall-clock cap (seconds) of one call: a backstop, not the budget.
DEFAULT_TIME_LIMIT_S = 30.0
#: Numpy elements per charged operation (vectorised work is ~this much cheaper).
VECTOR_OPS = 32


class BudgetExhausted(Exception):
    """The effort budget ran out in ``stage`` (``clock``: the wall-clock cap
    did); ``used``: operations charged so far, ``needed``: what the stage
    would have brought the count to."""

    def __init__(self, stage: str, used: int, needed: float, limit: float, clock: bool):
        self.stage = stage
        self.used = used
        self.needed = needed
        self.limit = limit
        self.clock = clock
        what = "the wall-clock cap" if clock else f"the operation budget ({_fmt(limit)})"
        super().__init__(f"{what} ran out in stage {stage!r} ({used} operations charged)")


def _fmt(x: float) -> str:
    return "unlimited" if not math.isfinite(x) else f"{int(x)} operations"


class Effort:
    """A deterministic operation budget with a wall-clock backstop.

    Args:
      limit: operations (> 0), or None for no limit.
      time_limit: seconds from now (> 0), or None for no cap.
    """

    def __init__(self, limit: Optional[int] = DEFAULT_EFFORT,
                 time_limit: Optional[float] = DEFAULT_TIME_LIMIT_S):
        self.limit = math.inf if limit is None else float(limit)
        self.time_limit = math.inf if time_limit is None else float(time_limit)
        self.deadline = time.monotonic() + self.time_limit
        self.used = 0
        self.exhausted: Optional[BudgetExhausted] = None
        self._charged: set = set()
        self.by_stage: dict = {}

    @classmethod
    def unlimited(cls) -> "Effort":
        """No operation limit and no clock (analyses, tests of components)."""
        return cls(None, None)

    @property
    def remaining(self) -> float:
        """Operations left (``inf`` when unlimited; never negative)."""
        return max(0.0, self.limit - self.used)

    def _fail(self, stage: str, clock: bool, pending: float = 0.0):
        exc = BudgetExhausted(stage, self.used, self.used + pending, self.limit, clock)
        if self.exhausted is None:
            self.exhausted = exc
        raise exc

    def check(self, pending: float, stage: str) -> None:
        """Raise :class:`BudgetExhausted` if ``pending`` more operations would
        exceed the budget, or if the wall-clock cap has passed (nothing charged)."""
        if self.used + pending > self.limit:
            self._fail(stage, False, pending)
        if time.monotonic() > self.deadline:
            self._fail(stage, True)

    def charge(self, ops: float, stage: str) -> None:
        """Charge ``ops`` operations to ``stage`` (``by_stage`` keeps the
        totals); raise :class:`BudgetExhausted` when the budget (or the clock)
        runs out (the operations stay charged)."""
        n = int(math.ceil(ops))
        self.used += n
        self.by_stage[stage] = self.by_stage.get(stage, 0) + n
        if self.used > self.limit:
            self._fail(stage, False)
        if time.monotonic() > self.deadline:
            self._fail(stage, True)

    def charge_once(self, thing, ops: float, stage: str) -> None:
        """Charge the build cost ``ops`` of a (possibly cached) structure
        ``thing`` on its first use in this call; later uses are free."""
        if id(thing) in self._charged:
            return
        self._charged.add(id(thing))
        self.charge(ops, stage)

    def add(self, ops: float) -> None:
        """Count ``ops`` operations without checking the budget (work that is
        never cut short, e.g. verifying a plan already found)."""
        self.used += int(math.ceil(ops))

    def affordable(self, ops: float) -> bool:
        """Whether ``ops`` more operations fit in the budget (clock not consulted)."""
        return self.used + ops <= self.limit
