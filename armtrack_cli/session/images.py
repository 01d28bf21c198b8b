"""Still images: the board pictures in calib/ for intrinsic calibration."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from armtrack_cli.core.errors import DataError

IMAGE_EXT = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")


def read_images(folder: str | Path) -> list[tuple[Path, np.ndarray]]:
    import cv2  # here, not at the top: `armtrack info` lists images without OpenCV

    folder = Path(folder)
    paths = sorted(p for p in folder.iterdir() if p.suffix.lower() in IMAGE_EXT)
    if not paths:
        raise DataError(folder, "holds no board images (.png, .jpg, …)",
                        "put 10-25 pictures of the ChArUco board here, or give intrinsics.yaml")
    out = []
    for p in paths:
        img = cv2.imread(str(p), cv2.IMREAD_COLOR)
        if img is None:
            raise DataError(p, "is not an image OpenCV can read")
        out.append((p, img))
    return out


def write_image(path: str | Path, image: np.ndarray) -> Path:
    import cv2

    from armtrack_cli.session.outputs import atomic_write

    def write(tmp: Path) -> None:
        if not cv2.imwrite(str(tmp), image):
            raise DataError(path, "OpenCV could not write the image")

    return atomic_write(path, write)
