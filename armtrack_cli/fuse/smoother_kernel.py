"""One pass of the linearised smoother: a Kalman filter forward and a Rauch–Tung–Striebel pass
back over a linear, time-varying model, compiled with numba (``smooth``); ``smooth.py_func``
is the same code run by Python, the reference the tests hold it to.

Model, for frames k = 0 … n−1 (symbols as filters/gaussian.py; d the state size):
  x_0 ~ N(x0, P0);  x_k = F_k x_{k−1} + b_k + w_k,  w_k ~ N(0, Q_k)  (k ≥ 1);
  camera rows  zc_k = Hc_k x_k + e,  e ~ N(0, rc I₂)  where use_c[k];
  one more row zk_k = Hk_k x_k + e,  e ~ N(0, rk)     where use_k[k].
A camera pair whose innovation y = zc − Hc x⁻ has y ᵀ S⁻¹ y > gate, S = Hc P⁻ Hcᵀ + rc I, is not
used (``gated[k]``). Rows are applied one at a time (for independent rows this equals the
joint update). Smoothed covariances overwrite the filtered ones to keep memory at one
(n, d, d) array.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _scalar_update(x, P, h, z, r):
    """Kalman update by one scalar row: s = h P hᵀ + r, gain = P hᵀ / s."""
    Ph = P @ h
    s = h @ Ph + r
    gain = Ph / s
    x += gain * (z - h @ x)
    P -= np.outer(gain, Ph)


@njit(cache=True)
def _gate(x, P, H, z, r):
    """Mahalanobis² of the 2-row innovation z − H x with S = H P Hᵀ + r I."""
    y0 = z[0] - H[0] @ x
    y1 = z[1] - H[1] @ x
    PH0, PH1 = P @ H[0], P @ H[1]
    s00, s01, s11 = H[0] @ PH0 + r, H[0] @ PH1, H[1] @ PH1 + r
    det = s00 * s11 - s01 * s01
    return (s11 * y0 * y0 - 2 * s01 * y0 * y1 + s00 * y1 * y1) / det


@njit(cache=True)
def smooth(x0, P0, F, b, Q, Hc, zc, use_c, rc, Hk, zk, use_k, rk, gate):
    """(xs (n, d), Ps (n, d, d), gated (n,) bool): the smoothed means and covariances."""
    n, d = F.shape[0], x0.size
    xf = np.empty((n, d))
    Pf = np.empty((n, d, d))
    gated = np.zeros(n, np.bool_)
    x, P = x0.copy(), P0.copy()
    for k in range(n):
        if k > 0:
            x = F[k] @ x + b[k]
            P = F[k] @ P @ F[k].T + Q[k]
        if use_c[k]:
            if _gate(x, P, Hc[k], zc[k], rc) > gate:
                gated[k] = True
            else:
                _scalar_update(x, P, Hc[k, 0], zc[k, 0], rc)
                _scalar_update(x, P, Hc[k, 1], zc[k, 1], rc)
        if use_k[k]:
            _scalar_update(x, P, Hk[k], zk[k], rk)
        P = 0.5 * (P + P.T)
        xf[k] = x
        Pf[k] = P
    # backwards (Rauch, Tung & Striebel 1965): gain_k = P_k F_{k+1}ᵀ (P⁻_{k+1})⁻¹,
    # x^s_k = x_k + gain_k (x^s_{k+1} − x⁻_{k+1}), P^s_k = P_k + gain_k (P^s_{k+1} − P⁻_{k+1}) gain_kᵀ
    for k in range(n - 2, -1, -1):
        Fn = F[k + 1]
        xp = Fn @ xf[k] + b[k + 1]
        FP = Fn @ Pf[k]
        Pp = FP @ Fn.T + Q[k + 1]
        gain = np.linalg.solve(Pp, FP).T  # Pp symmetric: (Pp⁻¹ F P)ᵀ = P Fᵀ Pp⁻¹
        xf[k] = xf[k] + gain @ (xf[k + 1] - xp)
        Ps = Pf[k] + gain @ (Pf[k + 1] - Pp) @ gain.T
        Pf[k] = 0.5 * (Ps + Ps.T)
    return xf, Pf, gated
