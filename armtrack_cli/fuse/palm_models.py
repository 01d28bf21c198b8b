"""Cordella et al.'s wrist models (II-B, II-D): the motion of the hand frame W2 = H relative
to the fixed frame W0 (H in the neutral start), and the projection of the six palm markers.

State (error-state UKF, filters/manifold_ukf.py): attitude R = R_{W0 H} and
x = (T (3), v (3), ω (3)): the WRIST position and velocity in W0 (m, m/s) and the angular
velocity of H in H (rad/s). Process noise w = (a (3), α (3)): the linear acceleration in W0
and the angular acceleration in H, constant over a step (m/s², rad/s²).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armtrack_cli.filters.manifold_ukf import exp_so3


@dataclass(frozen=True)
class PalmUkfSettings:
    """Recipe section [ukf_palm] (recipes/cordella-ukf-palm.toml)."""

    accel_density: float = 0.02  # q_v, (m/s²)²·s: white linear acceleration η_v (eq. 1)
    ang_accel_density: float = 5.0  # q_ω, (rad/s²)²·s: white angular acceleration
    pixel_sigma: float = 1.0  # px: ν_i of eq. 2, R = σ² I
    prior_marker: float = 0.9  # p(a_i = j ≠ 0), summed over the markers (eq. 7, as in [3])
    prior_clutter: float = 0.1  # p(a_i = 0)
    gate: float = 16.0  # squared Mahalanobis distance above which a blob cannot be marker j
    merge_px: float = 10.0  # two predicted markers closer than this may share a blob: unused
    merged_area: float = 1.7  # a blob this many times a marker's area is two merged markers
    max_coast_s: float = 1.0  # rows without markers for longer than this are left empty
    resume_min_markers: int = 3  # after a frame without update, fewer markers are not used:
    #                              a lone blob near a wide prediction may well be clutter
    init_sigma_deg: float = 2.0  # P0: attitude about the initial pose
    init_sigma_m: float = 0.003  # P0: WRIST position about the initial pose
    depth_sigma_m: float = 0.004  # σ_z of a marker's depth reading (eq. 13)
    depth_updates: bool = True  # also update with the associated markers' depths (the paper
    #                             uses depth at initialisation only: cordella-ukf-palm sets false)
    alpha: float = 1.0  # scaled sigma points (Wan & van der Merwe)
    beta: float = 2.0
    kappa: float = 0.0


@dataclass(frozen=True)
class Rig:
    """The camera and the markers: pixels = π(g_{W0 C} · g · T_wi) (eq. 2).

    K (3, 3), dist (5,) OpenCV k1 k2 p1 p2 k3; R_CW0 (3, 3), T_CW0 (3,): W0 in C
    (X_C = R_CW0 X_W0 + T_CW0); markers_H (M, 3): T_wi, the markers in H (m)."""

    K: np.ndarray
    dist: np.ndarray
    R_CW0: np.ndarray
    T_CW0: np.ndarray
    markers_H: np.ndarray


def distort_project(K: np.ndarray, dist: np.ndarray, X_C: np.ndarray) -> np.ndarray:
    """π with OpenCV's distortion: (..., 3) points in C -> (..., 2) pixels (eq. 2-3)."""
    d = np.zeros(5)
    d[:min(5, dist.size)] = dist[:5]
    k1, k2, p1, p2, k3 = d
    x, y = X_C[..., 0] / X_C[..., 2], X_C[..., 1] / X_C[..., 2]
    r2 = x * x + y * y
    rad = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    xd = x * rad + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * rad + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return np.stack([K[0, 0] * xd + K[0, 1] * yd + K[0, 2], K[1, 1] * yd + K[1, 2]], -1)


def markers_C(rig: Rig, R: np.ndarray, T: np.ndarray) -> np.ndarray:
    """(S, M, 3) markers in C for hand poses R (S, 3, 3), T (S, 3): g_{W0C} g T_wi."""
    X_W0 = np.einsum("sij,mj->smi", R, rig.markers_H) + T[:, None, :]
    return X_W0 @ rig.R_CW0.T + rig.T_CW0


