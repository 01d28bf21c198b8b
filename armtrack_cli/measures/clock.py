"""The uniform clock of a long trajectory found a window at a time, and each window's speed
profile on it (windowed.py): the numbers signal.uniform and signal.speed_profile give the
whole span, from the window's frames and its margins alone.

The clock needs the first and last finite sample, the longest gap and the median frame
interval over the whole span: one pass over the windows' own frames gathers them (the median
from the counts of each distinct interval: a camera's frame times have a few). Each
window's profile is then PCHIP (slopes from neighbouring knots only: the same bits as the
whole span's away from the read span's ends), the low-pass (whose start-up transient has
died out long before the 20 s margins end) and central differences, kept on the window's
inner span: equal to the whole span's to round-off (tests/test_flat_measures.py)."""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np

from armtrack_cli.measures.base import NotComputable, Settings
from armtrack_cli.measures.pchip import pchip
from armtrack_cli.measures.signal import lowpass
from armtrack_cli.measures.vec3 import norm3


def median_of_counts(counts: Counter) -> float:
    """np.median of the values counted (value -> how many times)."""
    vals = sorted(counts)
    cum = np.cumsum([counts[v] for v in vals])
    m = int(cum[-1])

    def nth(k: int) -> float:
        return float(vals[int(np.searchsorted(cum, k, "right"))])

    return float(np.mean([nth((m - 1) // 2), nth(m // 2)]))


class IntervalCounter:
    """Counts the intervals between consecutive times fed in order, in pieces."""

    def __init__(self):
        self.counts: Counter = Counter()
        self.last: float | None = None
        self.first: float | None = None
        self.n = 0
        self.longest = -np.inf

    def add(self, t: np.ndarray) -> None:
        if t.size == 0:
            return
        d = np.diff(t if self.last is None else np.r_[self.last, t])
        if d.size:
            u, c = np.unique(d, return_counts=True)
            self.counts.update(dict(zip(u.tolist(), c.tolist())))
            self.longest = max(self.longest, float(d.max()))
        self.first = float(t[0]) if self.first is None else self.first
        self.last, self.n = float(t[-1]), self.n + t.size

    def median(self) -> float:
        return median_of_counts(self.counts)


@dataclass(frozen=True)
class Clock:
    """signal.uniform's clock t0 + dt·k, k < n, and its low-pass rate."""

    t0: float
    dt: float
    n: int
    t_end: float = float("nan")  # the last finite sample's time (the session row's end)

    def at(self, k: np.ndarray) -> np.ndarray:
        return self.t0 + self.dt * k  # the bits of t0 + dt * np.arange(n)

    @property
    def fs(self) -> float:
        return 1.0 / (self.at(np.arange(2))[1] - self.t0)

    def searchsorted(self, x: float) -> int:
        """np.searchsorted(clock, x) (left) without the clock."""
        k = int(np.clip(np.floor((x - self.t0) / self.dt), 0, self.n))
        while k > 0 and self.at(np.array([k - 1]))[0] >= x:
            k -= 1
        while k < self.n and self.at(np.array([k]))[0] < x:
            k += 1
        return k


def find_clock(frames: Iterable[tuple[np.ndarray, np.ndarray]], s: Settings,
               what: str = "wrist trajectory") -> Clock:
    """signal.uniform's clock (and its NotComputable) from each window's own frames (t,
    x (n, d)) in time order."""
    c = IntervalCounter()
    for t, x in frames:
        ok = np.isfinite(x).all(axis=1) & np.isfinite(t)
        c.add(t[ok])
    if c.n < 10:
        raise NotComputable(f"fewer than 10 samples of the {what}")
    dt = c.median()
    gap = c.longest - dt
    if gap > s.max_gap_s:
        raise NotComputable(f"a {gap:.2f} s gap in the {what} (longest bridged: {s.max_gap_s} s)")
    n = int(np.floor((c.last - c.first) / dt + 1e-6)) + 1
    return Clock(c.first, dt, n, c.last)


@dataclass(frozen=True)
class Profile:
    """One window's speed profile on the session clock: samples k0 … k0 + len − 1; those
    from ``a`` to ``b`` (exclusive) are the window's own (its inner span)."""

    k0: int
    t: np.ndarray
    p: np.ndarray
    v: np.ndarray
    a: int
    b: int


def window_profile(clock: Clock, t: np.ndarray, x: np.ndarray, inner: Callable, s: Settings,
                   last: bool) -> Profile | None:
    """The profile of one window's frames t, x (n, 3) (its read span), ``inner`` its
    Window.inner; ``last``: the session's last window (its clock runs to the clock's end).
    None when the window has no finite sample."""
    ok = np.isfinite(x).all(axis=1) & np.isfinite(t)
    tt, xx = t[ok], x[ok]
    if tt.size < 2:
        return None
    k0 = clock.searchsorted(float(tt[0]))
    k1 = clock.n if last else min(clock.n, clock.searchsorted(float(tt[-1])) + 1)
    k = np.arange(k0, k1)
    if k.size < 2:
        return None
    tk = clock.at(k)
    p = pchip(tt, xx, tk)
    if not s.lowpass_hz >= 0.45 * clock.fs and clock.n > 27:
        p = lowpass(p, clock.fs, s.lowpass_hz)
    v = norm3(np.gradient(p, tk, axis=0))
    own = np.flatnonzero(inner(tk))
    a, b = (int(own[0]), int(own[-1]) + 1) if own.size else (0, 0)
    return Profile(k0, tk, p, v, a, b)
