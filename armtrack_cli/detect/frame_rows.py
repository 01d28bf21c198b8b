"""The patch tracker's per-frame rows (u, v, width, height, angle, ok), held only until no
later frame can change them (issue 15): detect hands them out a block at a time, so a long
session's bookkeeping stays a block's, not the session's."""

from __future__ import annotations

import numpy as np


class FrameRows:
    """Rows of frames ``base`` … ``n - 1`` (NaN until set; ok = 0 once a frame is started).
    ``take(stop)`` hands out and drops the frames before ``stop``."""

    def __init__(self, rows: int):
        """``rows``: the rows to hold at first (doubled when short; what take keeps after)."""
        self._rows = max(int(rows), 1)
        self.out = np.full((self._rows, 6), np.nan)
        self.base = 0  # the frame of out's first row: those before it were taken
        self.n = 0  # frames started

    def start(self, f: int) -> None:
        """Frame f is being looked at: ok = 0 until set says otherwise."""
        r = f - self.base
        if r >= self.out.shape[0]:
            grown = np.full((2 * max(r, self.out.shape[0]), 6), np.nan)
            grown[:self.out.shape[0]] = self.out
            self.out = grown
        self.out[r, 5] = 0
        self.n = max(self.n, f + 1)

    def set(self, f: int, row) -> None:
        """Frame f's row (f not yet taken: the tracker reports only frames it still holds)."""
        self.out[f - self.base] = row

    def held(self) -> np.ndarray:
        """A copy of the rows of frames base … n - 1."""
        return self.out[:self.n - self.base].copy()

    def take(self, stop: int) -> tuple[int, np.ndarray]:
        """(base, the rows of frames base … stop - 1), which are then dropped."""
        first, k, rest = self.base, stop - self.base, self.n - stop
        rows = self.out[:k].copy()
        kept = np.full((max(self._rows, 2 * rest), 6), np.nan)  # back to size after a long hold
        kept[:rest] = self.out[k:k + rest]
        self.out, self.base = kept, stop
        return first, rows