def project(rig: Rig, R: np.ndarray, x: np.ndarray) -> np.ndarray:
    """h(x): (S, 2M) pixels u1 v1 u2 v2 … of every marker for sigma points R (S,3,3),
    x (S, 9) (eq. 3; the WRIST row is eq. 4 since its T_wi = 0)."""
    px = distort_project(rig.K, rig.dist, markers_C(rig, R, x[:, :3]))
    return px.reshape(px.shape[0], -1)


def measure(rig: Rig, R: np.ndarray, x: np.ndarray) -> np.ndarray:
    """(S, 3M): every marker's pixels u1 v1 u2 v2 … (eq. 3) then every marker's depth
    e₃ᵀ X_C (the h_z of eq. 13, used at every frame when depth frames exist)."""
    RC = rig.R_CW0 @ R  # (S, 3, 3): H in C
    X = RC @ rig.markers_H.T + (x[:, :3] @ rig.R_CW0.T + rig.T_CW0)[:, :, None]  # (S, 3, M)
    d = rig.dist
    k1, k2, p1, p2 = d[0], d[1], d[2], d[3]
    k3 = d[4] if d.size > 4 else 0.0
    xn, yn = X[:, 0] / X[:, 2], X[:, 1] / X[:, 2]
    r2 = xn * xn + yn * yn
    rad = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    xy = xn * yn
    xd = xn * rad + 2 * p1 * xy + p2 * (r2 + 2 * xn * xn)
    yd = yn * rad + p1 * (r2 + 2 * yn * yn) + 2 * p2 * xy
    K = rig.K
    out = np.empty((R.shape[0], 3 * X.shape[2]))
    out[:, 0:2 * X.shape[2]:2] = K[0, 0] * xd + K[0, 1] * yd + K[0, 2]
    out[:, 1:2 * X.shape[2]:2] = K[1, 1] * yd + K[1, 2]
    out[:, 2 * X.shape[2]:] = X[:, 2]
    return out


def facing(rig: Rig, R: np.ndarray, T: np.ndarray) -> np.ndarray:
    """(M,) whether each marker faces the camera (z_H towards the eye) at one pose."""
    eye_W0 = -rig.R_CW0.T @ rig.T_CW0
    X = rig.markers_H @ R.T + T
    return (eye_W0 - X) @ R[:, 2] > 0


def _step_parts() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A(dt) = A0 + dt A1 + dt² A2 (15, 12) with [x, w] A = [x⁺, ψ]: the linear part of eq. 5
    and the rotation increment ψ = ω dt + α dt²/2."""
    A0, A1, A2, I = np.zeros((15, 12)), np.zeros((15, 12)), np.zeros((15, 12)), np.eye(3)
    A0[0:3, 0:3] = A0[3:6, 3:6] = A0[6:9, 6:9] = I  # T, v, ω carried
    A1[3:6, 0:3] = A1[9:12, 3:6] = A1[12:15, 6:9] = A1[6:9, 9:12] = I  # T += v dt, v += a dt,
    A2[9:12, 0:3] = A2[12:15, 9:12] = 0.5 * I  # ω += α dt; T += a dt²/2; ψ = ω dt + α dt²/2
    return A0, A1, A2


_A0, _A1, _A2 = _step_parts()


def process(R: np.ndarray, x: np.ndarray, w: np.ndarray, dt: float
            ) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 1 integrated over dt with the noise constant over the step (eq. 5, exact for it):
    T⁺ = T + v dt + a dt²/2, v⁺ = v + a dt, R⁺ = R exp((ω dt + α dt²/2)^), ω⁺ = ω + α dt.
    R (S,3,3), x (S,9), w (S,6) = (a, α) -> (R⁺, x⁺)."""
    out = np.hstack([x, w]) @ (_A0 + dt * _A1 + (dt * dt) * _A2)
    return R @ exp_so3(out[:, 9:]), out[:, :9]


def noise_cov(s: PalmUkfSettings, dt: float) -> np.ndarray:
    """Qw (6, 6): white noise of density q held over dt has variance q / dt."""
    return np.diag([s.accel_density / dt] * 3 + [s.ang_accel_density / dt] * 3)
