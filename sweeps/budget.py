"""What a run will cost, said before any work: the estimate line and the
budget above which a command asks for ``--yes`` (one line, exit 2, nothing
compiled or written).

Rates are the measured ones of :data:`robustness.models.THROUGHPUT` (samples/s
on 2 CPU cores, by plan kind, model and support family; ``bench/throughput.py``
measures them again).
"""
from __future__ import annotations

from typing import Optional

#: a run estimated above this many seconds needs ``--yes``
BUDGET_S = 3600.0


def fmt_time(s: float) -> str:
    """Seconds as a person reads them (s, min or h)."""
    return f"{s:.0f} s" if s < 120 else (f"{s / 60:.1f} min" if s < 7200 else f"{s / 3600:.1f} h")


def refusal(seconds: float, what: str, yes: bool, fix: str) -> Optional[str]:
    """One error line when ``seconds`` is over :data:`BUDGET_S` and the user has
    not accepted it (``yes``); ``what`` says what is estimated, ``fix`` how to
    make it smaller.  None when the run may start."""
    if yes or seconds <= BUDGET_S:
        return None
    return (f"{what} is estimated at about {fmt_time(seconds)} on 2 CPU cores (over the "
            f"{fmt_time(BUDGET_S)} budget): {fix}, or pass --yes to run it anyway")


__all__ = ["BUDGET_S", "fmt_time", "refusal"]
