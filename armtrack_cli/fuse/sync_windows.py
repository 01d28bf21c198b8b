"""The stretches of a long session that a declared IMU offset's check scores (issue 15).

A check only has to tell a declared offset that the data contradict (pipeline/imu_offset.py:
beyond 3 SD and WARN_FLOOR_S, 50 ms) from one they do not, which a few minutes of motion do
with an SD of a few ms (docs/validation-sync.md); scoring every frame of an hour cost 6.5 s
and 45 MB. So a session of CHECK_MIN_S or more is checked on CHECK_WINDOWS windows of
CHECK_WINDOW_S, one in each of as many equal parts of the session: in each part the window
with the most image acceleration Σ|ü|² over the frames the IMU covers at every offset
searched. That sum is the information about δ: the cost's curvature in δ is Σ|d(c V)/dt|²,
i.e. Σ|ü|² where the fit holds (fuse/imu_sync.py). The windows make one SyncProblem of
stretches, each with its own drift spline and its own integrals (SyncProblem.frame_cuts,
imu_cuts), sharing δ, the scale and the accelerometer's bias: the check's cost and memory are
those of CHECK_WINDOWS × CHECK_WINDOW_S seconds (two minutes) whatever the session's length.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from armtrack_cli.fuse.imu_sync import BRIDGE_S, WINDOW_S, SyncProblem, _imu_covers
from armtrack_cli.fuse.sync_signal import bridge, savgol

CHECK_MIN_S = 240.0  # a session this long is checked on windows (shorter: every frame)
CHECK_WINDOWS = 8  # … this many, one in each of as many equal parts of the session
CHECK_WINDOW_S = 15.0  # … of this length (two minutes in all: SD ~1-2 ms on long-10)
PAD_S = 0.5  # IMU kept beyond what the offsets searched reach (the refinement and the SD's
#              steps go a few frame periods past the search; Hermite needs the next sample)


def check_windows(p: SyncProblem, centre_s: float, search_s: float) -> SyncProblem:
    """``p`` on CHECK_WINDOWS windows (the module's docstring); ``p`` itself when shorter than
    CHECK_MIN_S, or when the IMU covers too little of it to fill them."""
    n = p.t_frames.size
    if n < 2 or p.t_frames[-1] - p.t_frames[0] < CHECK_MIN_S:
        return p
    dt = float(np.median(np.diff(p.t_frames)))
    w = int(round(CHECK_WINDOW_S / dt))
    starts = _best_windows(p, dt, w, centre_s, search_s)
    if starts is None:
        return p
    return _on_windows(p, _merged(starts, w, int(np.ceil((2 * (search_s + PAD_S) + 1) / dt))),
                       centre_s, search_s)


def _best_windows(p: SyncProblem, dt: float, w: int, centre_s: float, search_s: float
                  ) -> np.ndarray | None:
    """The first frame of each part's window of w frames with the largest Σ|ü|² (NaN: none);
    None when a part has no such window (its frames unseen or uncovered)."""
    n = p.t_frames.size
    window = max(5, int(round(WINDOW_S / dt)) | 1)
    acc = savgol(bridge(p.uv, int(round(BRIDGE_S / dt))), window, 2, dt)  # px/s²
    info = np.sum(acc**2, axis=1)
    reach = search_s + PAD_S
    covered = (_imu_covers(p, p.t_frames - centre_s - reach)
               & _imu_covers(p, p.t_frames - centre_s + reach))
    info = np.where(covered & np.isfinite(info), info, 0.0)
    total = np.r_[0.0, np.cumsum(info)]
    sums = total[w:] - total[:-w]  # window from frame i: sums[i], i = 0 … n − w
    edges = np.linspace(0, n, CHECK_WINDOWS + 1).astype(int)
    starts = []
    for a, b in zip(edges[:-1], edges[1:]):
        if b - a < w:
            return None
        i = a + int(np.argmax(sums[a:b - w + 1]))
        if sums[i] <= 0:
            return None
        starts.append(i)
    return np.array(starts)


def _merged(starts: np.ndarray, w: int, apart: int) -> list[tuple[int, int]]:
    """The windows [s, s + w) as frame ranges, those fewer than ``apart`` frames apart joined
    with the frames between (their IMU ranges would touch)."""
    out: list[list[int]] = []
    for s in starts.tolist():
        if out and s - out[-1][1] < apart:
            out[-1][1] = s + w
        else:
            out.append([s, s + w])
    return [(a, b) for a, b in out]


def _on_windows(p: SyncProblem, spans: list[tuple[int, int]], centre_s: float,
                search_s: float) -> SyncProblem:
    """The problem on the frames ``spans`` and the IMU's samples that the offsets searched
    (± PAD_S) bring under them: one stretch per span, end to end (spans at least _merged's
    ``apart`` from each other: their IMU's samples do not meet, more than GAP_S apart, so no
    frame of one stretch is covered by another's)."""
    reach = search_s + PAD_S
    frames, samples = [], []
    for a, b in spans:
        lo = np.searchsorted(p.t_imu, p.t_frames[a] - centre_s - reach, side="right") - 1
        hi = np.searchsorted(p.t_imu, p.t_frames[b - 1] - centre_s + reach) + 1
        frames.append(np.arange(a, b))
        samples.append(np.arange(max(lo, 0), min(hi, p.t_imu.size)))
    f, s = np.concatenate(frames), np.concatenate(samples)
    return replace(p, t_imu=p.t_imu[s], a_W=p.a_W[s], q_WB=p.q_WB[s], t_frames=p.t_frames[f],
                   uv=p.uv[f], frame_cuts=_cuts(frames), imu_cuts=_cuts(samples))


def _cuts(parts: list[np.ndarray]) -> tuple[int, ...]:
    """Where each part after the first starts, end to end."""
    return tuple(int(k) for k in np.cumsum([x.size for x in parts[:-1]]))
