"""Wrist path measures of one movement (a segment or the whole session).

Onset and offset are where the speed crosses a fraction of its peak (2 %, as in the
drinking-task protocol of Alt Murphy et al. 2011, Gait Posture 33: 8-13)."""

from __future__ import annotations

import numpy as np

from armtrack_cli.measures.base import NotComputable, Settings


def peak(v: np.ndarray, s: Settings) -> int:
    """Index of the peak speed; NotComputable when the wrist did not move."""
    if v.size < 3:
        raise NotComputable("fewer than 3 samples")
    k = int(np.argmax(v))
    if v[k] < s.min_moving_speed:
        raise NotComputable(f"no movement (peak speed {v[k]:.3f} m/s is below "
                            f"{s.min_moving_speed} m/s)")
    return k


def onset_offset(v: np.ndarray, s: Settings) -> tuple[int, int]:
    """Onset: walking back from the first sample at 20 % of peak speed (s.min_segment_peak),
    the last sample above onset_fraction (2 %) of peak; offset: walking on from the last
    sample at 20 %, likewise. A noise blip at rest that never reaches 20 % moves neither.
    (The measures below take it as ``span`` where the caller has it already.)"""
    k = peak(v, s)
    high = np.flatnonzero(v >= s.min_segment_peak * v[k])
    low = v < s.onset_fraction * v[k]
    before = np.flatnonzero(low[:high[0]])
    after = np.flatnonzero(low[high[-1]:])
    a = before[-1] + 1 if before.size else 0
    b = high[-1] + after[0] - 1 if after.size else v.size - 1
    return int(a), int(b)


def movement_time(t: np.ndarray, v: np.ndarray, s: Settings, *,
                  span: tuple[int, int] | None = None) -> float:
    a, b = span or onset_offset(v, s)
    if b - a < 2:
        raise NotComputable("the movement is shorter than 3 samples")
    return float(t[b] - t[a])


def time_to_peak(t: np.ndarray, v: np.ndarray, s: Settings, *,
                 span: tuple[int, int] | None = None) -> float:
    a, _ = span or onset_offset(v, s)
    return float(t[peak(v, s)] - t[a])


def mean_speed(v: np.ndarray, s: Settings, *, span: tuple[int, int] | None = None) -> float:
    """Mean speed between onset and offset."""
    a, b = span or onset_offset(v, s)
    return float(np.mean(v[a:b + 1]))


def path_length(p: np.ndarray, v: np.ndarray, s: Settings, *,
                span: tuple[int, int] | None = None) -> float:
    """Sum of the distances between consecutive samples from onset to offset, m."""
    a, b = span or onset_offset(v, s)
    return float(np.sum(np.linalg.norm(np.diff(p[a:b + 1], axis=0), axis=1)))


def straightness(p: np.ndarray, v: np.ndarray, s: Settings, *,
                 span: tuple[int, int] | None = None) -> float:
    """Path length / straight-line distance from onset to offset (1 = straight)."""
    a, b = span = span or onset_offset(v, s)
    d = float(np.linalg.norm(p[b] - p[a]))
    if d < s.min_reach_m:
        raise NotComputable(f"start and end are {100 * d:.1f} cm apart (a return, not a reach)")
    return path_length(p, v, s, span=span) / d


EDGE_MEASURES = ("wrist_mean_speed", "time_to_peak_speed", "movement_time", "wrist_path_length",
                 "movement_units", "sparc", "ldlj", "straightness")  # need onset and offset


def cut_edges(t: np.ndarray, v: np.ndarray, s: Settings) -> tuple[str | None, str | None]:
    """Why the movement at the start / the end of the data is cut, or None: the hand moving
    at 20 % of the peak speed or more (s.min_segment_peak), and at least at the speed that
    is movement at all (s.min_moving_speed), at the first / last sample, as where the
    wrist's data begin or end mid-movement (lost tracking before or after). Noise at rest is
    far below both (the 2 % onset threshold is not: a tracker's noise can cross it,
    docs/measures.md), so a recording that starts and ends at rest is never cut."""
    if v.size < 3 or not np.isfinite(v).all() or v.max() < s.min_moving_speed:
        return None, None
    high = max(s.min_segment_peak * v.max(), s.min_moving_speed)
    start = (f"the hand is moving ({v[0]:.3f} m/s) where the wrist's data begin at "
             f"{t[0]:.2f} s: the movement's start is not in the data") if v[0] >= high else None
    end = (f"the hand is moving ({v[-1]:.3f} m/s) where the wrist's data end at "
           f"{t[-1]:.2f} s: the movement's end is not in the data") if v[-1] >= high else None
    return start, end
