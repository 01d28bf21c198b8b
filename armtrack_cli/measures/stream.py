"""What the whole-span measures find in one pass over a signal, found over its pieces in time
order (windowed.py: each window's own samples, in turn): the onset and offset
(path.onset_offset), the runs above a threshold (segments.segments), the peaks' candidates
(peaks.find_peaks's maxima and valleys) and order statistics (np.percentile's) in passes
over the pieces. Each piece is (k0, x): global sample index of x[0], and the samples."""

from __future__ import annotations

import numpy as np

from armtrack_cli.measures.peaks import _prominences_table, by_distance, local_maxima


class OnsetOffset:
    """path.onset_offset given the peak speed vk: the last sample below ``low`` before the
    first at ``high`` or more, and the first below ``low`` from the last at ``high``."""

    def __init__(self, low: float, high: float, n: int):
        self.low, self.high, self.n = low, high, n
        self.first_high = self.last_high = None
        self.low_before = -1
        self.low_after: int | None = None

    def add(self, k0: int, v: np.ndarray) -> None:
        lows = np.flatnonzero(v < self.low) + k0
        highs = np.flatnonzero(v >= self.high) + k0
        if self.first_high is None:
            if highs.size:
                self.first_high = int(highs[0])
            before = lows[lows < self.first_high] if highs.size else lows
            if before.size:
                self.low_before = int(before[-1])
        if highs.size:
            self.last_high = int(highs[-1])
            after = lows[lows > self.last_high]
            self.low_after = int(after[0]) if after.size else None
        elif self.low_after is None and self.last_high is not None and lows.size:
            self.low_after = int(lows[0])

    def span(self) -> tuple[int, int]:
        b = self.low_after - 1 if self.low_after is not None else self.n - 1
        return self.low_before + 1, b


class Runs:
    """The runs of samples at or above ``level`` (start, stop exclusive, peak) over the pieces."""

    def __init__(self, level: float):
        self.level = level
        self.runs: list[tuple[int, int, float]] = []
        self.open: list | None = None  # [start, peak] of a run still going at a piece's end

    def add(self, k0: int, v: np.ndarray) -> None:
        above = v >= self.level
        if self.open is not None and not (v.size and above[0]):
            self._close(k0)  # the open run ended with the last piece
        edges = np.flatnonzero(np.diff(np.r_[0, above.astype(int), 0]))
        for a, b in zip(edges[::2].tolist(), edges[1::2].tolist()):
            start, pk = a + k0, float(v[a:b].max())
            if a == 0 and self.open is not None:  # the open run goes on
                start, pk = self.open[0], max(pk, self.open[1])
                self.open = None
            if b == v.size:
                self.open = [start, pk]
            else:
                self.runs.append((start, b + k0, pk))

    def _close(self, k: int) -> None:
        if self.open is not None:
            self.runs.append((self.open[0], k, self.open[1]))
            self.open = None

    def finish(self, n: int) -> list[tuple[int, int, float]]:
        self._close(n)
        return self.runs


class PeakSketch:
    """find_peaks(x, prominence, distance)'s count on x = the signal from sample a to b
    (inclusive), from its local maxima and the lowest sample between each two (what
    peaks._maxima_and_valleys keeps of it): a few per second of a speed profile."""

    def __init__(self, a: int, b: int):
        self.a, self.b = a, b
        self.cand: list[np.ndarray] = [np.array([a])]
        self.height: list[np.ndarray] = []
        self.valley: list[np.ndarray] = []
        self.low = np.inf  # the lowest sample since the last candidate

    def add(self, k0: int, x: np.ndarray, maxima: np.ndarray) -> None:
        """x: this piece's samples (of [a, b], in order); maxima: the signal's local maxima
        a < i < b in it (indices into x), found with the samples around it."""
        if x.size and k0 == self.a:
            self.height.append(x[:1])
        if x.size and k0 + x.size - 1 == self.b:  # b: the last candidate, in no valley
            self.end_height = float(x[-1])
            x = x[:-1]
        if x.size == 0:
            return
        if maxima.size == 0:
            self.low = min(self.low, float(x.min()))
            return
        before = float(x[:maxima[0]].min()) if maxima[0] > 0 else np.inf
        mins = np.minimum.reduceat(x, maxima)  # min x[m_j : m_j+1]: m_j's valley
        self.valley.append(np.r_[min(self.low, before), mins[:-1]])
        self.low = float(mins[-1])
        self.cand.append(maxima + k0)
        self.height.append(x[maxima])

    def count(self, prominence: float, distance: int) -> int:
        cand = np.concatenate(self.cand + [np.array([self.b])])
        height = np.concatenate(self.height + [np.array([self.end_height])])
        valley = np.concatenate(self.valley + [np.array([self.low])])
        peaks, h = cand[1:-1], height[1:-1]
        if peaks.size == 0:
            return 0
        if distance > 1 and peaks.size > 1:
            keep = by_distance(peaks, h, int(np.ceil(distance)))
            peaks, h = peaks[keep], h[keep]
        y = np.empty(2 * cand.size - 1)
        y[0::2], y[1::2] = height, valley
        at = 2 * np.searchsorted(cand, peaks)
        return int(np.count_nonzero(_prominences_table(y, at) >= prominence))


