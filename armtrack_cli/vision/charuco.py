"""The ChArUco board that defines W, built once for calibrate and simulate.

SESSION_FORMAT.md: W is OpenCV's board frame turned 180° about its x axis
(x_W = x_b, y_W = −y_b, z_W = −z_b), so z points up out of the table.
"""

from __future__ import annotations

import cv2
import numpy as np

B_TO_W = np.diag([1.0, -1.0, -1.0])  # X_b = B_TO_W X_W (its own inverse)
MIN_CORNERS = 6  # corners for a board pose (calibrate) and for a view used in intrinsics


def make_board(squares, square_m: float, marker_m: float, dictionary: str):
    """OpenCV's CharucoBoard of ``squares`` = (columns, rows), sizes in metres."""
    d = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, dictionary))
    return cv2.aruco.CharucoBoard(tuple(int(s) for s in squares), float(square_m), float(marker_m), d)
