"""Small curve tools in numpy, each as scipy computes it (tests/test_imu_sync.py holds them to
scipy), so that fuse's clock-offset check (fuse/imu_sync.py) imports neither scipy.signal nor
scipy.interpolate (with scipy.optimize and scipy.special behind it: over a second, issue 15)."""

from __future__ import annotations

import math

import numpy as np


def savgol_coeffs(window: int, deriv: int, dt: float) -> np.ndarray:
    """The weights (window,) of a cubic Savitzky–Golay filter's ``deriv``-th derivative at the
    window's centre, applied as a dot product with the samples in order (scipy.signal's
    savgol_coeffs(window, 3, deriv, delta=dt, use="dot"), without importing scipy.signal, over
    a second), as scipy finds them: the minimum-norm c with Σ_i c_i x_i^k = deriv! / dt^deriv
    for k = deriv and 0 for the other powers k ≤ 3, x_i the window's offsets (Savitzky &
    Golay 1964)."""
    h = window // 2
    A = np.arange(-h, window - h, dtype=float) ** np.arange(4)[:, None]  # (4, window)
    y = np.zeros(4)
    y[deriv] = math.factorial(deriv) / dt**deriv
    return np.linalg.lstsq(A, y, rcond=None)[0]


def hermite(t: np.ndarray, y: np.ndarray, dydt: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The cubic Hermite curve through (t (M,), y (M, d)) with slopes dydt (M, d), at x (n,)
    (scipy's CubicHermiteSpline(t, y, dydt)(x), extrapolated from the end intervals, without
    its (4, M − 1, d) coefficient table): with s = x − t_j in interval j of width h and the
    secant slope m = (y_{j+1} − y_j)/h, y_j + s (y'_j + s (c2 + s c3)), c2 = (3m − 2y'_j −
    y'_{j+1})/h, c3 = (y'_j + y'_{j+1} − 2m)/h², each in scipy's order of operations."""
    j = np.clip(np.searchsorted(t, x, side="right") - 1, 0, t.size - 2)
    h = (t[j + 1] - t[j])[:, None]
    m = (y[j + 1] - y[j]) / h
    d0, d1 = dydt[j], dydt[j + 1]
    c3 = (d0 + d1 - 2 * m) / h  # scipy's t, then c3 = t / h and c2 = (m − y'_j)/h − t
    c2 = (m - d0) / h - c3
    c3 /= h
    s = (x - t[j])[:, None]
    return ((c3 * s + c2) * s + d0) * s + y[j]


def bspline_rows(x: np.ndarray, t: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The B-spline basis of degree k on knots t (sorted, k-fold ends) at x (n,) inside
    [t[k], t[-k-1]]: (start (n,) int, w (n, k + 1)), row i being the values of basis functions
    start[i] … start[i] + k (scipy's BSpline.design_matrix(x, t, k), its k + 1 non-zeros a
    row). Cox–de Boor's recursion (de Boor, A Practical Guide to Splines, 1978, ch. X) on all
    points at once, in scipy's order of operations; x on the last knot falls in the last
    interval."""
    n_basis = t.size - k - 1
    ell = np.clip(np.searchsorted(t, x, side="right") - 1, k, n_basis - 1)  # t[ell] <= x
    h = np.zeros((x.size, k + 1))
    h[:, 0] = 1.0
    for j in range(1, k + 1):
        hh = h[:, :j].copy()
        h[:, 0] = 0.0
        for m in range(1, j + 1):
            xb, xa = t[ell + m], t[ell + m - j]
            same = xb == xa
            w = np.where(same, 0.0, hh[:, m - 1] / np.where(same, 1.0, xb - xa))
            h[:, m - 1] += w * (xb - x)
            h[:, m] = w * (x - xa)
    return (ell - k).astype(np.int64), h
