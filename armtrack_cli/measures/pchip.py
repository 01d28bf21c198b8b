"""Shape-preserving piecewise cubic Hermite interpolation (PCHIP: Fritsch & Carlson 1980, SIAM
J. Numer. Anal. 17: 238; slopes by the weighted harmonic mean of Fritsch & Butland 1984, the
ends by the three-point formula of Moler, Numerical Computing with MATLAB §3.4), in numpy
alone: scipy.interpolate.PchipInterpolator(x, y, axis=0)(xi) with the same operations in the
same order (tests/test_pchip.py), without importing scipy.interpolate (half a second)."""

from __future__ import annotations

import numpy as np


def _edge(h0, h1, m0, m1):
    d = ((2 * h0 + h1) * m0 - h0 * m1) / (h0 + h1)  # one-sided three-point estimate
    mask = np.sign(d) != np.sign(m0)
    mask2 = (np.sign(m0) != np.sign(m1)) & (np.abs(d) > 3.0 * np.abs(m0))
    mmm = (~mask) & mask2
    d[mask] = 0.0
    d[mmm] = 3.0 * m0[mmm]
    return d


def slopes(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(N, d) dy/dx at the knots x (N,) (increasing) of y (N, d)."""
    hk = (x[1:] - x[:-1])[:, None]
    mk = (y[1:] - y[:-1]) / hk
    if y.shape[0] == 2:
        return np.stack([mk[0], mk[0]])
    smk = np.sign(mk)
    flat = (smk[1:] != smk[:-1]) | (mk[1:] == 0) | (mk[:-1] == 0)  # a turn: slope 0
    w1 = 2 * hk[1:] + hk[:-1]
    w2 = hk[1:] + 2 * hk[:-1]
    dk = np.empty_like(y)
    with np.errstate(divide="ignore", invalid="ignore"):
        whmean = (w1 / mk[:-1] + w2 / mk[1:]) / (w1 + w2)
        dk[1:-1] = np.where(flat, 0.0, 1.0 / whmean)  # (no boolean gathers: ~2× faster)
    dk[0] = _edge(hk[0], hk[1], mk[0], mk[1])
    dk[-1] = _edge(hk[-1], hk[-2], mk[-1], mk[-2])
    return dk


def pchip(x: np.ndarray, y: np.ndarray, xi: np.ndarray) -> np.ndarray:
    """y (N, d) at knots x (N,) (increasing, N ≥ 2), interpolated at xi (M,) -> (M, d);
    beyond the knots the end pieces extend."""
    y = np.asarray(y, float)
    dydx = slopes(x, y)
    dx = np.diff(x)[:, None]
    slope = np.diff(y, axis=0) / dx
    t = (dydx[:-1] + dydx[1:] - 2 * slope) / dx
    c0, c1, c2, c3 = t / dx, (slope - dydx[:-1]) / dx - t, dydx[:-1], y[:-1]
    i = np.clip(np.searchsorted(x, xi, side="right") - 1, 0, x.size - 2)
    s = (xi - x[i])[:, None]
    res = c3.take(i, axis=0)  # Σ c_k s^(3−k), accumulated as scipy's PPoly evaluates it
    z = s  #                    (from c3 · 1.0: the same bits)
    res += c2.take(i, axis=0) * z
    z = z * s
    res += c1.take(i, axis=0) * z
    z = z * s
    res += c0.take(i, axis=0) * z
    return res
