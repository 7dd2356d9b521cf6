"""What a run will cost, said before any work: the estimate line and the
budget above which a command asks for ``--yes`` (one line, exit 2, nothing
compiled or written).

Rates are the measured ones of :data:`robustness.models.THROUGHPUT` (samples/s
on 2 CPU cores, by plan kind, model and support family; ``bench/throughput.py``
measures them again), peak memory :func:`robustness.peak_bytes` of the blocks a
process holds at once (``robustness.models.SAMPLE_BYTES``, measured).
"""
from __future__ import annotations

from typing import Optional

#: a run estimated above this many seconds needs ``--yes``
BUDGET_S = 3600.0

#: the most samples a task of ``nudge certify --n-samples auto`` draws, unless
#: ``--max-samples`` / ``max_samples:`` says otherwise
MAX_SAMPLES = 100_000


def fmt_time(s: float) -> str:
    """Seconds as a person reads them (s, min or h)."""
    return f"{s:.0f} s" if s < 120 else (f"{s / 60:.1f} min" if s < 7200 else f"{s / 3600:.1f} h")


def fmt_bytes(b: float) -> str:
    """Bytes as a person reads them (MB or GB)."""
    return f"{b / 1e6:.0f} MB" if b < 1e9 else f"{b / 1e9:.1f} GB"


def machine_memory() -> Optional[float]:
    """This machine's physical memory (bytes), or None where it cannot be read."""
    import os

    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):   # pragma: no cover - not POSIX
        return None


def estimate_line(seconds: float, peak: float, detail: str = "") -> str:
    """The line before a run: its time and peak memory (``detail``: what they
    were estimated for, in brackets)."""
    return (f"estimate: about {fmt_time(seconds)} on 2 CPU cores, peak memory about "
            f"{fmt_bytes(peak)}" + (f" ({detail})" if detail else ""))


def refusal(seconds: float, what: str, yes: bool, fix: str, peak: Optional[float] = None,
            memory_fix: str = "set chunk_samples lower") -> Optional[str]:
    """One error line when ``seconds`` is over :data:`BUDGET_S`, or the peak
    memory ``peak`` (bytes) over this machine's memory, and the user has not
    accepted it (``yes``); ``what`` says what is estimated, ``fix`` /
    ``memory_fix`` how to make it smaller.  None when the run may start."""
    if yes:
        return None
    mem = machine_memory()
    if peak is not None and mem is not None and peak > mem:
        return (f"{what} needs an estimated {fmt_bytes(peak)} of memory at its peak, more than "
                f"this machine's {fmt_bytes(mem)}: {memory_fix}, or pass --yes to run it anyway")
    if seconds <= BUDGET_S:
        return None
    return (f"{what} is estimated at about {fmt_time(seconds)} on 2 CPU cores (over the "
            f"{fmt_time(BUDGET_S)} budget): {fix}, or pass --yes to run it anyway")


__all__ = ["BUDGET_S", "estimate_line", "fmt_bytes", "fmt_time", "machine_memory", "refusal"]
