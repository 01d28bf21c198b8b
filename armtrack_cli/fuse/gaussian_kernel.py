"""The Gaussian filters of ``methods.run_gaussian`` (inertial, EKF, UKF on the arm model)
compiled with numba: the same equations as filters/gaussian.py on the same models
(models.Steps, models.Projection), in one loop with every work array allocated once.

The numpy functions are the reference: tests/test_gaussian_kernel.py holds this equal to them
to 1e-12 per step from the same prior. Symbols as there: x (6,), P (6, 6), F, Q, H (2, 6),
R (2, 2), gain (6, 2); n_frames camera frames, z (n_frames, 2) px with NaN = no detection.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from armtrack_cli.fuse.projection_kernel import _pixel

METHODS = {"inertial": 0, "ekf": 1, "ukf": 2}


@njit(cache=True)
def _predict(x, P, dt, dp, dv, q, xo, Po):
    """x⁻ = F x + b, P⁻ = F P Fᵀ + Q (eqs. 5, 6) with F = [[I, Δ I], [0, I]], b = (dp, dv),
    Q = q [[Δ³/3, Δ²/2], [Δ²/2, Δ]] ⊗ I₃ (models.Steps), written out for this F."""
    for j in range(3):
        xo[j] = x[j] + dt * x[3 + j] + dp[j]
        xo[3 + j] = x[3 + j] + dv[j]
    FP = np.empty((6, 6))  # F P
    for a in range(6):
        for b in range(6):
            FP[a, b] = P[a, b] + dt * P[a + 3, b] if a < 3 else P[a, b]
    for a in range(6):
        for b in range(6):
            Po[a, b] = FP[a, b] + dt * FP[a, b + 3] if b < 3 else FP[a, b]
    _add_white_acceleration(Po, q, dt)


@njit(cache=True)
def _add_white_acceleration(Po, q, dt):
    """Po += Q of a white-acceleration density q over dt: [[dt³/3, dt²/2], [dt²/2, dt]] q."""
    qpp, qpv, qvv = q * dt**3 / 3, q * dt**2 / 2, q * dt
    for j in range(3):
        Po[j, j] += qpp
        Po[j, 3 + j] += qpv
        Po[3 + j, j] += qpv
        Po[3 + j, 3 + j] += qvv


@njit(cache=True)
def _jacobian(p, cam, dist, H):
    """H = ∂π/∂x (2, 6) at p: models.Projection.jacobian, zero on the velocities."""
    k1, k2, t1, t2, k3 = dist[0], dist[1], dist[2], dist[3], dist[4]
    Xc = np.empty(3)
    for a in range(3):
        Xc[a] = cam[3 * a] * p[0] + cam[3 * a + 1] * p[1] + cam[3 * a + 2] * p[2] + cam[9 + a]
    x, y, Z = Xc[0] / Xc[2], Xc[1] / Xc[2], Xc[2]
    r2 = x * x + y * y
    rad = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    D = k1 + 2 * k2 * r2 + 3 * k3 * r2 * r2  # ∂rad/∂r²
    J00 = rad + 2 * x * x * D + 2 * t1 * y + 6 * t2 * x
    J01 = 2 * x * y * D + 2 * t1 * x + 2 * t2 * y
    J11 = rad + 2 * y * y * D + 6 * t1 * y + 2 * t2 * x
    for a in range(3):  # f · Jd · Jn · R, Jn = [[1/Z, 0, −X/Z²], [0, 1/Z, −Y/Z²]]
        n0 = cam[a] / Z - Xc[0] / Z**2 * cam[6 + a]
        n1 = cam[3 + a] / Z - Xc[1] / Z**2 * cam[6 + a]
        H[0, a] = cam[12] * (J00 * n0 + J01 * n1)
        H[1, a] = cam[13] * (J01 * n0 + J11 * n1)
        H[0, 3 + a] = 0.0
        H[1, 3 + a] = 0.0


@njit(cache=True)
def _gain_update(x, P, innov, Pxz, Pzz, xo, Po):
    """gain = P_xz P_zz⁻¹; x = x + gain (z − ẑ); P = P − gain P_zz gainᵀ, symmetrised
    (gaussian.ukf_update). P_zz is 2 × 2: its inverse in closed form."""
    det = Pzz[0, 0] * Pzz[1, 1] - Pzz[0, 1] * Pzz[1, 0]
    i00, i01, i10, i11 = Pzz[1, 1] / det, -Pzz[0, 1] / det, -Pzz[1, 0] / det, Pzz[0, 0] / det
    gain = np.empty((6, 2))
    for a in range(6):
        gain[a, 0] = Pxz[a, 0] * i00 + Pxz[a, 1] * i10
        gain[a, 1] = Pxz[a, 0] * i01 + Pxz[a, 1] * i11
        xo[a] = x[a] + gain[a, 0] * innov[0] + gain[a, 1] * innov[1]
    for a in range(6):
        for b in range(6):
            Po[a, b] = P[a, b] - (gain[a, 0] * (Pzz[0, 0] * gain[b, 0] + Pzz[0, 1] * gain[b, 1])
                                  + gain[a, 1] * (Pzz[1, 0] * gain[b, 0] + Pzz[1, 1] * gain[b, 1]))
    for a in range(6):
        for b in range(a + 1, 6):
            Po[a, b] = Po[b, a] = 0.5 * (Po[a, b] + Po[b, a])
    return gain


@njit(cache=True)
def _mahalanobis2(innov, S):
    """innovᵀ S⁻¹ innov for a 2 × 2 S (gaussian.mahalanobis2)."""
    det = S[0, 0] * S[1, 1] - S[0, 1] * S[1, 0]
    a, b = innov[0], innov[1]
    return (a * (S[1, 1] * a - S[0, 1] * b) + b * (S[0, 0] * b - S[1, 0] * a)) / det


@njit(cache=True)
def _ekf_update(x, P, z, cam, dist, r2, xo, Po, gate):
    """H = ∂h/∂x (x⁻); S = H P Hᵀ + R; gain = P Hᵀ S⁻¹; x = x + gain (z − h(x⁻)); P in
    Joseph form (I − gain H) P (I − gain H)ᵀ + gain R gainᵀ (gaussian.ekf_update). Returns the
    innovation's Mahalanobis²; above ``gate`` nothing is updated (fuse/robust.py)."""
    H = np.empty((2, 6))
    _jacobian(x, cam, dist, H)
    PHt = P @ H.T  # (6, 2)
    S = H @ PHt
    S[0, 0] += r2
    S[1, 1] += r2
    u, v = _pixel(x[0], x[1], x[2], cam, dist)
    innov = np.array([z[0] - u, z[1] - v])
    d2 = _mahalanobis2(innov, S)
    if d2 > gate:
        return d2
    gain = _gain_update(x, P, innov, PHt, S, xo, Po)
    I_KH = np.eye(6) - gain @ H
    Pj = I_KH @ P @ I_KH.T + r2 * (gain @ gain.T)
    Po[:] = Pj
    return d2


