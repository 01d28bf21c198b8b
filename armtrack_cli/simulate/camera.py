"""The simulated camera: pinhole with optional radial distortion, placed in front of and
above the table looking down, and the ChArUco board that defines W (SESSION_FORMAT.md:
W is OpenCV's board frame turned 180° about x: x_W = x_b, y_W = −y_b, z_W = −z_b)."""

from __future__ import annotations

import cv2
import numpy as np

from armtrack_cli.core.streams import CameraModel


def look_at(eye: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """R_WC, T_WC of a camera at ``eye`` looking at ``target`` with image 'up' towards +z_W."""
    z = target - eye
    z = z / np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x = x / np.linalg.norm(x)
    y = np.cross(z, x)  # OpenCV: x right, y down, z forward
    R_WC = np.stack([x, y, z])  # rows: camera axes in W, so X_C = R_WC (X_W − eye)
    return R_WC, -R_WC @ eye


def default_camera(*, width: int = 640, height: int = 480, focal_px: float = 560.0,
                   k1: float = -0.12, k2: float = 0.03,
                   eye=(0.22, -0.40, 0.66), target=(0.22, 0.09, 0.04)) -> CameraModel:
    K = np.array([[focal_px, 0, width / 2 - 0.5 + 3.2], [0, focal_px, height / 2 - 0.5 - 2.1],
                  [0, 0, 1.0]])
    R, T = look_at(np.asarray(eye, float), np.asarray(target, float))
    return CameraModel(K, np.array([k1, k2, 0.0, 0.0, 0.0]), width, height, R, T)


def project(cam: CameraModel, X_W: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixels (N, 2) as observed (with distortion) and depths z_C (N,) of points (N, 3) in W."""
    X_W = np.asarray(X_W, float).reshape(-1, 3)
    rvec = cv2.Rodrigues(cam.R_WC)[0]
    px = cv2.projectPoints(X_W, rvec, cam.T_WC, cam.K, cam.dist)[0].reshape(-1, 2)
    depth = (X_W @ cam.R_WC.T + cam.T_WC)[:, 2]
    return px, depth


def pixel_rays(cam: CameraModel) -> np.ndarray:
    """(H, W, 3) unit-depth rays in C (x_n, y_n, 1) of every observed (distorted) pixel."""
    u, v = np.meshgrid(np.arange(cam.width, dtype=np.float32),
                       np.arange(cam.height, dtype=np.float32))
    pts = np.stack([u.ravel(), v.ravel()], -1)[:, None, :]
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-9)
    n = cv2.undistortPoints(pts, cam.K, cam.dist, R=None, P=None, criteria=crit)
    n = n.reshape(cam.height, cam.width, 2).astype(float)
    return np.concatenate([n, np.ones((cam.height, cam.width, 1))], -1)

