"""A time-ordered table kept in a session/spill.Spill, read back by time span without holding its
clock (issue 15): compare's truth (360,200 rows at 60 minutes) and trajectories live on disk and
a window's rows are read as it is scored. Only every STEP-th time is held (a 60-minute capture:
88 values), so what compare holds does not grow with the session's length."""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

STEP = 4096  # rows between the times held: a search reads one block of this many times


class SpilledTable:
    """Rows appended block by block (each a dict of columns, "t" time-ordered), then searched
    by time and read by row range. ``spill`` is a session/spill.Spill the caller opened (its
    append, read and len; the file access stays in the I/O layer)."""

    def __init__(self, spill, blocks: Iterable[dict[str, np.ndarray]]):
        self.spill = spill
        marks, self.names = [], ()
        for block in blocks:
            self.names = self.names or tuple(block)
            n0 = len(spill)
            t = np.asarray(block["t"], float)
            marks.append(t[(-n0) % STEP::STEP])  # the times at rows k·STEP
            spill.append(block)
        self.marks = np.concatenate(marks) if marks else np.empty(0)
        self.n = len(spill)
        if self.n:
            self.first, self.last = (float(spill.read(k, k + 1, ("t",))["t"][0])
                                     for k in (0, self.n - 1))

    def __len__(self) -> int:
        return self.n

    def search(self, x: float, side: str = "left") -> int:
        """np.searchsorted(t, x, side) over the whole clock, exactly, reading one block."""
        b = int(np.searchsorted(self.marks, x, side)) - 1  # the block x falls in
        if b < 0:
            return 0
        lo = b * STEP
        t = self.spill.read(lo, lo + STEP, ("t",))["t"]
        return lo + int(np.searchsorted(t, x, side))

    def rows(self, lo: int, hi: int, names: tuple[str, ...] | None = None) -> dict:
        """Rows [lo, hi) (clipped to the table) of the columns ``names`` (all by default)."""
        return self.spill.read(max(lo, 0), max(min(hi, self.n), 0), names)

    def span(self, start: float, stop: float, *, extra: int = 0,
             names: tuple[str, ...] | None = None) -> dict:
        """The rows with start <= t <= stop and ``extra`` rows more either side."""
        return self.rows(self.search(start, "left") - extra, self.search(stop, "right") + extra,
                         names)
