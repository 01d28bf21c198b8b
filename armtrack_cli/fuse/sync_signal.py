"""The IMU clock-offset fit's signals (fuse/imu_sync.py): a cubic Savitzky–Golay smoothing or
derivative along time, stopping at the ends of a problem's stretches (a check's windows,
fuse/sync_windows.py), and lost detections bridged for the derivative."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from armtrack_cli.core.curves import savgol_coeffs


def stretches(cuts: tuple[int, ...], n: int) -> list[tuple[int, int]]:
    """(start, end) of the stretches that ``cuts`` (interior starts) make of 0 … n − 1."""
    edges = [0, *cuts, n]
    return list(zip(edges[:-1], edges[1:]))


def joined(parts: list[np.ndarray]) -> np.ndarray:
    """The stretches' arrays end to end (one stretch's as it is: no copy)."""
    return parts[0] if len(parts) == 1 else np.concatenate(parts)


@lru_cache(maxsize=8)
def _coeffs(window: int, deriv: int, dt: float) -> np.ndarray:
    """savgol_coeffs, once per (window, deriv, dt): every δ's columns use the same (read only)."""
    return savgol_coeffs(window, deriv, dt)


def savgol(x: np.ndarray, window: int, deriv: int, dt: float) -> np.ndarray:
    """Cubic Savitzky–Golay along axis 0 (odd ``window``); NaN wherever the window holds a NaN
    or runs off either end."""
    c = _coeffs(window, deriv, dt)
    h = window // 2
    out = np.full(x.shape, np.nan)
    if x.shape[0] < window:
        return out
    m = x.shape[0] - 2 * h
    acc = out[h:h + m]  # Σ_j c_j x[k − h + j], on views (a NaN in the window stays NaN)
    acc[...] = c[0] * x[:m]
    for j in range(1, window):
        acc += c[j] * x[j:j + m]
    return out


def savgol_cut(x: np.ndarray, cuts: tuple[int, ...], window: int, deriv: int, dt: float
               ) -> np.ndarray:
    """savgol on each stretch of x that ``cuts`` make, as if each were all there is."""
    return joined([savgol(x[a:b], window, deriv, dt) for a, b in stretches(cuts, x.shape[0])])


def bridge(x: np.ndarray, most: int) -> np.ndarray:
    """x (n, d) with runs of at most ``most`` missing rows between two present ones filled
    linearly (for the derivative only: a lost frame or two must not void a whole window);
    longer runs stay missing."""
    ok = np.isfinite(x).all(axis=1)
    idx = np.flatnonzero(ok)
    out = x.copy()
    if idx.size < 2:
        return out
    i = np.arange(x.shape[0])
    nxt = np.clip(np.searchsorted(idx, i), 0, idx.size - 1)
    prv = np.clip(nxt - 1, 0, idx.size - 1)
    fill = ~ok & (i > idx[0]) & (i < idx[-1]) & (idx[nxt] - idx[prv] - 1 <= most)
    for a in range(x.shape[1]):
        out[fill, a] = np.interp(i[fill], idx, x[idx, a])
    return out
