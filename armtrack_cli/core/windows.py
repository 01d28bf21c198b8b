"""A long session cut into windows, so that a stage holds one window's arrays at a time and
its peak memory stays flat with the session's length (issue 15).

Each window has an inner span, whose results are kept, and margins either side that the
stage also reads, so that what it computes in the inner span sees the data a whole-session
run would see around it (the arm smoother over 5-minute windows with 20 s margins gave the
whole-session estimate to 0.25 mm at most on a 60-minute session: docs/benchmarks.md). The
inner spans tile the session: every instant is in exactly one. A session no longer than one
window and its margins is one window, run whole (its outputs as before windows existed)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

WINDOW_S = 300.0  # inner span of a window, s
MARGIN_S = 20.0  # read either side of it, s


@dataclass(frozen=True)
class Window:
    lo: float  # inner span [lo, hi), s; the first window's lo is -inf, the last's hi +inf
    hi: float
    start: float  # the span read: [start, stop] = the inner span and its margins, clipped to
    stop: float  # the session's [t0, t1]; the first's start is t0, the last's stop t1

    def inner(self, t: np.ndarray) -> np.ndarray:
        """Which of the times ``t`` (s) are this window's own (a boolean mask)."""
        return (t >= self.lo) & (t < self.hi)

    def read(self, t: np.ndarray) -> slice:
        """The index range of sorted times ``t`` (s) this window reads."""
        return slice(int(np.searchsorted(t, self.start, "left")),
                     int(np.searchsorted(t, self.stop, "right")))


def windows(t0: float, t1: float, length_s: float = WINDOW_S, margin_s: float = MARGIN_S
            ) -> list[Window]:
    """The windows of a session spanning [t0, t1] s: one when it is no longer than a window
    and its two margins (or ``length_s`` <= 0: windows off), else inner spans of ``length_s``
    (the last one up to a window and a half long, never a sliver) with ``margin_s`` either
    side."""
    if not t1 >= t0:
        raise ValueError(f"windows over [{t0}, {t1}]: not a span")
    if length_s <= 0 or t1 - t0 <= length_s + 2 * margin_s:
        return [Window(-np.inf, np.inf, t0, t1)]
    n = max(1, int(round((t1 - t0) / length_s)))  # the rest shared out: none a sliver
    edges = t0 + np.arange(n + 1) * length_s
    edges[0], edges[-1] = -np.inf, np.inf
    return [Window(float(lo), float(hi), max(t0, float(lo) - margin_s) if np.isfinite(lo) else t0,
                   min(t1, float(hi) + margin_s) if np.isfinite(hi) else t1)
            for lo, hi in zip(edges[:-1], edges[1:])]
