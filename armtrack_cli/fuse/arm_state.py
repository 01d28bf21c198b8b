"""The arm smoother's state (fuse/arm_smoother.py): where each part sits in it (p, v, δθ, b_a,
b_g[, c][, ℓ, S]) and how it steps from frame to frame: F, b, Q of Tao & Hu's eqs. 4–6 with
both IMU errors (the IMU folded between frames by fuse/imu_fold.py), the orientation error
following the gyroscope or a Gauss–Markov process, the drifting arm's random walks."""

from __future__ import annotations

import numpy as np

from armtrack_cli.fuse import camera_pose, imu_fold
from armtrack_cli.fuse.settings import FuseSettings

P_, V_, TH, BA, BG = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12), slice(12, 15)

DRIFT = 4  # the drifting arm's states, the state's last: ℓ (m), then S (3, m in W)


def state_size(gyro: bool, camera: bool, drifting: bool) -> int:
    """d: (p, v, δθ, b_a) 12, + b_g 3 with a gyroscope, + c 6 with the camera pose's
    correction, + (ℓ, S) 4 with the drifting arm."""
    return 12 + 3 * gyro + camera_pose.POSE * camera + DRIFT * drifting


def camera_slice(d: int, drifting: bool) -> slice:
    """The camera pose's correction c (camera_pose.POSE states) in a state of size d: just
    before the drifting arm's (ℓ, S) where there is one, else the last."""
    end = d - DRIFT * drifting
    return slice(end - camera_pose.POSE, end)


def shoulder_slice(d: int) -> slice:
    """The drifting shoulder's place in a state of size d: always the last three."""
    return slice(d - 3, d)


def drift_slice(d: int) -> slice:
    """The drifting arm's place (ℓ, S) in a state of size d: the last DRIFT."""
    return slice(d - DRIFT, d)


def drift_noise(dt: np.ndarray, s: FuseSettings) -> np.ndarray:
    """Q (n, 4, 4) of (ℓ, S)'s random walks over steps dt (n,) s: the upper arm's length and
    each axis of the shoulder change by upper_arm_walk_m_s and shoulder_walk_m_s per √s."""
    rate = np.array([s.upper_arm_walk_m_s] + [s.shoulder_walk_m_s] * 3) ** 2
    return dt[:, None, None] * np.diag(rate)


def drift_prior(shoulder: np.ndarray, s: FuseSettings) -> tuple[np.ndarray, np.ndarray]:
    """(ℓ, S) at the first frame: the declared arm moved by the offset of the sphere the elbow
    turns about from it (ℓ = upper_arm_offset_m, S = the declared shoulder + shoulder_offset_*;
    0 by default: the declared arm), as uncertain as that sphere about it (upper_arm_sd_m,
    shoulder_sd_m per axis)."""
    sd = np.array([s.upper_arm_sd_m] + [s.shoulder_sd_m] * 3)
    off = np.array([s.shoulder_offset_x_m, s.shoulder_offset_y_m, s.shoulder_offset_z_m])
    return np.r_[s.upper_arm_offset_m, shoulder + off], np.diag(sd**2)


def orientation_var(s: FuseSettings) -> np.ndarray:
    """(3, 3) stationary covariance of δθ: tilt (about W's x and y) and heading (about z)."""
    return np.diag(np.deg2rad([s.orientation_sd_deg, s.orientation_sd_deg,
                               s.heading_sd_deg]) ** 2)


def process(fd: imu_fold.Folded, s: FuseSettings, shoulder: np.ndarray | None,
            imu_period: float, track: imu_fold.OrientationTrack | None = None,
            camera: bool = False, noise: bool = True) -> tuple:
    """F (n, d, d), b (n, d), Q (n, d, d) of the augmented state's steps (index 0 unused);
    with ``track`` (the gyro's) δθ follows it and the state holds the gyro bias b_g; with
    ``camera`` the pose's correction c, static (F = I, Q = 0); without ``noise``, (F, b)
    alone. Each 3 × 3 block that is a multiple of I or a cross-product matrix is written by
    its non-zero entries only (``_diagonal``, ``_skew``: the same numbers as dt · I or
    [s]×; F, b, Q in 0.7-1.2 ms a 1,024-frame block, 1.2-2.8 ms with the blocks built whole)."""
    n = fd.dt.size
    d = state_size(track is not None, camera, shoulder is not None)
    dt = fd.dt
    F = np.zeros((n, d, d))
    b = np.zeros((n, d))
    _diagonal(F, 0, 0, 1.0, d)
    _diagonal(F, 0, 3, dt)
    _skew(F, 0, 6, fd.s_p)  # ∂p/∂δθ = [s_p]× (imu_fold.Folded.A_p)
    _skew(F, 3, 6, fd.s_v)
    F[:, P_, BA], F[:, V_, BA] = -fd.B_p, -fd.B_v
    b[:, P_], b[:, V_] = fd.dp, fd.dv
    if track is not None:  # δθ_k = δθ_{k−1} + Δθ_gyro + G b_g + walk (imu_fold.orientation_track)
        b[:, TH], F[:, TH, BG] = track.dtheta, track.G
    else:
        phi = np.exp(-dt / s.orientation_tau_s)  # Gauss–Markov: Var stays orientation_sd²
        _diagonal(F, 6, 6, phi)
    if not noise:
        return F, b
    Q = np.zeros((n, d, d))
    q = s.smoother_accel_noise**2 * imu_period  # white acceleration density (models.Steps)
    _diagonal(Q, 0, 0, q * dt**3 / 3)
    _diagonal(Q, 0, 3, q * dt**2 / 2)
    _diagonal(Q, 3, 0, q * dt**2 / 2)
    _diagonal(Q, 3, 3, q * dt)
    if track is not None:
        _diagonal(Q, 6, 6, np.deg2rad(s.orientation_walk_deg) ** 2 * dt)
        _diagonal(Q, 12, 12, np.deg2rad(s.gyro_bias_walk_deg_s) ** 2 * dt)
    else:
        Q[:, TH, TH] = orientation_var(s) * (1 - phi**2)[:, None, None]
    _diagonal(Q, 9, 9, s.accel_bias_walk**2 * dt)
    if shoulder is not None:  # (ℓ, S): random walks (F = I, b = 0)
        Q[:, drift_slice(d), drift_slice(d)] = drift_noise(dt, s)
    return F, b, Q


def _diagonal(M: np.ndarray, r: int, c: int, v, k: int = 3) -> None:
    """M[:, r + i, c + i] = v for i < k: v a number or (n,) per matrix (through a strided
    view of those entries: a fancy-indexed write took 5 times as long)."""
    n, s0, s1, s2 = M.shape[0], *M.strides
    view = np.lib.stride_tricks.as_strided(M[:, r, c:], shape=(n, k), strides=(s0, s1 + s2))
    view[...] = v if np.ndim(v) == 0 else np.asarray(v)[:, None]


def _skew(M: np.ndarray, r: int, c: int, v: np.ndarray) -> None:
    """M[:, r:r + 3, c:c + 3] = [v]× (imu_fold.skew) for v (n, 3), its zeros as they are."""
    M[:, r, c + 1], M[:, r, c + 2] = -v[:, 2], v[:, 1]
    M[:, r + 1, c], M[:, r + 1, c + 2] = v[:, 2], -v[:, 0]
    M[:, r + 2, c], M[:, r + 2, c + 1] = -v[:, 1], v[:, 0]
