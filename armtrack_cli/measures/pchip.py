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


def slopes(x: np.ndarray, y: np.ndarray, k0: int = 0, k1: int | None = None) -> np.ndarray:
    """(k1 − k0, d) dy/dx at the knots k0 … k1 − 1 (default: all) of x (N,) (increasing) and
    y (N, d): each from its neighbouring knots alone (the ends from the first or last three),
    so a range's slopes are those of the whole, from a window of it."""
    n = x.shape[0]
    k1 = n if k1 is None else k1
    if n == 2:
        mk = (y[1:] - y[:-1]) / (x[1:] - x[:-1])[:, None]
        return np.stack([mk[0], mk[0]])[k0:k1]
    w0, w1 = max(k0 - 1, 0), min(k1 + 1, n)  # the knots the range's slopes look at
    w0, w1 = min(w0, n - 3), max(w1, 3)  # an end's slope: its first three
    x, y = x[w0:w1], y[w0:w1]
    hk = (x[1:] - x[:-1])[:, None]
    mk = (y[1:] - y[:-1]) / hk
    smk = np.sign(mk)
    flat = (smk[1:] != smk[:-1]) | (mk[1:] == 0) | (mk[:-1] == 0)  # a turn: slope 0
    w1_ = 2 * hk[1:] + hk[:-1]
    w2_ = hk[1:] + 2 * hk[:-1]
    dk = np.empty_like(y)
    with np.errstate(divide="ignore", invalid="ignore"):
        whmean = (w1_ / mk[:-1] + w2_ / mk[1:]) / (w1_ + w2_)
        dk[1:-1] = np.where(flat, 0.0, 1.0 / whmean)  # (no boolean gathers: ~2× faster)
    if w0 == 0:
        dk[0] = _edge(hk[0], hk[1], mk[0], mk[1])
    if w1 == n:
        dk[-1] = _edge(hk[-1], hk[-2], mk[-1], mk[-2])
    return dk[k0 - w0:k1 - w0]


BLOCK = 1 << 14  # points evaluated at once: the temporaries of a block, not of the session
#                  (a 60-minute trajectory's were ~30 MB at once)


def pchip(x: np.ndarray, y: np.ndarray, xi: np.ndarray, block: int = BLOCK) -> np.ndarray:
    """y (N, d) at knots x (N,) (increasing, N ≥ 2), interpolated at xi (M,) -> (M, d);
    beyond the knots the end pieces extend. A block of points at a time, each from the
    slopes and pieces of the intervals it falls in (the same numbers as all at once)."""
    y = np.asarray(y, float)
    i = np.clip(np.searchsorted(x, xi, side="right") - 1, 0, x.size - 2)
    out = np.empty((xi.size, *y.shape[1:]))
    for lo in range(0, xi.size, block):
        ib = i[lo:lo + block]
        a, b = int(ib.min()), int(ib.max()) + 1  # the intervals a … b − 1: knots a … b
        out[lo:lo + block] = _pieces(x[a:b + 1], y[a:b + 1], slopes(x, y, a, b + 1),
                                     xi[lo:lo + block], ib - a)
    return out


def _pieces(x, y, dydx, xi, i):
    """The cubic pieces on the intervals of knots x, y with slopes dydx, at xi in interval i."""
    dx = np.diff(x)[:, None]
    slope = np.diff(y, axis=0) / dx
    t = (dydx[:-1] + dydx[1:] - 2 * slope) / dx
    c0, c1, c2, c3 = t / dx, (slope - dydx[:-1]) / dx - t, dydx[:-1], y[:-1]
    s = (xi - x[i])[:, None]
    res = c3.take(i, axis=0)  # Σ c_k s^(3−k), accumulated as scipy's PPoly evaluates it
    z = s  #                    (from c3 · 1.0: the same bits)
    res += c2.take(i, axis=0) * z
    z = z * s
    res += c1.take(i, axis=0) * z
    z = z * s
    res += c0.take(i, axis=0) * z
    return res
