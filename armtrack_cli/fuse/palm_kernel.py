"""One ukf-palm step compiled with numba: the same equations as the numpy reference
(filters/manifold_ukf.predict and predicted_measurement with fuse/palm_models.process and
measure; manifold_ukf.correct), in loops over preallocated work arrays.

tests/test_palm_kernel.py holds each function equal to its reference to 1e-10 from the same
state. ``cache=True``: the compile happens once per install and is loaded from __pycache__.

Symbols as in manifold_ukf: error state δ = (φ, T, v, ω) (d = 12), augmented with the noise
(a, α) (m = 6) to n = 18 and S = 2n + 1 = 37 sigma points; M markers, measurement
(u1 v1 … uM vM, z1 … zM) of size 3M.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from armtrack_cli.filters.manifold_ukf import rodrigues_coefficients

D, NOISE = 12, 6
MEAN_TOL2 = 1e-7**2  # manifold_ukf.MEAN_TOL_RAD squared
MEAN_MAX_ITER = 20

_rodrigues = njit(cache=True)(rodrigues_coefficients)


@njit(cache=True)
def _exp(x, y, z, out):
    """Rodrigues, exp(φ^) (manifold_ukf.exp_so3, series for θ < 1e-4)."""
    a, b, c = _rodrigues(x * x + y * y + z * z)
    out[0, 0], out[0, 1], out[0, 2] = c + b * x * x, b * x * y - a * z, b * x * z + a * y
    out[1, 0], out[1, 1], out[1, 2] = b * x * y + a * z, c + b * y * y, b * y * z - a * x
    out[2, 0], out[2, 1], out[2, 2] = b * x * z - a * y, b * y * z + a * x, c + b * z * z


@njit(cache=True)
def _log(R, out):
    """Rotation vector of R (manifold_ukf.log_so3, angle in [0, π])."""
    th = math.acos(min(1.0, max(-1.0, (R[0, 0] + R[1, 1] + R[2, 2] - 1.0) / 2.0)))
    v0, v1, v2 = R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]
    if th < 1e-4:
        f = 0.5 + th * th / 12.0
    else:
        f = th / (2.0 * math.sin(th))
    out[0], out[1], out[2] = f * v0, f * v1, f * v2
    if th > math.pi - 1e-4:  # the antisymmetric part vanishes: the symmetric part's axis
        k = 0
        for i in range(1, 3):
            if R[i, i] > R[k, k]:
                k = i
        a0, a1, a2 = (R[0, k] + (k == 0)) / 2, (R[1, k] + (k == 1)) / 2, (R[2, k] + (k == 2)) / 2
        nrm = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
        sgn = -1.0 if a0 * v0 + a1 * v1 + a2 * v2 < 0 else 1.0
        out[0], out[1], out[2] = sgn * a0 / nrm * th, sgn * a1 / nrm * th, sgn * a2 / nrm * th


@njit(cache=True)
def _mul(A, B, out):
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]


@njit(cache=True)
def _mul_t(A, B, out):
    """out = Aᵀ B."""
    for i in range(3):
        for j in range(3):
            out[i, j] = A[0, i] * B[0, j] + A[1, i] * B[1, j] + A[2, i] * B[2, j]


@njit(cache=True)
def _sigma_points(R, x, P, qa, qal, dt, c, Rs, xs):
    """Augmented sigma points (P^a = diag(P, Qw), [14] of Cordella) pushed through eq. 5:
    T⁺ = T + v dt + a dt²/2, v⁺ = v + a dt, R⁺ = R exp((ω dt + α dt²/2)^), ω⁺ = ω + α dt."""
    L = np.linalg.cholesky(c * P)  # the noise block of √(c P^a) is diagonal: √(c q / dt)
    sa, sal = math.sqrt(c * qa / dt), math.sqrt(c * qal / dt)
    n = D + NOISE
    d = np.zeros(n)
    E3, Ri = np.empty((3, 3)), np.empty((3, 3))
    for i in range(2 * n + 1):
        d[:] = 0.0
        if i > 0:
            j, sg = (i - 1) % n, 1.0 if i <= n else -1.0
            if j < D:
                for r in range(j, D):
                    d[r] = sg * L[r, j]
            else:
                d[j] = sg * (sa if j < D + 3 else sal)
        _exp(d[0], d[1], d[2], E3)
        _mul(R, E3, Ri)  # R_i = R exp(φ_i^)
        for a in range(3):
            T, v, w = x[a] + d[3 + a], x[3 + a] + d[6 + a], x[6 + a] + d[9 + a]
            acc, alp = d[D + a], d[D + 3 + a]
            xs[i, a] = T + v * dt + acc * dt * dt * 0.5
            xs[i, 3 + a] = v + acc * dt
            xs[i, 6 + a] = w + alp * dt
            d[a] = w * dt + alp * (dt * dt) * 0.5  # ψ, reusing d's first three slots
        _exp(d[0], d[1], d[2], E3)
        _mul(Ri, E3, Rs[i])


@njit(cache=True)
def _mean_rotation(Rs, Wm, Rbar, eR):
    """Weighted Karcher mean (manifold_ukf.rotation_mean) from Rs[0]; eR the errors about it."""
    S = Rs.shape[0]
    Rbar[:, :] = Rs[0]
    A, E3, Rn = np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3))
    step = np.empty(3)
    for _ in range(MEAN_MAX_ITER):
        step[:] = 0.0
        for i in range(S):
            _mul_t(Rbar, Rs[i], A)
            _log(A, eR[i])
            for a in range(3):
                step[a] += Wm[i] * eR[i, a]
        _exp(step[0], step[1], step[2], E3)
        _mul(Rbar, E3, Rn)
        Rbar[:, :] = Rn
        if step[0] * step[0] + step[1] * step[1] + step[2] * step[2] < MEAN_TOL2:
            break
    for i in range(S):
        for a in range(3):
            eR[i, a] -= step[a]


@njit(cache=True)
def _measure(Rs, xs, mk, RC, TC, cam, dist, Z):
    """palm_models.measure: every marker's distorted pixels, then its depth, per sigma point."""
    M = mk.shape[0]
    k1, k2, p1, p2, k3 = dist[0], dist[1], dist[2], dist[3], dist[4]
    RCi = np.empty((3, 3))
    for i in range(Rs.shape[0]):
        _mul(RC, Rs[i], RCi)
        t0 = RC[0, 0] * xs[i, 0] + RC[0, 1] * xs[i, 1] + RC[0, 2] * xs[i, 2] + TC[0]
        t1 = RC[1, 0] * xs[i, 0] + RC[1, 1] * xs[i, 1] + RC[1, 2] * xs[i, 2] + TC[1]
        t2 = RC[2, 0] * xs[i, 0] + RC[2, 1] * xs[i, 1] + RC[2, 2] * xs[i, 2] + TC[2]
        for m in range(M):
            X0 = RCi[0, 0] * mk[m, 0] + RCi[0, 1] * mk[m, 1] + RCi[0, 2] * mk[m, 2] + t0
            X1 = RCi[1, 0] * mk[m, 0] + RCi[1, 1] * mk[m, 1] + RCi[1, 2] * mk[m, 2] + t1
            X2 = RCi[2, 0] * mk[m, 0] + RCi[2, 1] * mk[m, 1] + RCi[2, 2] * mk[m, 2] + t2
            xn, yn = X0 / X2, X1 / X2
            r2 = xn * xn + yn * yn
            rad = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
            xy = xn * yn
            xd = xn * rad + 2 * p1 * xy + p2 * (r2 + 2 * xn * xn)
            yd = yn * rad + p1 * (r2 + 2 * yn * yn) + 2 * p2 * xy
            Z[i, 2 * m] = cam[0] * xd + cam[1] * yd + cam[2]
            Z[i, 2 * m + 1] = cam[3] * yd + cam[4]
            Z[i, 2 * M + m] = X2


