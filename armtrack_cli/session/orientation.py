"""Orientation estimated offline from gyro + accelerometer (+ magnetometer) with VQF.

VQF (Laidig & Seel 2023) is the best-tested open IMU orientation filter; its offline mode
runs forward and backward for bias estimation. We use it instead of an AHRS of our own.
Its quaternions are (w, x, y, z) rotating the sensor frame into a z-up earth frame whose
heading is that of the first samples, which is what a heading reset gives.
"""

from __future__ import annotations

import numpy as np


def estimate_orientation(gyr: np.ndarray, acc: np.ndarray, mag: np.ndarray | None,
                         rate_hz: float) -> np.ndarray:
    """(N, 4) quaternions B -> W; rows where gyro or accelerometer is missing stay NaN."""
    from vqf import offlineVQF

    ok = np.isfinite(gyr).all(axis=1) & np.isfinite(acc).all(axis=1)
    use_mag = mag is not None and np.isfinite(mag[ok]).all() and np.abs(mag[ok]).sum() > 0
    out = np.full((gyr.shape[0], 4), np.nan)
    if ok.sum() < 2:
        return out
    g = np.ascontiguousarray(gyr[ok], dtype=float)
    a = np.ascontiguousarray(acc[ok], dtype=float)
    m = np.ascontiguousarray(mag[ok], dtype=float) if use_mag else None
    res = offlineVQF(g, a, m, 1.0 / rate_hz, None)
    out[ok] = res["quat9D"] if use_mag else res["quat6D"]
    return out
