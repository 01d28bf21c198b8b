"""Camera models in OpenCV FileStorage YAML: intrinsics.yaml (read) and camera.yaml (write).

Keys as the contract names them: camera_matrix, distortion_coefficients, image_width,
image_height, and in camera.yaml also R_WC (3x3), T_WC (3x1, m), reprojection_error_px.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from armtrack_cli.core.errors import VideoError
from armtrack_cli.core.limits import MAX_SMALL_BYTES
from armtrack_cli.core.streams import CameraModel
from armtrack_cli.session import opencv_yaml
from armtrack_cli.session.files import regular_file
from armtrack_cli.session.outputs import atomic_write


def read_camera_yaml(path: str | Path) -> CameraModel:
    path = regular_file(path, VideoError, "a camera model (OpenCV FileStorage YAML)",
                        hint="check [camera] intrinsics in session.toml",
                        max_bytes=MAX_SMALL_BYTES)
    head = path.read_bytes()[:64]
    if not head.strip():
        raise VideoError(path, "is empty, expected OpenCV FileStorage YAML with camera_matrix")
    if b"\x00" in head:
        raise VideoError(path, "is a binary file, expected OpenCV FileStorage YAML")
    try:
        doc = opencv_yaml.parse(path.read_bytes().decode("utf-8", errors="strict"))
    except UnicodeDecodeError:
        raise VideoError(path, "is not a text file (not UTF-8), expected OpenCV FileStorage YAML") \
            from None
    except opencv_yaml.YamlError as exc:
        raise VideoError(path, f"is not OpenCV FileStorage YAML ({exc})",
                         "it should start with %YAML:1.0 and hold camera_matrix") from None

    def matrix(name):
        v = doc.get(name)
        if v is not None and not isinstance(v, np.ndarray):
            raise VideoError(path, f"{name} is not a matrix (!!opencv-matrix)")
        return v

    def number(name):
        v = doc.get(name)
        if v is not None and not isinstance(v, float):
            raise VideoError(path, f"{name} = {v!r} is not a number")
        return v

    K, dist, R, T = (matrix(k) for k in ("camera_matrix", "distortion_coefficients", "R_WC", "T_WC"))
    w, h, err = (number(k) for k in ("image_width", "image_height", "reprojection_error_px"))
    w, h = (0.0 if v is None else v for v in (w, h))
    if K is None or K.shape != (3, 3):
        raise VideoError(path, "has no 3x3 camera_matrix")
    if not np.isfinite(K).all() or not K[0, 0] < 1e6 or not K[1, 1] < 1e6:
        raise VideoError(path, f"camera_matrix {K.tolist()} has a value that is not finite or "
                         "is absurd (focal length over 1e6 px)", "recalibrate the intrinsics")
    if not (K[0, 0] > 0 and K[1, 1] > 0 and K[2, 2] == 1 and abs(K[1, 0]) + abs(K[2, 0]) + abs(
            K[2, 1]) == 0):
        raise VideoError(path, f"camera_matrix {K.tolist()} is not a pinhole matrix",
                         "expected [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] with fx, fy > 0")
    dist = np.zeros(5) if dist is None else dist.reshape(-1).astype(float)
    if dist.size not in (4, 5, 8, 12, 14):
        raise VideoError(path, f"distortion_coefficients has {dist.size} values",
                         "OpenCV takes 4, 5, 8, 12 or 14")
    if not np.isfinite(dist).all() or np.abs(dist).max() > 1e3:
        raise VideoError(path, f"distortion_coefficients {dist.tolist()} are not finite, or "
                         "absurd (over 1000)", "recalibrate the intrinsics")
    if not (0 < w <= 20000 and 0 < h <= 20000):
        raise VideoError(path, "image_width and image_height are missing or outside 1 … 20000")
    _check_pose(path, R, T)
    return CameraModel(K.astype(float), dist, int(w), int(h),
                       None if R is None else R.astype(float),
                       None if T is None else T.reshape(3).astype(float), err)


def _check_pose(path: Path, R, T) -> None:
    """R_WC a rotation (orthonormal, det +1) and T_WC a finite translation, if present."""
    if R is None and T is None:
        return
    if R is None or T is None or R.shape != (3, 3) or T.size != 3:
        raise VideoError(path, "R_WC must be 3x3 and T_WC 3x1, both present",
                         "rerun `armtrack calibrate`")
    if not (np.isfinite(R).all() and np.isfinite(T).all()):
        raise VideoError(path, "R_WC or T_WC has a value that is not finite",
                         "rerun `armtrack calibrate`")
    off = float(np.abs(R @ R.T - np.eye(3)).max())
    if off > 1e-6 or np.linalg.det(R) < 0:
        raise VideoError(path, f"R_WC is not a rotation (RRᵀ differs from I by {off:.2g}, det "
                         f"{np.linalg.det(R):.3f})", "rerun `armtrack calibrate`")
    if np.linalg.norm(T) > 100.0:
        raise VideoError(path, f"T_WC puts the camera {np.linalg.norm(T):.3g} m from the board",
                         "rerun `armtrack calibrate`")


def write_camera_yaml(path: str | Path, cam: CameraModel) -> Path:
    import cv2  # only to write: reading is opencv_yaml's (compare reads it without OpenCV)

    def write(tmp: Path) -> None:
        fs = cv2.FileStorage(str(tmp), cv2.FILE_STORAGE_WRITE | cv2.FILE_STORAGE_FORMAT_YAML)
        fs.write("camera_matrix", np.asarray(cam.K, dtype=float))
        fs.write("distortion_coefficients", np.asarray(cam.dist, dtype=float).reshape(1, -1))
        fs.write("image_width", int(cam.width))
        fs.write("image_height", int(cam.height))
        if cam.R_WC is not None:
            fs.write("R_WC", np.asarray(cam.R_WC, dtype=float))
            fs.write("T_WC", np.asarray(cam.T_WC, dtype=float).reshape(3, 1))
        if cam.reprojection_error_px is not None:
            fs.write("reprojection_error_px", float(cam.reprojection_error_px))
        fs.release()

    return atomic_write(path, write)


def read_calibrated_camera(path: str | Path) -> CameraModel:
    """camera.yaml as calibrate wrote it into the work folder: intrinsics and the pose in W."""
    path = regular_file(path, VideoError, "a camera model (camera.yaml)",
                        hint="run `armtrack calibrate SESSION` first, with the same --out")
    cam = read_camera_yaml(path)
    if cam.R_WC is None or cam.T_WC is None:
        raise VideoError(path, "has no R_WC/T_WC (the camera's pose in W)",
                         "run `armtrack calibrate SESSION` to write it")
    return cam
