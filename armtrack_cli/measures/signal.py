"""Signals ready for measuring: one uniform clock, short gaps bridged, low-passed, speed."""

from __future__ import annotations

import numpy as np

from armtrack_cli.core.butter import lowpass_columns
from armtrack_cli.measures.base import NotComputable, Settings
from armtrack_cli.measures.pchip import pchip
from armtrack_cli.measures.vec3 import norm3


def longest_gap_s(t: np.ndarray, ok: np.ndarray) -> float:
    """Longest interior stretch of time without a finite sample (between finite ones)."""
    tt = t[ok]
    return float(np.max(np.diff(tt))) if tt.size > 1 else float("inf")


def uniform(t: np.ndarray, x: np.ndarray, s: Settings, what: str) -> tuple[np.ndarray, np.ndarray]:
    """(t_u, x_u): x (N, d) on a uniform clock at the median sampling interval, from the first
    to the last finite sample; interior gaps up to s.max_gap_s bridged by PCHIP (shape-
    preserving cubic, no overshoot). A longer gap, or too few samples, raises NotComputable."""
    x = np.asarray(x, float).reshape(len(t), -1)
    ok = np.isfinite(x).all(axis=1) & np.isfinite(t)
    if ok.sum() < 10:
        raise NotComputable(f"fewer than 10 samples of the {what}")
    gap = longest_gap_s(t, ok) - np.median(np.diff(t[ok]))
    if gap > s.max_gap_s:
        raise NotComputable(f"a {gap:.2f} s gap in the {what} (longest bridged: {s.max_gap_s} s)")
    tt, xx = t[ok], x[ok]
    dt = float(np.median(np.diff(tt)))
    n = int(np.floor((tt[-1] - tt[0]) / dt + 1e-6)) + 1
    t_u = tt[0] + dt * np.arange(n)
    return t_u, pchip(tt, xx, t_u)  # scipy's PchipInterpolator, in numpy


def lowpass(x: np.ndarray, fs: float, fc: float) -> np.ndarray:
    """4th-order zero-phase Butterworth low-pass of (N, d) samples (Winter, Biomechanics and
    Motor Control of Human Movement, 2009: 6 Hz for arm kinematics); unchanged when fc is
    near Nyquist or the record too short to pad."""
    if fc >= 0.45 * fs or len(x) <= 27:  # sosfiltfilt pads 3 × (2 × order + 1) samples
        return x
    return lowpass_columns(x, fs, fc)  # scipy's sosfiltfilt(butter(4, …)), in numpy


def speed_profile(t: np.ndarray, xyz: np.ndarray, s: Settings,
                  what: str = "wrist trajectory") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t_u, p_u, v): positions on a uniform clock, low-passed, and their speed |dp/dt|
    (central differences), m/s."""
    t_u, p = uniform(t, xyz, s, what)
    fs = 1.0 / (t_u[1] - t_u[0])
    p = lowpass(p, fs, s.lowpass_hz)
    v = norm3(np.gradient(p, t_u, axis=0))
    return t_u, p, v
