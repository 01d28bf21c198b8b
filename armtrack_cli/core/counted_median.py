"""The exact median of values seen a chunk at a time, from the count of each distinct value:
a clock's steps take a handful of values (20 among the 60-minute bench session's 360,000
IMU samples), so the streamed readers (session/imu_stream.py, session/qualisys_stream.py)
hold a few counts instead of every step (issue 15)."""

from __future__ import annotations

from collections import Counter

import numpy as np


class CountedMedian:
    """np.median of values seen a chunk at a time, from the count of each distinct value:
    exact, and a few entries where the values take a handful (a clock's steps: 20 distinct
    among the 60-minute bench session's 360,000), instead of every value held."""

    def __init__(self) -> None:
        self.counts: Counter = Counter()
        self.nan = False

    def add(self, v: np.ndarray) -> None:
        nan = np.isnan(v)
        self.nan = self.nan or bool(nan.any())
        u, c = np.unique(v[~nan], return_counts=True)
        self.counts.update(dict(zip(u.tolist(), c.tolist())))

    @property
    def size(self) -> int:
        return sum(self.counts.values()) + self.nan

    def median(self) -> float:
        """np.median of every value added (NaN if one was, as there)."""
        n = sum(self.counts.values())
        if self.nan or not n:
            return float("nan")
        at, mid = 0, []
        for v, c in sorted(self.counts.items()):  # the (n − 1) // 2-th and n // 2-th smallest
            mid += [v] * sum(at <= k < at + c for k in ((n - 1) // 2, n // 2))
            at += c
        return float(np.mean(mid))  # as np.median takes the mean of the middle one or two