@njit(cache=True)
def _sigma_points(x, P, scale, X):
    """X (13, 6): x, x ± rows of Lᵀ, L L ᵀ = (n + λ) P (Cholesky, written out)."""
    n = x.size
    L = np.zeros((n, n))
    for j in range(n):
        s = scale * P[j, j]
        for m in range(j):
            s -= L[j, m] * L[j, m]
        L[j, j] = np.sqrt(s)
        for i in range(j + 1, n):
            s = scale * P[i, j]
            for m in range(j):
                s -= L[i, m] * L[j, m]
            L[i, j] = s / L[j, j]
    for a in range(n):
        X[0, a] = x[a]
        for i in range(n):
            X[1 + i, a] = x[a] + L[a, i]
            X[1 + n + i, a] = x[a] - L[a, i]


@njit(cache=True)
def _ukf_predict(x, P, dt, dp, dv, q, Wm, Wc, scale, X, xo, Po):
    """Sigma points through the step x ↦ F x + b; x⁻ = Σ Wm Y, P⁻ = Σ Wc (Y − x⁻)(Y − x⁻)ᵀ + Q."""
    _sigma_points(x, P, scale, X)
    for i in range(X.shape[0]):
        for j in range(3):
            X[i, j] += X[i, 3 + j] * dt + dp[j]
            X[i, 3 + j] += dv[j]
    _weighted_moments(X, Wm, Wc, xo, Po)
    _add_white_acceleration(Po, q, dt)


