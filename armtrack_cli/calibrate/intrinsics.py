"""Camera intrinsics from images of the ChArUco board (OpenCV's calibration, Zhang's method).

k3 is held at zero: a 640x480 webcam-class lens is modelled well by k1, k2, p1, p2, and
freeing k3 with a dozen views mostly fits noise.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from armtrack_cli.calibrate.board_pose import detect_corners
from armtrack_cli.core.streams import CameraModel
from armtrack_cli.vision.charuco import MIN_CORNERS

MIN_VIEWS = 4


@dataclass(frozen=True)
class Intrinsics:
    camera: CameraModel
    rms_px: float
    views_used: int
    views_rejected: tuple[int, ...]


def calibrate_intrinsics(images: list[np.ndarray], board) -> Intrinsics | None:
    """None when fewer than MIN_VIEWS images show at least MIN_CORNERS corners."""
    obj, img, rejected = [], [], []
    size = None
    for k, image in enumerate(images):
        size = (image.shape[1], image.shape[0])
        px, ids = detect_corners(image, board)
        if ids.size < MIN_CORNERS:
            rejected.append(k)
            continue
        obj.append(board.getChessboardCorners()[ids].astype(np.float32))
        img.append(px.astype(np.float32))
    if len(obj) < MIN_VIEWS:
        return None
    rms, K, dist, _, _ = cv2.calibrateCamera(obj, img, size, None, None, flags=cv2.CALIB_FIX_K3)
    return Intrinsics(CameraModel(K, dist.reshape(-1), size[0], size[1]), float(rms), len(obj),
                      tuple(rejected))
