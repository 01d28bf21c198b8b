"""The one timer the benchmarks use: the best of several runs (least disturbed by the machine)."""

from __future__ import annotations

import time


def best_of(fn, runs: int = 3) -> float:
    best = float("inf")
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best
