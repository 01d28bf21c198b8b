"""The camera's pose as the board gave it, with its uncertainty, for the arm smoother to refine.

`calibrate` solves the camera's pose from the ChArUco board's corners in one frame. Its error is
what moves the wrist's depth most where the camera ray grazes the arm's sphere: a rotation δ
turns each ray by δ, moves the wrist δ·depth across it, and the arm constraint turns that into
depth (docs/validation-from-mocap.md measures it). With ``camera_pose = "board"`` the arm
smoother carries a correction c = (φ, τ) of the pose as six static states,

    X_C = exp([φ]×) (R_WC X_W + T_WC) + τ,

whose prior is the board's: zero mean, covariance σ² (Jᵀ J)⁻¹ with J the Jacobian of the inner
corners' pixels with respect to c and σ the board's reprojection error, the Gauss–Newton
covariance of a least-squares pose (Hartley & Zisserman 2004, "Multiple View Geometry", 2nd
ed., § 5.2.3, eq. 5.10 with Σ = σ² I). The camera's rows then move c as much as the IMU's
metric motion and the arm disagree with the board's pose along that covariance.
"""

from __future__ import annotations

import numpy as np

from armtrack_cli.core.streams import CameraModel
from armtrack_cli.fuse.imu_fold import skew
from armtrack_cli.fuse.models import Projection

POSE = 6  # (φ, τ): rad, m, in the camera frame


def board_corners_W(squares: tuple[int, int], square_m: float) -> np.ndarray:
    """(n, 3) the ChArUco board's inner corners in W: OpenCV's board frame (corner (i, j) at
    square_m·(i, j), i, j ≥ 1) turned 180° about x, as the contract defines W."""
    cols, rows = int(squares[0]), int(squares[1])
    i, j = np.meshgrid(np.arange(1, cols), np.arange(1, rows))
    return np.c_[i.ravel() * square_m, -j.ravel() * square_m, np.zeros(i.size)]


def pixel_jacobians(proj: Projection, X: np.ndarray) -> np.ndarray:
    """∂π/∂X_C (n, 2, 3) at camera-frame points X (n, 3), OpenCV's distortion included."""
    x, y, Z = X[:, 0] / X[:, 2], X[:, 1] / X[:, 2], X[:, 2]
    r2 = x * x + y * y
    rad = 1 + r2 * (proj.k1 + r2 * (proj.k2 + r2 * proj.k3))
    D = proj.k1 + 2 * proj.k2 * r2 + 3 * proj.k3 * r2 * r2  # ∂rad/∂r²
    off = 2 * x * y * D + 2 * proj.p1 * x + 2 * proj.p2 * y
    Jd = np.stack([np.stack([rad + 2 * x * x * D + 2 * proj.p1 * y + 6 * proj.p2 * x, off], -1),
                   np.stack([off, rad + 2 * y * y * D + 6 * proj.p1 * y + 2 * proj.p2 * x], -1)],
                  -2)
    zero = np.zeros_like(Z)
    Jn = np.stack([np.stack([1 / Z, zero, -X[:, 0] / Z**2], -1),
                   np.stack([zero, 1 / Z, -X[:, 1] / Z**2], -1)], -2)
    return proj._f[None, :, None] * (Jd @ Jn)


def in_camera(proj: Projection, p: np.ndarray) -> np.ndarray:
    """(n, 3) points p (n, 3) in W in the camera frame of ``proj``."""
    return p @ proj.R.T + proj.T


def _rotation(phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """exp([φ]×) (Rodrigues) and its left Jacobian J_l(φ), ∂(exp([φ]×) X)/∂φ = −[exp([φ]×) X]× J_l
    (Barfoot 2017, "State Estimation for Robotics", eq. 7.86)."""
    ang = float(np.linalg.norm(phi))
    if ang < 1e-12:
        return np.eye(3), np.eye(3)
    K = skew(np.asarray(phi, float)[None])[0] / ang
    rot = np.eye(3) + np.sin(ang) * K + (1 - np.cos(ang)) * K @ K
    jl = np.eye(3) + (1 - np.cos(ang)) / ang * K + (1 - np.sin(ang) / ang) * K @ K
    return rot, jl


def pose_jacobians(proj: Projection, p: np.ndarray, c: np.ndarray | None = None) -> np.ndarray:
    """∂π/∂c (n, 2, 6) at points p (n, 3) in W and the correction c = (φ, τ) of ``proj``'s pose
    (zero when None): X_C = exp([φ]×) X₀ + τ, ∂X_C/∂φ = −[exp([φ]×) X₀]× J_l(φ), ∂X_C/∂τ = I."""
    c = np.zeros(POSE) if c is None else np.asarray(c, float)
    rot, jl = _rotation(c[:3])
    Xr = in_camera(proj, p) @ rot.T
    dX = np.concatenate([-skew(Xr) @ jl, np.broadcast_to(np.eye(3), Xr.shape[:1] + (3, 3))], 2)
    return pixel_jacobians(proj, Xr + c[3:6]) @ dX


def board_covariance(proj: Projection, corners_W: np.ndarray, sigma_px: float) -> np.ndarray:
    """(6, 6) covariance of the pose correction c from the board: σ² (Σ Jᵀ J)⁻¹ over its
    corners (pose_jacobians), σ the board's reprojection error (px)."""
    J = pose_jacobians(proj, corners_W).reshape(-1, POSE)
    return sigma_px**2 * np.linalg.inv(J.T @ J)


def board_prior(proj: Projection, board) -> np.ndarray | None:
    """board_covariance of ``proj``'s pose from the session's [camera] board (its squares and
    square_m) and the reprojection error calibrate wrote; None without either."""
    err = proj.cam.reprojection_error_px
    if board is None or not err:
        return None
    return board_covariance(proj, board_corners_W(board.squares, board.square_m), err)


def moved(proj: Projection, c: np.ndarray) -> Projection:
    """``proj`` with its pose corrected by c = (φ, τ): R' = exp([φ]×) R, T' = exp([φ]×) T + τ."""
    rot = _rotation(np.asarray(c[:3], float))[0]
    cam = proj.cam
    return Projection(CameraModel(cam.K, cam.dist, cam.width, cam.height, rot @ proj.R,
                                  rot @ proj.T + np.asarray(c[3:6], float),
                                  cam.reprojection_error_px), pose_cov=proj.pose_cov)
