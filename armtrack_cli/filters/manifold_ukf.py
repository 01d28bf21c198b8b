"""The augmented unscented Kalman filter on SO(3) × Rⁿ, as pure functions.

The state is an attitude R (3×3) and a Euclidean part x (n,). Its uncertainty lives in the
error state δ = (φ, δx) of dimension d = 3 + n, with R_true = R · exp(φ^) (a right, body-frame
perturbation) and x_true = x + δx; P is the (d, d) covariance of δ. This replaces Cordella et
al.'s ZYZ Euler angles (III-B), which are singular at the neutral pose every session starts in.

Augmented UKF (Kandepu et al. 2008, [14] of Cordella): the process noise w (m,) is appended
to the error state, so noise that enters non-linearly (the attitude noise of eq. 5) is pushed
through the model with the state; the sigma points are perturbations of the mean,
    R_i = R · exp(φ_i^),  x_i = x + δx_i,  w_i,
and the predicted mean rotation is the weighted Karcher mean found by iterated rotation
averaging, R̄ ← R̄ · exp(Σ W_m^i log(R̄ᵀ R_i)) until the step is below 1e-7 rad.
The measurement update uses the propagated sigma points (eq. 9-11 of Cordella) and applies
the correction on the manifold, R⁺ = R̄ · exp((K ν)_φ^).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from armtrack_cli.filters.gaussian import SigmaPoints

MEAN_TOL_RAD = 1e-7  # 6e-6°: far below any error that matters; about 2 iterations
MEAN_MAX_ITER = 20


@dataclass(frozen=True)
class ManifoldState:
    """Posterior: R (3, 3), x (n,), P (3 + n, 3 + n) covariance of the error (φ, δx)."""

    R: np.ndarray
    x: np.ndarray
    P: np.ndarray


@dataclass(frozen=True)
class Prior:
    """Prediction: the mean, its covariance and the propagated sigma points.

    Rs (S, 3, 3), xs (S, n): propagated sigma points; E (S, d): their errors about the mean
    (log(R̄ᵀ R_i), x_i − x̄); Wm, Wc (S,): the weights."""

    R: np.ndarray
    x: np.ndarray
    P: np.ndarray
    Rs: np.ndarray
    xs: np.ndarray
    E: np.ndarray
    Wm: np.ndarray
    Wc: np.ndarray


def hat(v: np.ndarray) -> np.ndarray:
    """(..., 3) -> (..., 3, 3) skew matrices, hat(a) b = a × b."""
    v = np.asarray(v, float)
    z = np.zeros(v.shape[:-1])
    return np.stack([np.stack([z, -v[..., 2], v[..., 1]], -1),
                     np.stack([v[..., 2], z, -v[..., 0]], -1),
                     np.stack([-v[..., 1], v[..., 0], z], -1)], -2)


_I3 = np.eye(3)
_HAT = np.zeros((3, 9))  # hat(φ).ravel() = φ @ _HAT
_HAT[0, [7, 5]], _HAT[1, [2, 6]], _HAT[2, [3, 1]] = (1, -1), (1, -1), (1, -1)
_VEE = _HAT.T.copy()  # R.ravel() @ _VEE = (R32 − R23, R13 − R31, R21 − R12)
_TRACE = _I3.ravel()


def exp_so3(phi: np.ndarray) -> np.ndarray:
    """Rodrigues: exp(φ^) = cos θ I + (1 − cos θ)/θ² φφᵀ + sin θ/θ φ^ for (N, 3) or (3,)
    rotation vectors -> (N, 3, 3) or (3, 3) (series for θ < 1e-4)."""
    phi = np.asarray(phi, float)
    if phi.ndim == 1:
        return _exp_one(phi)
    th2 = np.einsum("ni,ni->n", phi, phi)
    small = th2 < 1e-8
    th = np.sqrt(np.where(small, 1.0, th2))
    c = np.cos(th)
    a = np.where(small, 1.0 - th2 / 6.0, np.sin(th) / th)[:, None]
    b = np.where(small, 0.5 - th2 / 24.0, (1.0 - c) / (th * th))[:, None]
    c = np.where(small, 1.0 - th2 / 2.0, c)[:, None]
    out = b * (phi[:, :, None] * phi[:, None, :]).reshape(-1, 9) + a * (phi @ _HAT) + c * _TRACE
    return out.reshape(-1, 3, 3)


def rodrigues_coefficients(th2: float) -> tuple[float, float, float]:
    """(sin θ/θ, (1 − cos θ)/θ², cos θ) of exp(φ^) = c I + a φ^ + b φφᵀ for θ² = |φ|², by
    their series below θ = 1e-4 (the compiled palm kernel uses this same function)."""
    if th2 < 1e-8:
        return 1.0 - th2 / 6.0, 0.5 - th2 / 24.0, 1.0 - th2 / 2.0
    th = math.sqrt(th2)
    return math.sin(th) / th, (1.0 - math.cos(th)) / th2, math.cos(th)


def _exp_one(phi: np.ndarray) -> np.ndarray:
    """exp_so3 of one rotation vector, in plain floats (the filter's per-step corrections)."""
    x, y, z = float(phi[0]), float(phi[1]), float(phi[2])
    a, b, c = rodrigues_coefficients(x * x + y * y + z * z)
    return np.array([[c + b * x * x, b * x * y - a * z, b * x * z + a * y],
                     [b * x * y + a * z, c + b * y * y, b * y * z - a * x],
                     [b * x * z - a * y, b * y * z + a * x, c + b * z * z]])


def log_so3(R: np.ndarray) -> np.ndarray:
    """Rotation vectors (..., 3) of rotations (..., 3, 3), angle in [0, π]."""
    R = np.asarray(R, float)
    flat = R.reshape(-1, 9)
    th = np.arccos(np.clip((flat @ _TRACE - 1.0) / 2.0, -1.0, 1.0))
    v = flat @ _VEE
    small = th < 1e-4
    f = np.where(small, 0.5 + th * th / 12.0, th / (2.0 * np.sin(np.where(small, 1.0, th))))
    out = f[:, None] * v
    near_pi = th > np.pi - 1e-4  # the antisymmetric part vanishes: use the symmetric part
    if near_pi.any():
        B = (R.reshape(-1, 3, 3)[near_pi] + _I3) / 2.0
        k = np.argmax(np.diagonal(B, axis1=-2, axis2=-1), -1)
        axis = B[np.arange(len(k)), :, k]
        axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
        sgn = np.where(np.sum(axis * v[near_pi], -1) < 0, -1.0, 1.0)
        out[near_pi] = sgn[:, None] * axis * th[near_pi][:, None]
    return out.reshape(R.shape[:-2] + (3,))


def rotation_mean(Rs: np.ndarray, W: np.ndarray, R0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Weighted Karcher mean of rotations (S, 3, 3), started at R0, by iterated averaging of
    the rotation vectors about the current mean; returns (R̄, errors log(R̄ᵀ R_i) (S, 3))."""
    R = R0
    for _ in range(MEAN_MAX_ITER):
        e = log_so3(R.T @ Rs)
        step = W @ e
        R = R @ exp_so3(step)
        if step @ step < MEAN_TOL_RAD**2:
            break
    return R, e - step  # the errors about the final mean, to O(|step| |e|) < 1e-8 rad


@functools.lru_cache(maxsize=8)
def _weights(sp: SigmaPoints) -> tuple[np.ndarray, np.ndarray]:
    return sp.weights()


def predict(s: ManifoldState, f, Qw: np.ndarray, sp: SigmaPoints) -> Prior:
    """Augmented UKF prediction. f(Rs (S,3,3), xs (S,n), ws (S,m)) -> (Rs', xs') pushes every
    sigma point through the process model with its own noise sample; Qw (m, m) is the noise
    covariance, sp the scaled sigma points of dimension d + m."""
    d, m = s.P.shape[0], Qw.shape[0]
    assert sp.n == d + m, "the sigma points must span the augmented state"
    Pa = np.zeros((d + m, d + m))
    Pa[:d, :d], Pa[d:, d:] = s.P, Qw  # [14]: P^a = diag(P, Q)
    D = sp.points(np.zeros(d + m), Pa)  # (2(d+m)+1, d+m) perturbations
    Rs = s.R @ exp_so3(D[:, :3])  # R_i = R exp(φ_i^)
    Rp, xp = f(Rs, s.x + D[:, 3:d], D[:, d:])
    Wm, Wc = _weights(sp)
    R, eR = rotation_mean(Rp, Wm, Rp[0])
    x = Wm @ xp
    E = np.hstack([eR, xp - x])
    P = (Wc[:, None] * E).T @ E
    return Prior(R, x, 0.5 * (P + P.T), Rp, xp, E, Wm, Wc)


def predicted_measurement(pr: Prior, Z: np.ndarray, R_meas: np.ndarray
                          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """From the measurement sigma points Z (S, k) = h(Rs, xs): ẑ (eq. 10), P_zz (eq. 11,
    with the measurement noise R_meas (k, k)) and the cross-covariance P_δz (d, k)."""
    zm = pr.Wm @ Z  # eq. 10
    dz = Z - zm
    Pzz = (pr.Wc[:, None] * dz).T @ dz + R_meas  # eq. 11
    Pxz = (pr.Wc[:, None] * pr.E).T @ dz
    return zm, Pzz, Pxz


def correct(pr: Prior, z: np.ndarray, zm: np.ndarray, Pzz: np.ndarray,
            Pxz: np.ndarray) -> ManifoldState:
    """K = P_δz P_zz⁻¹, δ = K (z − ẑ); R⁺ = R̄ exp(δ_φ^), x⁺ = x̄ + δ_x, P⁺ = P⁻ − K P_zz Kᵀ."""
    K = np.linalg.solve(Pzz, Pxz.T).T
    dx = K @ (z - zm)
    P = pr.P - K @ Pzz @ K.T
    return ManifoldState(pr.R @ exp_so3(dx[:3]), pr.x + dx[3:], 0.5 * (P + P.T))


def no_update(pr: Prior) -> ManifoldState:
    """No usable measurement: the posterior is the prediction."""
    return ManifoldState(pr.R, pr.x, pr.P)


def update(pr: Prior, z: np.ndarray | None, h, R_meas: np.ndarray) -> ManifoldState:
    """Measurement update with h(Rs, xs) -> (S, k); z=None leaves the prediction."""
    if z is None:
        return no_update(pr)
    zm, Pzz, Pxz = predicted_measurement(pr, h(pr.Rs, pr.xs), R_meas)
    return correct(pr, z, zm, Pzz, Pxz)