@njit(cache=True)
def prior(R, x, P, qa, qal, dt, c, Wm, Wc, mk, RC, TC, cam, dist, rvar,
          Rs, xs, E, Z, Rbar, xbar, Pbar, zm, Pzz, Pxz):
    """Predict (eq. 5 through the augmented sigma points) and the predicted measurement
    (eq. 9-11): fills Rs (S,3,3), xs (S,9), E (S,12), Z (S,3M), R̄, x̄, P̄ (12,12), ẑ (3M,),
    P_zz (3M,3M) with the noise variances rvar (3M,) on its diagonal, P_δz (12,3M).
    c = n + λ; cam = (f_x, skew, c_x, f_y, c_y); dist = k1 k2 p1 p2 k3."""
    S, k = Rs.shape[0], Z.shape[1]
    _sigma_points(R, x, P, qa, qal, dt, c, Rs, xs)
    _mean_rotation(Rs, Wm, Rbar, E)
    for a in range(9):
        acc = 0.0
        for i in range(S):
            acc += Wm[i] * xs[i, a]
        xbar[a] = acc
    for i in range(S):
        for a in range(9):
            E[i, 3 + a] = xs[i, a] - xbar[a]
    _measure(Rs, xs, mk, RC, TC, cam, dist, Z)
    for a in range(k):
        acc = 0.0
        for i in range(S):
            acc += Wm[i] * Z[i, a]
        zm[a] = acc
    for i in range(S):
        for a in range(k):
            Z[i, a] -= zm[a]  # Z now holds dz
    Pbar[:, :] = 0.0
    Pzz[:, :] = 0.0
    Pxz[:, :] = 0.0
    for i in range(S):
        w = Wc[i]
        for a in range(D):
            ea = w * E[i, a]
            for b in range(a, D):
                Pbar[a, b] += ea * E[i, b]
            for b in range(k):
                Pxz[a, b] += ea * Z[i, b]
        for a in range(k):
            za = w * Z[i, a]
            for b in range(a, k):
                Pzz[a, b] += za * Z[i, b]
    for a in range(D):
        for b in range(a):
            Pbar[a, b] = Pbar[b, a]
    for a in range(k):
        Pzz[a, a] += rvar[a]
        for b in range(a):
            Pzz[a, b] = Pzz[b, a]


