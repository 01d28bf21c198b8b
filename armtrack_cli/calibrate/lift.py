"""Pixels lifted to 3-D points in W: by the depth frame where it has a reading, else onto the
plane of the back of a hand lying flat on the table."""

from __future__ import annotations

import cv2
import numpy as np

from armtrack_cli.core.streams import CameraModel

HAND_HEIGHT_M = 0.035  # back of a hand lying flat, above the table, when there is no depth
DEPTH_WINDOW = 2  # median over a (2·2+1)² window of depth pixels


def lift_pixels(cam: CameraModel, px: np.ndarray, depth: np.ndarray | None) -> np.ndarray:
    """(k, 3) points in W under pixels (k, 2); depth (H, W) m along the optical axis, NaN =
    no reading. X_W = R_WCᵀ (z·ray − T_WC) with ray the undistorted unit-depth ray."""
    n = cv2.undistortPoints(px.reshape(-1, 1, 2).astype(np.float64), cam.K, cam.dist).reshape(-1, 2)
    rays = np.c_[n, np.ones(len(n))]
    eye = cam.centre_W
    out = np.empty((len(px), 3))
    w = DEPTH_WINDOW
    for i, (r, (u, v)) in enumerate(zip(rays, px)):
        z = np.nan
        if depth is not None:
            y0, x0 = int(round(v)), int(round(u))
            win = depth[max(0, y0 - w):y0 + w + 1, max(0, x0 - w):x0 + w + 1]
            z = np.nanmedian(win) if np.isfinite(win).any() else np.nan
        if np.isfinite(z):
            out[i] = cam.R_WC.T @ (z * r - cam.T_WC)
        else:  # the ray meets the plane z_W = HAND_HEIGHT_M
            d = cam.R_WC.T @ r
            out[i] = eye + (HAND_HEIGHT_M - eye[2]) / d[2] * d
    return out
