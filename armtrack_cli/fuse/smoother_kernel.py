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
(n, d, d) array. ``filter_block`` and ``rts_block`` are the same two passes a block of frames
at a time, for the checkpointed form whose memory does not grow with the session
(fuse/smoother_blocks.py).
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
def _filter_step(x, P, F, b, Q, Hc, zc, use_c, rc, Hk, zk, use_k, rk, gate, predict):
    """(x, P, gated) of one frame: predict through (F, b, Q) unless ``predict`` is False (the
    session's first frame), then the gated camera pair and the arm row."""
    gated = False
    if predict:
        x = F @ x + b
        P = F @ P @ F.T + Q
    if use_c:
        if _gate(x, P, Hc, zc, rc) > gate:
            gated = True
        else:
            _scalar_update(x, P, Hc[0], zc[0], rc)
            _scalar_update(x, P, Hc[1], zc[1], rc)
    if use_k:
        _scalar_update(x, P, Hk, zk, rk)
    return x, 0.5 * (P + P.T), gated


@njit(cache=True)
def _rts_step(x, P, F, b, Q, xs, Ps):
    """Rauch, Tung & Striebel (1965), frame k from frame k+1: gain = P Fᵀ (P⁻)⁻¹,
    x^s = x + gain (x^s_{k+1} − x⁻), P^s = P + gain (P^s_{k+1} − P⁻) gainᵀ; (F, b, Q) the step
    into frame k+1, (x, P) frame k's filtered state, (xs, Ps) frame k+1's smoothed one."""
    xp = F @ x + b
    FP = F @ P
    Pp = FP @ F.T + Q
    gain = np.linalg.solve(Pp, FP).T  # Pp symmetric: (Pp⁻¹ F P)ᵀ = P Fᵀ Pp⁻¹
    Pn = P + gain @ (Ps - Pp) @ gain.T
    return x + gain @ (xs - xp), 0.5 * (Pn + Pn.T)


@njit(cache=True)
def smooth(x0, P0, F, b, Q, Hc, zc, use_c, rc, Hk, zk, use_k, rk, gate):
    """(xs (n, d), Ps (n, d, d), gated (n,) bool): the smoothed means and covariances."""
    n, d = F.shape[0], x0.size
    xf = np.empty((n, d))
    Pf = np.empty((n, d, d))
    gated = np.zeros(n, np.bool_)
    x, P = x0.copy(), P0.copy()
    for k in range(n):
        x, P, gated[k] = _filter_step(x, P, F[k], b[k], Q[k], Hc[k], zc[k], use_c[k], rc,
                                      Hk[k], zk[k], use_k[k], rk, gate, k > 0)
        xf[k] = x
        Pf[k] = P
    for k in range(n - 2, -1, -1):  # backwards, the smoothed overwriting the filtered
        xf[k], Pf[k] = _rts_step(xf[k], Pf[k], F[k + 1], b[k + 1], Q[k + 1], xf[k + 1], Pf[k + 1])
    return xf, Pf, gated


@njit(cache=True)
def filter_block(x0, P0, F, b, Q, Hc, zc, use_c, rc, Hk, zk, use_k, rk, gate, first, m,
                 xf, Pf, gated):
    """The forward filter over the first m rows of a block of frames (row j: frame lo + j, F[j]
    the step into it), from (x0, P0): frame lo − 1's filtered state, or, with ``first``, the
    session's prior. Writes the filtered states into xf (≥ m, d), Pf (≥ m, d, d) and the gate's
    decisions into gated (≥ m,); returns the last frame's (x, P)."""
    x, P = x0.copy(), P0.copy()
    for j in range(m):
        x, P, gated[j] = _filter_step(x, P, F[j], b[j], Q[j], Hc[j], zc[j], use_c[j], rc,
                                      Hk[j], zk[j], use_k[j], rk, gate, j > 0 or not first)
        xf[j] = x
        Pf[j] = P
    return x, P


@njit(cache=True)
def rts_block(xf, Pf, m, F, b, Q, xs_next, Ps_next, last):
    """Smooth a block's m filtered states (xf, Pf, overwritten) backwards; unless ``last`` (the
    block ends the session) from the next frame's smoothed state (xs_next, Ps_next) through
    the step into it, row m of (F, b, Q)."""
    if not last:
        xf[m - 1], Pf[m - 1] = _rts_step(xf[m - 1], Pf[m - 1], F[m], b[m], Q[m], xs_next, Ps_next)
    for k in range(m - 2, -1, -1):
        xf[k], Pf[k] = _rts_step(xf[k], Pf[k], F[k + 1], b[k + 1], Q[k + 1], xf[k + 1], Pf[k + 1])
