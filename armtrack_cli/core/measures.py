"""Clinical measures of a wrist (and elbow) trajectory, for estimates and ground truth alike.

Positions are first low-pass filtered (4th-order zero-phase Butterworth, 6 Hz, the usual
choice for arm kinematics; Winter, Biomechanics and Motor Control of Human Movement): frame-to-
frame estimation noise would otherwise add path length and speed that the arm never had.
Movement is where the wrist speed exceeds 5 % of its peak. Smoothness is SPARC, the spectral
arc length of the speed profile (Balasubramanian et al. 2015): closer to 0 is smoother.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import butter, sosfiltfilt

CUTOFF_HZ = 6.0

MEASURES = {  # name: unit
    "wrist_path_length": "m", "wrist_peak_speed": "m/s", "wrist_mean_speed": "m/s",
    "movement_time": "s", "wrist_range_x": "m", "wrist_range_y": "m", "wrist_range_z": "m",
    "sparc": "1", "elbow_flexion_min": "deg", "elbow_flexion_max": "deg",
    "elbow_flexion_rom": "deg",
}


def sparc(speed: np.ndarray, fs: float, fc: float = 10.0, amp_th: float = 0.05,
          padlevel: int = 4) -> float:
    """Spectral arc length of a speed profile sampled at fs (Balasubramanian et al. 2015)."""
    n = int(2 ** np.ceil(np.log2(len(speed)) + padlevel))
    f = np.arange(n) / n * fs
    mag = np.abs(np.fft.fft(speed, n))
    if mag.max() == 0:
        return 0.0
    mag = mag / mag.max()
    sel = f <= fc
    f, mag = f[sel], mag[sel]
    above = np.flatnonzero(mag >= amp_th)
    f, mag = f[: above[-1] + 1], mag[: above[-1] + 1]
    df = np.diff(f) / (f[-1] - f[0]) if f[-1] > f[0] else np.zeros(len(f) - 1)
    return float(-np.sum(np.sqrt(df**2 + np.diff(mag) ** 2)))


def elbow_flexion_deg(shoulder: np.ndarray, elbow: np.ndarray, wrist: np.ndarray) -> np.ndarray:
    """0° with the arm straight: 180° minus the angle between E→S and E→W."""
    a, b = shoulder - elbow, wrist - elbow
    c = np.sum(a * b, -1) / (np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1))
    return 180.0 - np.degrees(np.arccos(np.clip(c, -1, 1)))


def lowpass(x: np.ndarray, fs: float, fc: float = CUTOFF_HZ) -> np.ndarray:
    """Zero-phase low-pass of (N, 3) samples, each run of finite samples on its own (gaps stay
    gaps); runs too short to filter are left as they are."""
    out = x.copy()
    if fc >= 0.45 * fs:
        return out
    sos = butter(4, fc, fs=fs, output="sos")
    ok = np.isfinite(x).all(axis=1)
    edges = np.flatnonzero(np.diff(np.r_[0, ok.astype(int), 0]))
    for a, b in zip(edges[::2], edges[1::2]):
        if b - a > 27:  # sosfiltfilt's default padding needs 3 × (2 × order + 1) samples
            out[a:b] = sosfiltfilt(sos, x[a:b], axis=0)
    return out


def measures(t: np.ndarray, wrist: np.ndarray, *, elbow: np.ndarray | None = None,
             shoulder: np.ndarray | None = None) -> dict[str, float]:
    """The measures of MEASURES over the valid (finite) samples; NaN where undefined."""
    ok = np.isfinite(wrist).all(axis=1)
    out = {k: float("nan") for k in MEASURES}
    if ok.sum() < 3:
        return out
    fs0 = 1.0 / np.median(np.diff(t))
    wrist = lowpass(wrist, fs0)
    elbow = lowpass(elbow, fs0) if elbow is not None else None
    t, w = t[ok], wrist[ok]
    dt = np.diff(t)
    step = np.linalg.norm(np.diff(w, axis=0), axis=1)
    speed = np.r_[0.0, step / dt]
    fs = 1.0 / np.median(dt)
    peak = float(speed.max())
    moving = speed > 0.05 * peak if peak > 0 else np.zeros_like(speed, bool)
    out.update({
        "wrist_path_length": float(step.sum()), "wrist_peak_speed": peak,
        "wrist_mean_speed": float(speed[moving].mean()) if moving.any() else 0.0,
        "movement_time": float(np.sum(np.r_[dt, 0.0][moving])),
        "wrist_range_x": float(np.ptp(w[:, 0])), "wrist_range_y": float(np.ptp(w[:, 1])),
        "wrist_range_z": float(np.ptp(w[:, 2])),
        "sparc": sparc(speed[moving] if moving.sum() > 8 else speed, fs),
    })
    if elbow is not None and shoulder is not None:
        e = elbow[ok]
        good = np.isfinite(e).all(axis=1)
        if good.any():
            ang = elbow_flexion_deg(np.broadcast_to(shoulder, e.shape)[good], e[good], w[good])
            out.update({"elbow_flexion_min": float(ang.min()), "elbow_flexion_max": float(ang.max()),
                        "elbow_flexion_rom": float(np.ptp(ang))})
    return out


def kinematics_rows(t: np.ndarray, wrist: np.ndarray, *, elbow: np.ndarray | None = None,
                    shoulder: np.ndarray | None = None) -> dict[str, list]:
    """kinematics-METHOD.csv's columns: one row per measure (measure, value, unit)."""
    m = measures(t, wrist, elbow=elbow, shoulder=shoulder)
    return {"measure": list(m), "value": list(m.values()), "unit": [MEASURES[k] for k in m]}
