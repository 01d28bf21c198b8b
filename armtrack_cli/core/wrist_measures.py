"""Peak and mean angular speed of each wrist angle (Cordella et al. IV-A), for estimates and
ground truth alike: the one measure of issue 11 that the measures package (CATALOGUE) does not
hold yet; one function, for the measures package to take over.

Angles are low-pass filtered first (4th-order zero-phase Butterworth, 6 Hz, Winter) so
frame-to-frame estimation noise does not add speed the hand never had; speeds are central
differences within each run of valid samples.
"""

from __future__ import annotations

import numpy as np

from armtrack_cli.core.butter import zero_phase
from armtrack_cli.core.wrist import ANGLES

CUTOFF_HZ = 6.0
UNIT = "deg/s (low-passed at 6 Hz)"


def lowpass(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """(N,) x low-passed at 6 Hz, each run of finite samples on its own (short runs kept)."""
    fs = 1.0 / np.median(np.diff(t)) if t.size > 1 else 1.0
    out = x.copy()
    if CUTOFF_HZ >= 0.45 * fs:
        return out
    edges = np.flatnonzero(np.diff(np.r_[0, np.isfinite(x).astype(int), 0]))
    for a, b in zip(edges[::2], edges[1::2]):
        if b - a > 27:  # sosfiltfilt's padding needs 3 × (2 × order + 1) samples
            out[a:b] = next(zero_phase(x[None, a:b], fs, [CUTOFF_HZ]))[0]  # = scipy's sosfiltfilt
    return out


def _speed(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """|dx/dt| of (N,) x after the low-pass, within each run of finite samples; NaN at gaps."""
    v = np.full(x.shape, np.nan)
    y = lowpass(t, x)
    edges = np.flatnonzero(np.diff(np.r_[0, np.isfinite(x).astype(int), 0]))
    for a, b in zip(edges[::2], edges[1::2]):
        if b - a >= 3:
            v[a:b] = np.gradient(y[a:b], t[a:b])
    return np.abs(v)


def angular_speeds(t: np.ndarray, angles_deg: np.ndarray) -> list[tuple[str, float, str]]:
    """(measure, value, unit): wrist_{flexion,deviation,pronation}_{peak,mean}_speed."""
    rows = []
    for k, name in enumerate(ANGLES):
        sp = _speed(t, angles_deg[:, k])
        sp = sp[np.isfinite(sp)]
        rows += [(f"wrist_{name}_peak_speed", float(sp.max()) if sp.size else float("nan"), UNIT),
                 (f"wrist_{name}_mean_speed", float(sp.mean()) if sp.size else float("nan"), UNIT)]
    return rows
