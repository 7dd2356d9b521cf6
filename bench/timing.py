"""Timing helper shared by the benchmark scripts (run by hand; no assertions)."""
import math
import time


def best_of(fn, repeat: int) -> float:
    """Best wall time (s) of ``repeat`` calls of ``fn`` (warm it up first)."""
    best = math.inf
    for _ in range(max(1, repeat)):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best
