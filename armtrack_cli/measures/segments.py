"""Movement segments of a repeated task: laps of a circle, each reach and each return.

A segment is a run of samples whose speed is at or above 10 % of the session's peak speed
(s.segment_fraction: a tracker's noise at a lap's turning point seldom falls below the 2 %
onset threshold; each segment's own onset and offset still use 2 %), lasting at least
s.min_segment_s and peaking above 20 % of the session's peak (so noise at rest is no
movement); the rests, or the near-zero speed where a lap ends or a reach turns back, separate
them. A task repeated without ever slowing down is one segment: the session measures say it
all."""

from __future__ import annotations

import numpy as np

from armtrack_cli.measures.base import DEFAULT, Settings


def segments(t: np.ndarray, v: np.ndarray, s: Settings = DEFAULT) -> list[tuple[int, int]]:
    """[(start, stop)] sample windows (stop exclusive), each holding one movement with half of
    the rests around it, so its own onset and offset can be found inside."""
    if v.size < 3 or not np.isfinite(v).all() or v.max() < s.min_moving_speed:
        return []
    above = v >= s.segment_fraction * v.max()
    edges = np.flatnonzero(np.diff(np.r_[0, above.astype(int), 0]))
    runs = [(a, b) for a, b in zip(edges[::2], edges[1::2]) if t[b - 1] - t[a] >= s.min_segment_s
            and v[a:b].max() >= s.min_segment_peak * v.max()]
    out = []
    for k, (a, b) in enumerate(runs):
        lo = 0 if k == 0 else (runs[k - 1][1] + a) // 2
        hi = v.size if k == len(runs) - 1 else (b + runs[k + 1][0]) // 2 + 1
        out.append((lo, hi))
    return out