@njit(cache=True)
def _weighted_moments(Y, Wm, Wc, m, C):
    m[:] = Wm @ Y
    d = Y - m
    C[:] = (Wc.reshape(-1, 1) * d).T @ d


@njit(cache=True)
def _ukf_update(x, P, z, cam, dist, r2, Wm, Wc, scale, X, xo, Po, gate):
    """Z = h(X) from fresh sigma points of (x⁻, P⁻); P_zz = Σ Wc dz dzᵀ + R,
    P_xz = Σ Wc dx dzᵀ; then _gain_update (gaussian.ukf_update). Returns the innovation's
    Mahalanobis²; above ``gate`` nothing is updated."""
    _sigma_points(x, P, scale, X)
    Z = np.empty((X.shape[0], 2))
    for i in range(X.shape[0]):
        Z[i, 0], Z[i, 1] = _pixel(X[i, 0], X[i, 1], X[i, 2], cam, dist)
    zm = Wm @ Z
    dz = Z - zm
    dx = X - x
    wdz = Wc.reshape(-1, 1) * dz
    Pzz = wdz.T @ dz
    Pzz[0, 0] += r2
    Pzz[1, 1] += r2
    Pxz = dx.T @ wdz
    d2 = _mahalanobis2(z - zm, Pzz)
    if d2 <= gate:
        _gain_update(x, P, z - zm, Pxz, Pzz, xo, Po)
    return d2


@njit(cache=True)
def _update(method, x, P, z, cam, dist, r2, Wm, Wc, scale, X, xo, Po, gate):
    if method == 1:
        return _ekf_update(x, P, z, cam, dist, r2, xo, Po, gate)
    return _ukf_update(x, P, z, cam, dist, r2, Wm, Wc, scale, X, xo, Po, gate)


@njit(cache=True)
def run(x0, P0, z, dt, dp, dv, q, cam, dist, r2, method, Wm, Wc, scale, gate, reacquire, infl):
    """methods.run_gaussian: started at frame 0 with (x0, P0); method 0 inertial (prediction
    only), 1 EKF, 2 UKF; R = r2 I. Detections gated at Mahalanobis² ``gate`` (0: off); after
    ``reacquire`` frames in a row gated or without a detection the next is used with infl
    (6,) added to P's diagonal (fuse/robust.py). Returns mean (n_frames, 6), cov (n_frames,
    6, 6), codes (n_frames,)."""
    n_frames = z.shape[0]
    mean = np.empty((n_frames, 6))
    cov = np.empty((n_frames, 6, 6))
    codes = np.zeros(n_frames, np.int8)
    x, P = x0.copy(), P0.copy()
    xo, Po = np.empty(6), np.empty((6, 6))
    X = np.empty((Wm.size, 6))
    limit = gate if gate > 0 else np.inf
    run_gated = 0
    for k in range(n_frames):
        if k > 0:
            if method == 2:
                _ukf_predict(x, P, dt[k], dp[k], dv[k], q, Wm, Wc, scale, X, xo, Po)
            else:
                _predict(x, P, dt[k], dp[k], dv[k], q, xo, Po)
            x, xo, P, Po = xo, x, Po, P
        if method > 0 and np.isfinite(z[k, 0]) and np.isfinite(z[k, 1]):
            codes[k] = 1
            if run_gated < 0:  # the grace after a re-acquisition (robust.gate)
                _update(method, x, P, z[k], cam, dist, r2, Wm, Wc, scale, X, xo, Po, np.inf)
                run_gated += 1
            elif _update(method, x, P, z[k], cam, dist, r2, Wm, Wc, scale, X, xo, Po,
                         limit) <= limit:
                run_gated = 0
            elif run_gated < reacquire:
                codes[k] = 2
                run_gated += 1
            else:
                codes[k] = 3
                run_gated = -reacquire
                for a in range(6):
                    P[a, a] += infl[a]
                _update(method, x, P, z[k], cam, dist, r2, Wm, Wc, scale, X, xo, Po, np.inf)
            if codes[k] != 2:
                x, xo, P, Po = xo, x, Po, P
        elif method > 0 and run_gated >= 0:  # no detection: as a gated one (robust.blind)
            run_gated += 1
        mean[k] = x
        cov[k] = P
    return mean, cov, codes