@njit(cache=True)
def correct(Rbar, xbar, Pbar, rows, z, zm, Pzz, Pxz, R_out, x_out, P_out):
    """manifold_ukf.correct on the measurement rows ``rows``: K = P_δz P_zz⁻¹, δ = K (z − ẑ),
    R⁺ = R̄ exp(δ_φ^), x⁺ = x̄ + δ_x, P⁺ = P̄ − K P_zz Kᵀ (symmetrised)."""
    k = rows.size
    Szz, Pxr = np.empty((k, k)), np.empty((k, D))
    for a in range(k):
        for b in range(k):
            Szz[a, b] = Pzz[rows[a], rows[b]]
        for b in range(D):
            Pxr[a, b] = Pxz[b, rows[a]]
    Kt = np.linalg.solve(Szz, Pxr)  # (k, 12) = Kᵀ
    dx = np.zeros(D)
    for a in range(k):
        nu = z[a] - zm[rows[a]]
        for b in range(D):
            dx[b] += Kt[a, b] * nu
    E3 = np.empty((3, 3))
    _exp(dx[0], dx[1], dx[2], E3)
    _mul(Rbar, E3, R_out)
    for a in range(9):
        x_out[a] = xbar[a] + dx[3 + a]
    for a in range(D):  # K P_zz Kᵀ = P_δz Kᵀ = (Pxr)ᵀ Kt
        for b in range(D):
            acc = 0.0
            for r in range(k):
                acc += Pxr[r, a] * Kt[r, b]
            P_out[a, b] = Pbar[a, b] - acc
    for a in range(D):
        for b in range(a):
            P_out[a, b] = P_out[b, a] = 0.5 * (P_out[a, b] + P_out[b, a])
