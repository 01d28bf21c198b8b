"""The camera's pose in W from one image of the ChArUco board lying on the table.

ChArUco corners are detected (OpenCV's CharucoDetector), optionally refined to the image's
saddle points (calibrate/saddle.py), the pose is solved with IPPE for a planar target and refined
with Levenberg-Marquardt, then converted to W as the contract defines it: W is OpenCV's board
frame turned 180° about x, so R_WC = R_bC · diag(1, −1, −1).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from armtrack_cli.calibrate.saddle import saddle_points
from armtrack_cli.core.streams import CameraModel
from armtrack_cli.vision.charuco import B_TO_W, MIN_CORNERS


@dataclass(frozen=True)
class CalibrateSettings:
    """Recipe section [calibrate]."""

    max_error_px: float = 2.0  # board reprojection error above this is refused
    corners: str = "opencv"  # "opencv": the ChArUco detector's; "saddle": refined to the
    #                         image's saddle points (calibrate/saddle.py)


CORNERS = ("opencv", "saddle")


@dataclass(frozen=True)
class BoardPose:
    R_WC: np.ndarray  # (3, 3), X_C = R_WC X_W + T_WC
    T_WC: np.ndarray  # (3,) m
    rms_px: float  # reprojection error of the corners used
    n_corners: int
    corners_px: np.ndarray  # (n, 2) detected corners
    ids: np.ndarray  # (n,)

    @property
    def camera_position_W(self) -> np.ndarray:
        return CameraModel.centre(self.R_WC, self.T_WC)


def _gray(image: np.ndarray) -> np.ndarray:
    return cv2.cvtColor(image, cv2.COLOR_BGR2GRAY) if image.ndim == 3 else image


def detect_corners(image: np.ndarray, board) -> tuple[np.ndarray, np.ndarray]:
    """(n, 2) ChArUco corner pixels and their (n,) ids; empty arrays when none are found."""
    gray = _gray(image)
    corners, ids, _, _ = cv2.aruco.CharucoDetector(board).detectBoard(gray)
    if ids is None or len(ids) == 0:
        return np.zeros((0, 2)), np.zeros(0, dtype=int)
    return corners.reshape(-1, 2).astype(float), ids.reshape(-1).astype(int)


def board_pose(image: np.ndarray, board, cam: CameraModel, *, corners: str = "opencv"
               ) -> BoardPose | None:
    """Pose from the board's corners (``corners`` = "saddle": refined to the image's saddle
    points), or None with fewer than MIN_CORNERS of them."""
    px, ids = detect_corners(image, board)
    if ids.size < MIN_CORNERS:
        return BoardPose(np.eye(3), np.zeros(3), np.inf, int(ids.size), px, ids) if ids.size else None
    if corners == "saddle":
        px = saddle_points(_gray(image), px)
    obj = board.getChessboardCorners()[ids].astype(float)  # board frame, z = 0
    ok, rvec, tvec = cv2.solvePnP(obj, px, cam.K, cam.dist, flags=cv2.SOLVEPNP_IPPE)
    if not ok:
        return None
    rvec, tvec = cv2.solvePnPRefineLM(obj, px, cam.K, cam.dist, rvec, tvec)
    proj = cv2.projectPoints(obj, rvec, tvec, cam.K, cam.dist)[0].reshape(-1, 2)
    rms = float(np.sqrt(np.mean(np.sum((proj - px) ** 2, axis=1))))
    R_bC = cv2.Rodrigues(rvec)[0]
    return BoardPose(R_bC @ B_TO_W, tvec.reshape(3), rms, int(ids.size), px, ids)
