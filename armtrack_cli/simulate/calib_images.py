"""Images of a hand-held ChArUco board at varied poses, as a lab films for intrinsic
calibration: the printed board (with a white margin) rendered through the true lens model."""

from __future__ import annotations

import cv2
import numpy as np

from armtrack_cli.core.streams import CameraModel
from armtrack_cli.simulate.camera import pixel_rays

PX_PER_M = 2000  # texture resolution of the printed board


def _rot(axis, angle):
    return cv2.Rodrigues(np.asarray(axis, float) * angle)[0]


def board_images(cam: CameraModel, board, n: int, rng: np.random.Generator) -> list[np.ndarray]:
    """``n`` grey-background images of the board at random poses 0.3-0.6 m from the camera."""
    cols, rows = board.getChessboardSize()
    sq = board.getSquareLength()
    w_m, h_m = cols * sq, rows * sq
    margin = int(0.02 * PX_PER_M)
    tex = board.generateImage((int(round(w_m * PX_PER_M)), int(round(h_m * PX_PER_M))),
                              marginSize=0)
    tex = cv2.copyMakeBorder(tex, margin, margin, margin, margin, cv2.BORDER_CONSTANT, value=255)
    rays = pixel_rays(cam).reshape(-1, 3)
    out = []
    while len(out) < n:
        dist = rng.uniform(0.3, 0.6)
        # steep tilts (20-45°) about a random in-plane axis: focal length and distortion are
        # only observable from foreshortened views; fronto-parallel ones leave them free
        tilt_axis = np.r_[np.cos(a := rng.uniform(0, 2 * np.pi)), np.sin(a), 0.0]
        R = _rot([0, 0, 1], rng.uniform(-0.5, 0.5)) @ _rot(tilt_axis, rng.uniform(0.35, 0.8))
        centre_px = rng.uniform([0.15, 0.15], [0.85, 0.85]) * [cam.width, cam.height]
        c_n = np.linalg.inv(cam.K) @ np.r_[centre_px, 1.0]
        t = c_n * dist - R @ np.array([w_m / 2, h_m / 2, 0.0])  # board centre on that ray
        nrm = R[:, 2]
        s = (nrm @ t) / (rays @ nrm)
        X = s[:, None] * rays - t  # in C, relative to the board origin
        xb = X @ R  # board coordinates (Rᵀ X)
        # texel j covers [j, j+1) of the texture; remap puts texel centres at integers: −0.5
        mx = (xb[:, 0] * PX_PER_M + margin - 0.5).reshape(cam.height, cam.width).astype(np.float32)
        my = (xb[:, 1] * PX_PER_M + margin - 0.5).reshape(cam.height, cam.width).astype(np.float32)
        bad = (s <= 0).reshape(cam.height, cam.width)
        mx[bad] = -1
        img = cv2.remap(tex, mx, my, cv2.INTER_LINEAR,
                        borderMode=cv2.BORDER_CONSTANT, borderValue=110)
        img = np.clip(img.astype(np.float32) + rng.normal(0, 2.0, img.shape), 0, 255)
        img = cv2.GaussianBlur(img, (3, 3), 0.6).astype(np.uint8)
        out.append(cv2.cvtColor(img, cv2.COLOR_GRAY2BGR))
    return out
