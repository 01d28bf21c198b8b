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

The passes run on work arrays made once per call (``_Work``): each frame's predict, updates and
RTS step write in place, in loops over the d × d entries, so the inner loop allocates nothing
(issue 15: a third of the time went to numba's small temporaries). ``_filter_step`` and
``_rts_step`` keep the same arithmetic in matrix form, the reference the tests hold the passes
to (and ``smooth.py_func`` runs it all in Python).
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
def _work(d):
    """Work arrays of one pass: (vector, vector, matrix, matrix, matrix, pivots, F's non-zero
    columns row by row, their counts)."""
    return (np.empty(d), np.empty(d), np.empty((d, d)), np.empty((d, d)), np.empty((d, d)),
            np.empty(d, np.int64), np.empty((d, d), np.int64), np.empty(d, np.int64))


@njit(cache=True)
def _pattern(F, nz, cnt):
    """Row i of F's non-zero columns, in order, into nz[i, :cnt[i]] (the model's F is the
    identity plus a few 3 × 3 blocks: a product skipping its zeros adds the same non-zero
    terms in the same order, so its result is the dense loop's)."""
    d = F.shape[0]
    for i in range(d):
        c = 0
        for k in range(d):
            if F[i, k] != 0.0:
                nz[i, c] = k
                c += 1
        cnt[i] = c


@njit(cache=True)
def _f_products(F, P, Q, FP, out, nz, cnt):
    """FP ← F P and out ← F P Fᵀ + Q, over F's non-zeros (_pattern)."""
    d = F.shape[0]
    _pattern(F, nz, cnt)
    for i in range(d):
        for j in range(d):
            FP[i, j] = 0.0
        for c in range(cnt[i]):
            k = nz[i, c]
            a = F[i, k]
            for j in range(d):
                FP[i, j] += a * P[k, j]
    for i in range(d):
        for j in range(d):
            acc = 0.0
            for c in range(cnt[j]):
                k = nz[j, c]
                acc += FP[i, k] * F[j, k]
            out[i, j] = acc + Q[i, j]


@njit(cache=True)
def _dot(h, x):
    acc = 0.0
    for i in range(h.size):
        acc += h[i] * x[i]
    return acc


@njit(cache=True)
def _mat_vec(P, h, out):
    """out = P h."""
    d = h.size
    for i in range(d):
        acc = 0.0
        for j in range(d):
            acc += P[i, j] * h[j]
        out[i] = acc


@njit(cache=True)
def _predict_into(x, P, F, b, Q, w):
    """x ← F x + b, P ← F P Fᵀ + Q in place (w: _work)."""
    v, FP = w[0], w[2]
    d = x.size
    _mat_vec(F, x, v)
    for i in range(d):
        x[i] = v[i] + b[i]
    _f_products(F, P, Q, FP, P, w[6], w[7])  # F P is done before P is overwritten


@njit(cache=True)
def _update_into(x, P, h, z, r, Ph):
    """_scalar_update in place with Ph (d,) as its work array."""
    _mat_vec(P, h, Ph)
    s = _dot(h, Ph) + r
    innov = z - _dot(h, x)
    d = x.size
    for i in range(d):
        x[i] += Ph[i] / s * innov
    for i in range(d):
        g = Ph[i] / s
        for j in range(d):
            P[i, j] -= g * Ph[j]


@njit(cache=True)
def _gate_into(x, P, H, z, r, w):
    """_gate with w's two vectors as its work arrays."""
    PH0, PH1 = w[0], w[1]
    y0 = z[0] - _dot(H[0], x)
    y1 = z[1] - _dot(H[1], x)
    _mat_vec(P, H[0], PH0)
    _mat_vec(P, H[1], PH1)
    s00, s01, s11 = _dot(H[0], PH0) + r, _dot(H[0], PH1), _dot(H[1], PH1) + r
    det = s00 * s11 - s01 * s01
    return (s11 * y0 * y0 - 2 * s01 * y0 * y1 + s00 * y1 * y1) / det


@njit(cache=True)
def _symmetrise(P):
    d = P.shape[0]
    for i in range(d):
        for j in range(i + 1, d):
            m = 0.5 * (P[i, j] + P[j, i])
            P[i, j] = m
            P[j, i] = m


@njit(cache=True)
def _step_into(x, P, F, b, Q, Hc, zc, use_c, rc, Hk, zk, use_k, rk, gate, predict, w):
    """_filter_step in place on (x, P); returns gated."""
    gated = False
    if predict:
        _predict_into(x, P, F, b, Q, w)
    if use_c:
        if _gate_into(x, P, Hc, zc, rc, w) > gate:
            gated = True
        else:
            _update_into(x, P, Hc[0], zc[0], rc, w[0])
            _update_into(x, P, Hc[1], zc[1], rc, w[0])
    if use_k:
        _update_into(x, P, Hk, zk, rk, w[0])
    _symmetrise(P)
    return gated


@njit(cache=True)
def _solve_into(A, B, piv):
    """B ← A⁻¹ B by LU with partial pivoting (LAPACK's gesv), A overwritten by its factors."""
    d = A.shape[0]
    for c in range(d):
        p = c
        for i in range(c + 1, d):
            if abs(A[i, c]) > abs(A[p, c]):
                p = i
        piv[c] = p
        if p != c:
            for j in range(d):
                A[c, j], A[p, j] = A[p, j], A[c, j]
                B[c, j], B[p, j] = B[p, j], B[c, j]
        for i in range(c + 1, d):
            f = A[i, c] / A[c, c]
            A[i, c] = f
            for j in range(c + 1, d):
                A[i, j] -= f * A[c, j]
            for j in range(B.shape[1]):
                B[i, j] -= f * B[c, j]
    for c in range(d - 1, -1, -1):  # row by row, the columns innermost (contiguous)
        for k in range(c + 1, d):
            a = A[c, k]
            for j in range(B.shape[1]):
                B[c, j] -= a * B[k, j]
        for j in range(B.shape[1]):
            B[c, j] /= A[c, c]


@njit(cache=True)
def _rts_into(x, P, F, b, Q, xs, Ps, w):
    """_rts_step in place on frame k's (x, P) (w: _work)."""
    v, dx, FP, Pp, G, piv = w[0], w[1], w[2], w[3], w[4], w[5]
    d = x.size
    _mat_vec(F, x, v)
    for i in range(d):
        dx[i] = xs[i] - (v[i] + b[i])  # x^s_{k+1} − x⁻
    _f_products(F, P, Q, FP, Pp, w[6], w[7])
    for i in range(d):  # P^s_{k+1} − P⁻, before the solve overwrites P⁻
        for j in range(d):
            G[i, j] = Ps[i, j] - Pp[i, j]
    _solve_into(Pp, FP, piv)  # FP ← (P⁻)⁻¹ F P = gainᵀ
    for i in range(d):  # x^s = x + gain (x^s_{k+1} − x⁻)
        acc = 0.0
        for k in range(d):
            acc += FP[k, i] * dx[k]
        x[i] += acc
    # P^s = P + gain (P^s_{k+1} − P⁻) gainᵀ: gain (P^s_{k+1} − P⁻) into Pp, then its rows
    # times gainᵀ (= FP) added to P's; each product row by row with the columns innermost
    # (contiguous, so the compiler runs several columns at once)
    for i in range(d):
        for j in range(d):
            Pp[i, j] = 0.0
        for k in range(d):
            a = FP[k, i]
            for j in range(d):
                Pp[i, j] += a * G[k, j]
    for i in range(d):
        for j in range(d):
            v[j] = 0.0
        for k in range(d):
            a = Pp[i, k]
            for j in range(d):
                v[j] += a * FP[k, j]
        for j in range(d):
            P[i, j] += v[j]
    _symmetrise(P)


@njit(cache=True, nogil=True)  # a second thread runs beside it (issue 15)
def smooth(x0, P0, F, b, Q, Hc, zc, use_c, rc, Hk, zk, use_k, rk, gate):
    """(xs (n, d), Ps (n, d, d), gated (n,) bool): the smoothed means and covariances."""
    n, d = F.shape[0], x0.size
    xf = np.empty((n, d))
    Pf = np.empty((n, d, d))
    gated = np.zeros(n, np.bool_)
    w = _work(d)
    x, P = x0.copy(), P0.copy()
    for k in range(n):
        gated[k] = _step_into(x, P, F[k], b[k], Q[k], Hc[k], zc[k], use_c[k], rc, Hk[k],
                              zk[k], use_k[k], rk, gate, k > 0, w)
        xf[k] = x
        Pf[k] = P
    for k in range(n - 2, -1, -1):  # backwards, the smoothed overwriting the filtered
        _rts_into(xf[k], Pf[k], F[k + 1], b[k + 1], Q[k + 1], xf[k + 1], Pf[k + 1], w)
    return xf, Pf, gated


@njit(cache=True, nogil=True)  # a second thread runs beside it (issue 15)
def filter_block(x0, P0, F, b, Q, Hc, zc, use_c, rc, Hk, zk, use_k, rk, gate, first, m,
                 xf, Pf, gated):
    """The forward filter over the first m rows of a block of frames (row j: frame lo + j, F[j]
    the step into it), from (x0, P0): frame lo − 1's filtered state, or, with ``first``, the
    session's prior. Writes the filtered states into xf (≥ m, d), Pf (≥ m, d, d) and the gate's
    decisions into gated (≥ m,); returns the last frame's (x, P)."""
    w = _work(x0.size)
    x, P = x0.copy(), P0.copy()
    for j in range(m):
        gated[j] = _step_into(x, P, F[j], b[j], Q[j], Hc[j], zc[j], use_c[j], rc, Hk[j], zk[j],
                              use_k[j], rk, gate, j > 0 or not first, w)
        xf[j] = x
        Pf[j] = P
    return x, P


@njit(cache=True, nogil=True)  # a second thread runs beside it (issue 15)
def rts_block(xf, Pf, m, F, b, Q, xs_next, Ps_next, last):
    """Smooth a block's m filtered states (xf, Pf, overwritten) backwards; unless ``last`` (the
    block ends the session) from the next frame's smoothed state (xs_next, Ps_next) through
    the step into it, row m of (F, b, Q)."""
    w = _work(xf.shape[1])
    if not last:
        _rts_into(xf[m - 1], Pf[m - 1], F[m], b[m], Q[m], xs_next, Ps_next, w)
    for k in range(m - 2, -1, -1):
        _rts_into(xf[k], Pf[k], F[k + 1], b[k + 1], Q[k + 1], xf[k + 1], Pf[k + 1], w)