def interior_maxima(x: np.ndarray, lo: int, hi: int) -> np.ndarray:
    """Local maxima of x (one window's samples, read with its margins) at lo <= i < hi."""
    m = local_maxima(x)
    return m[(m >= lo) & (m < hi)]


def percentile_index(n: int, q: float) -> tuple[int, int, float]:
    """np.percentile(x, q)'s (linear) neighbouring ranks and weight for n values."""
    qq = np.float64(q) / 100
    vi = n * qq + (1 + qq * (1 - 1 - 1)) - 1
    lo = float(np.floor(vi))
    if vi >= n - 1:
        return n - 1, n - 1, float(vi - lo)
    return int(lo), int(lo) + 1, float(vi - lo)


def lerp(a: float, b: float, g: float) -> float:
    """numpy's _lerp (np.percentile's interpolation), for one pair."""
    d = b - a
    return float(b - d * (1 - g)) if g >= 0.5 else float(a + d * g)


class OrderStats:
    """The values at given ranks (0 = the least) of a stream of n values in [lo, hi], found
    in passes over it: each pass narrows each rank's range to one of BINS bins (a histogram),
    until the bin holds at most COLLECT values, which the next pass keeps and sorts. Memory:
    the bins and those values, whatever n."""

    BINS, COLLECT = 1024, 4096

    def __init__(self, lo: float, hi: float, ranks):
        self.state = {r: dict(lo=lo, hi=hi, closed=True, below=0, collect=False, value=None)
                      for r in set(ranks)}
        for st in self.state.values():
            if lo == hi:
                st["value"] = lo

    def pending(self) -> list[int]:
        return [r for r, st in self.state.items() if st["value"] is None]

    def begin(self) -> None:
        for r in self.pending():
            st = self.state[r]
            st["counts"] = np.zeros(self.BINS, int)
            st["kept"] = []
            st["under"] = 0
            st["least"], st["most"] = np.inf, -np.inf  # of the values in [lo, hi]

    def add(self, x: np.ndarray) -> None:
        for r in self.pending():
            st = self.state[r]
            inside = (x >= st["lo"]) & ((x <= st["hi"]) if st["closed"] else (x < st["hi"]))
            st["under"] += int(np.count_nonzero(x < st["lo"]))
            if inside.any():
                st["least"] = min(st["least"], float(x[inside].min()))
                st["most"] = max(st["most"], float(x[inside].max()))
            if st["collect"]:
                st["kept"].append(x[inside])
                continue
            edges = np.linspace(st["lo"], st["hi"], self.BINS + 1)
            j = np.clip(np.searchsorted(edges, x[inside], "right") - 1, 0, self.BINS - 1)
            st["counts"] += np.bincount(j, minlength=self.BINS)

    def end(self) -> bool:
        """After a pass: True when every rank has its value."""
        for r in self.pending():
            st = self.state[r]
            if st["least"] == st["most"]:  # every value left in the range is one (ties)
                st["value"] = st["least"]
            elif st["collect"]:
                kept = np.sort(np.concatenate(st["kept"]))
                st["value"] = float(kept[r - st["under"]])
            else:
                cum = st["under"] + np.cumsum(st["counts"])
                j = int(np.searchsorted(cum, r, "right"))
                edges = np.linspace(st["lo"], st["hi"], self.BINS + 1)
                old = (st["lo"], st["hi"])
                st["closed"] = st["closed"] and j == self.BINS - 1
                st["lo"], st["hi"] = float(edges[j]), float(edges[j + 1])
                st["collect"] = (st["counts"][j] <= self.COLLECT or not st["lo"] < st["hi"]
                                 or (st["lo"], st["hi"]) == old)  # no narrower in floats
        return not self.pending()

    def value(self, r: int) -> float:
        return self.state[r]["value"]
