"""Clinical measures of a wrist-pose trajectory (Cordella et al. IV-A: RoM, angular and linear
velocity, trajectory), for estimates and ground truth alike. One function, so the measures
rewrite (core/measures.py) can take it over.

Angles and positions are low-pass filtered first (4th-order zero-phase Butterworth, 6 Hz,
Winter) so frame-to-frame estimation noise does not add speed the hand never had; speeds are
central differences over the valid samples.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import butter, sosfiltfilt

from armtrack_cli.core.wrist import ANGLES

CUTOFF_HZ = 6.0


def _smooth(x: np.ndarray, fs: float) -> np.ndarray:
    """Each run of finite samples of (N, k) low-passed on its own; short runs left as they are."""
    out = x.copy()
    if CUTOFF_HZ >= 0.45 * fs:
        return out
    sos = butter(4, CUTOFF_HZ, fs=fs, output="sos")
    ok = np.isfinite(x).all(axis=1)
    edges = np.flatnonzero(np.diff(np.r_[0, ok.astype(int), 0]))
    for a, b in zip(edges[::2], edges[1::2]):
        if b - a > 27:
            out[a:b] = sosfiltfilt(sos, x[a:b], axis=0)
    return out


def _speed(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """(N,) |dx/dt| per sample of (N, k) by central differences within runs; NaN at gaps."""
    v = np.full(x.shape, np.nan)
    ok = np.isfinite(x).all(axis=1)
    edges = np.flatnonzero(np.diff(np.r_[0, ok.astype(int), 0]))
    for a, b in zip(edges[::2], edges[1::2]):
        if b - a >= 3:
            v[a:b] = np.gradient(x[a:b], t[a:b], axis=0)
    return np.linalg.norm(v, axis=1) if x.shape[1] > 1 else np.abs(v[:, 0])


def wrist_pose_measures(t: np.ndarray, wrist: np.ndarray, angles_deg: np.ndarray
                        ) -> list[tuple[str, float, str]]:
    """(measure, value, unit) rows: per angle RoM as max − min and as the 5th-95th percentile
    span, peak and mean angular speed; wrist path length, peak and mean linear speed."""
    ok = np.isfinite(angles_deg).all(axis=1) & np.isfinite(wrist).all(axis=1)
    nan = float("nan")
    rows: list[tuple[str, float, str]] = []
    fs = 1.0 / np.median(np.diff(t)) if t.size > 1 else 1.0
    a = _smooth(np.where(ok[:, None], angles_deg, np.nan), fs)
    w = _smooth(np.where(ok[:, None], wrist, np.nan), fs)
    for k, name in enumerate(ANGLES):
        v = a[ok, k]
        sp = _speed(t, a[:, k:k + 1])
        sp = sp[np.isfinite(sp)]
        rows += [(f"{name}_rom", float(np.ptp(v)) if v.size else nan, "deg"),
                 (f"{name}_rom_p5_p95", float(np.subtract(*np.percentile(v, [95, 5])))
                  if v.size else nan, "deg"),
                 (f"{name}_min", float(v.min()) if v.size else nan, "deg"),
                 (f"{name}_max", float(v.max()) if v.size else nan, "deg"),
                 (f"{name}_peak_speed", float(sp.max()) if sp.size else nan, "deg/s"),
                 (f"{name}_mean_speed", float(sp.mean()) if sp.size else nan, "deg/s")]
    steps = np.linalg.norm(np.diff(w, axis=0), axis=1)
    ls = _speed(t, w)
    ls = ls[np.isfinite(ls)]
    rows += [("wrist_path_length", float(np.nansum(steps)), "m"),
             ("wrist_peak_speed", float(ls.max()) if ls.size else nan, "m/s"),
             ("wrist_mean_speed", float(ls.mean()) if ls.size else nan, "m/s")]
    return rows
