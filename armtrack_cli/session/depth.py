"""RGB-D depth frames: depth/NNNNNN.png, 16-bit, millimetres along the optical axis,
0 = no reading (SESSION_FORMAT.md). In armtrack: metres, NaN = no reading."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from armtrack_cli.core.errors import DataError
from armtrack_cli.session.outputs import atomic_write

MAX_MM = 65535


def depth_path(folder: str | Path, frame: int) -> Path:
    return Path(folder) / "depth" / f"{frame:06d}.png"


def write_depth_png(path: str | Path, depth_m: np.ndarray) -> Path:
    mm = np.where(np.isfinite(depth_m), np.round(depth_m * 1000.0), 0)
    img = np.clip(mm, 0, MAX_MM).astype(np.uint16)

    def write(tmp: Path) -> None:
        if not cv2.imwrite(str(tmp), img, [cv2.IMWRITE_PNG_COMPRESSION, 9]):
            raise DataError(path, "OpenCV could not write the PNG")

    return atomic_write(path, write)


def read_depth_png(path: str | Path, size: tuple[int, int] | None = None) -> np.ndarray:
    """(H, W) depth in metres, NaN where the sensor gave no reading; with ``size`` (the
    video's width, height) one of another size is refused: it is not registered to the
    video's pixels, and its depths would be read under the wrong ones."""
    path = Path(path)
    if not path.is_file():
        raise DataError(path, "not found", "depth frames are depth/000000.png, depth/000001.png, …")
    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise DataError(path, "is not an image OpenCV can read")
    if img.dtype != np.uint16 or img.ndim != 2:
        raise DataError(path, f"is {img.dtype} with {1 if img.ndim == 2 else img.shape[2]} "
                        "channel(s); depth frames are single-channel 16-bit PNG in mm")
    if size is not None and img.shape[::-1] != tuple(size):
        raise DataError(path, f"is {img.shape[1]}x{img.shape[0]}, the video {size[0]}x{size[1]}",
                        "depth frames are registered to the video's pixels (export the depth "
                        "aligned to colour)")
    return np.where(img > 0, img.astype(float) / 1000.0, np.nan)


def read_depth_frame(session_root: str | Path, frame: int,
                     size: tuple[int, int] | None = None) -> np.ndarray | None:
    """Frame ``frame``'s depth in metres, or None when the session has no depth for it."""
    path = depth_path(session_root, frame)
    return read_depth_png(path, size) if path.exists() else None


def count_depth_frames(session_root: str | Path) -> int | None:
    """How many depth/NNNNNN.png frames the session has (None: no depth/ folder). PNGs there
    none of which is so named are an error: armtrack would run without depth, silently."""
    folder = Path(session_root) / "depth"
    if not folder.is_dir():
        return None
    pngs = [p.name for p in folder.iterdir() if p.suffix.lower() == ".png"]
    n = sum(len(name) == 10 and name[:6].isdigit() and name.endswith(".png") for name in pngs)
    if pngs and n == 0:
        raise DataError(folder, f"holds {len(pngs)} PNGs (such as {sorted(pngs)[0]}) but none "
                        "named as armtrack reads them", "depth frames are depth/000000.png, "
                        "depth/000001.png, … numbered from the video's first frame")
    return n
