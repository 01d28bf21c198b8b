"""The data-quality verdict: "good", "usable with care: …" or "not usable: …", with reasons.

Thresholds (ours, stated on page 1): a frame is tracked when the camera found the wrist;
under 50 % tracked or a calibration reprojection error over 2 px is not usable; under 90 %
tracked, IMU gaps longer than 0.1 s or over 1 % of samples lost, reprojection over 1 px, a
synchronisation offset left to estimate, or (with ground truth) a wrist RMS error over 5 cm
asks for care; over 10 cm is not usable. Measures taken over less than 90 % of the recording
(the tracking has no wrist for the rest) ask for care, saying over which part."""

from __future__ import annotations

import math

from armtrack_cli.report.data import SessionReport


def _wrist_rmse_cm(r: SessionReport) -> float | None:
    if r.errors is None or r.method is None:
        return None
    e = r.errors[(r.errors["method"] == r.method) & (r.errors["joint"] == "wrist")
                 & (r.errors["axis"] == "3d")]
    return float(e["rmse_cm"].iloc[0]) if len(e) else None


COVER_CARE = 0.9  # measures over less than this share of the recording ask for care


def coverage(r: SessionReport) -> tuple[float, float, float] | None:
    """spans() of the session's measures (kinematics' t_start, t_end) in its trajectory."""
    k, d = r.kinematics, r.trajectory
    if k is None or d is None or "t_start" not in k:
        return None
    row = k[k["segment"] == "session"]
    if not len(row):
        return None
    return spans(float(row["t_start"].iloc[0]), float(row["t_end"].iloc[0]),
                 d["t"].to_numpy(dtype=float))


def spans(a: float, b: float, t) -> tuple[float, float, float] | None:
    """(start, end, recording length) in s: the span measures are taken over, [a, b] (from
    the first to the last frame with a wrist), and the trajectory's whole span (frame times
    ``t``), one frame interval included in each; None without two finite frames and a span."""
    import numpy as np

    if len(t) < 2 or not np.isfinite(t).all() or not (np.isfinite(a) and np.isfinite(b)):
        return None
    dt = float(np.median(np.diff(t)))
    return a, b + dt, float(t[-1] - t[0]) + dt


def coverage_text(c: tuple[float, float, float]) -> str:
    a, b, total = c
    return f"{b - a:.1f} s of the {total:.1f} s recorded ({a:.1f} to {b:.1f} s)"


def verdict(r: SessionReport) -> tuple[str, list[str]]:
    """("good" | "usable with care" | "not usable", reasons in plain words)."""
    q = r.quality
    bad, care = [], []
    if r.trajectory is None and not r.notes:
        bad.append("no movement estimate in this work folder")
    if r.trajectory is None:
        bad += list(r.notes)
    if math.isfinite(q.tracked_pct):
        if q.tracked_pct < 50:
            bad.append(f"the camera found the wrist in only {q.tracked_pct:.0f} % of frames")
        elif q.tracked_pct < 90:
            care.append(f"the camera found the wrist in {q.tracked_pct:.0f} % of frames")
    if math.isfinite(q.reprojection_px):
        if q.reprojection_px > 2:
            bad.append(f"camera calibration error {q.reprojection_px:.2f} px (over 2 px)")
        elif q.reprojection_px > 1:
            care.append(f"camera calibration error {q.reprojection_px:.2f} px (over 1 px)")
    if q.imu_longest_gap_s is not None and q.imu_longest_gap_s > 0.1:
        care.append(f"motion-sensor data missing for up to {q.imu_longest_gap_s:.2f} s")
    if q.imu_dropped and q.imu_samples and q.imu_dropped > 0.01 * q.imu_samples:
        care.append(f"{q.imu_dropped} motion-sensor samples lost")
    for what, off in (("motion sensor", q.imu_offset_s), ("reference system", q.groundtruth_offset_s)):
        if isinstance(off, str):
            care.append(f"the {what}'s time offset was not given")
    rmse = _wrist_rmse_cm(r)
    if rmse is not None and rmse > 10:
        bad.append(f"wrist error against the reference {rmse:.1f} cm RMS (over 10 cm)")
    elif rmse is not None and rmse > 5:
        care.append(f"wrist error against the reference {rmse:.1f} cm RMS (over 5 cm)")
    c = coverage(r)
    if c is not None and c[1] - c[0] < COVER_CARE * c[2]:
        care.append(f"the measures cover only {coverage_text(c)}: the tracking has no wrist "
                    "position for the rest")
    if r.trajectory is not None:
        care += list(r.notes)
    if bad:
        return "not usable", bad + care
    return ("usable with care", care) if care else ("good", [])


def sentence(r: SessionReport) -> str:
    v, reasons = verdict(r)
    return v if not reasons else f"{v}: " + "; ".join(reasons)
