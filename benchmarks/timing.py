"""The one timer the benchmarks use: the best of several runs (least disturbed by the machine),
in CPU seconds of this process, so that other work on a shared machine does not count."""

from __future__ import annotations

import time


def best_of(fn, runs: int = 3, clock=time.process_time) -> float:
    best = float("inf")
    for _ in range(runs):
        t0 = clock()
        fn()
        best = min(best, clock() - t0)
    return best
