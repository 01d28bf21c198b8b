"""A windowed fuse's summary (meta.json's settings, --json) from its windows' (issue 15):
each window's method summarises its inner frames (or, where a method only summarises all it
ran, its whole window), and they combine as docs/fusion.md says: counts add up, maxima take
the largest, RMS and means over all frames (each window's weighted by its frames), a
bias or drift at the session's end (the last window's)."""

from __future__ import annotations

import numpy as np

SUMS = ("gated_frames", "reacquired", "reseeded", "detections_gated", "start_runs_moved",
        "frames_at_rest")
MAXIMA = ("smoother_iterations_run", "kalman_linearisations_max", "shoulder_drift_max_m")
RMS = {"orientation_error_rms_deg": 3, "imu_bias_rms_m_s2": 4}  # key: decimals kept
MEANS = {"kalman_linearisations_mean": 2, "shoulder_mean_m": 4}
# the rest (accel_bias_m_s2, gyro_bias_deg_s: the last frame's; orientation_error_model): the
# last window's; upper_arm_change_m: the range over all windows


def combined(parts: list[tuple[dict, int]]) -> dict:
    """The windows' summaries, each with its number of inner frames, as one."""
    out: dict = {}
    for key in dict.fromkeys(k for d, _ in parts for k in d):
        have = [(d[key], n) for d, n in parts if key in d]
        vals, w = [v for v, _ in have], np.array([n for _, n in have], float)
        if key in SUMS:
            out[key] = int(sum(vals))
        elif key in MAXIMA:
            out[key] = max(vals)
        elif key in RMS:
            out[key] = round(float(np.sqrt(np.sum(w * np.square(vals)) / w.sum())), RMS[key])
        elif key in MEANS:
            m = np.sum(w[:, None] * np.atleast_2d(np.asarray(vals, float).T).T, 0) / w.sum()
            out[key] = round(float(m[0]), MEANS[key]) if np.ndim(vals[0]) == 0 else \
                [round(float(v), MEANS[key]) for v in m]
        elif key == "upper_arm_change_m":
            out[key] = [min(v[0] for v in vals), max(v[1] for v in vals)]
        else:
            out[key] = vals[-1]
    return out
