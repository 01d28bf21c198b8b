"""Smoothness of a speed profile: movement units, SPARC and log dimensionless jerk."""

from __future__ import annotations

import numpy as np

from armtrack_cli.measures.base import DEFAULT, NotComputable, Settings
from armtrack_cli.measures.peaks import find_peaks


def _check(v: np.ndarray, fs: float) -> np.ndarray:
    v = np.asarray(v, float)
    if v.size < 10 or not np.isfinite(v).all():
        raise NotComputable("fewer than 10 finite speed samples")
    if np.max(np.abs(v)) == 0 or np.ptp(v) == 0:
        raise NotComputable("the speed is constant")
    if fs <= 0:
        raise NotComputable("no sampling rate")
    return v


def sparc(v: np.ndarray, fs: float, s: Settings = DEFAULT) -> float:
    """Spectral arc length (Balasubramanian, Melendez-Calderon & Burdet 2012, IEEE TBME 59:
    2126; SPARC as revised in Balasubramanian et al. 2015, J NeuroEng Rehabil 12: 112)."""
    v = _check(v, fs)
    nfft = int(2 ** (np.ceil(np.log2(v.size)) + s.sparc_pad))  # zero padding
    if s.sparc_fc_hz < fs / 2:  # a real signal's spectrum: the bins up to Nyquist say it all
        mag = np.abs(np.fft.rfft(v, nfft))
    else:
        mag = np.abs(np.fft.fft(v, nfft))
    mag = mag / mag.max()  # normalised magnitude spectrum
    f = np.arange(mag.size) * fs / nfft
    sel = f <= s.sparc_fc_hz
    f, mag = f[sel], mag[sel]
    keep = np.flatnonzero(mag >= s.sparc_amp_th)  # adaptive cut-off: last point above 0.05
    f, mag = f[keep[0]:keep[-1] + 1], mag[keep[0]:keep[-1] + 1]
    if f.size < 2:
        raise NotComputable("the spectrum has a single point above the amplitude threshold")
    df = np.diff(f) / (f[-1] - f[0])
    return float(-np.sum(np.sqrt(df**2 + np.diff(mag) ** 2)))  # eq. (2) of the 2015 paper


def ldlj(v: np.ndarray, fs: float) -> float:
    """Log dimensionless jerk of a speed profile, the speed form of Balasubramanian et al.
    2015: −ln( T³ / v_peak² · ∫ (d²v/dt²)² dt ), T = N / fs, jerk by second differences and
    the integral by a sum, as in their published code."""
    v = _check(v, fs)
    dt = 1.0 / fs
    T = v.size * dt
    jerk = np.diff(v, 2) / dt**2
    dlj = T**3 / np.max(np.abs(v)) ** 2 * np.sum(jerk**2) * dt
    if dlj <= 0:
        raise NotComputable("the speed has no jerk (a straight line)")
    return float(-np.log(dlj))


def movement_units(t: np.ndarray, v: np.ndarray, s: Settings = DEFAULT) -> tuple[int, np.ndarray]:
    """(count, indices of the counted peaks): a unit is a rise of more than s.mu_rise from a
    local minimum to the next maximum, peaks at least s.mu_min_gap_s apart (Alt Murphy,
    Willén & Sunnerhagen 2011, Gait Posture 33: 8-13). The rise is read as the peak's
    prominence (its height above the higher of the minima on either side, scipy's definition),
    so a ripple on a rising flank, which the speed soon exceeds, is not a unit."""
    v = _check(v, 1.0)
    dist = max(1, int(np.ceil(s.mu_min_gap_s / np.median(np.diff(t)) - 1e-9)))
    peaks = find_peaks(v, prominence=s.mu_rise, distance=dist)  # scipy's rules: measures/peaks.py
    return int(peaks.size), peaks
