"""Write frames to a video file (MPEG-4 Part 2 in .mp4, readable by OpenCV's FFmpeg)."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from pathlib import Path

import cv2
import numpy as np

from armtrack_cli.core.errors import OutputError


def write_video(path: str | Path, frames: Iterable[tuple[int, np.ndarray]], *, fps: float,
                size: tuple[int, int], on_frame: Callable[[int], None] | None = None) -> int:
    """Stream (index, BGR image) frames into ``path``; returns the number written."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), fps, size)
    if not writer.isOpened():
        raise OutputError(path, "OpenCV cannot open an MPEG-4 writer here")
    n = 0
    try:
        for _, img in frames:
            writer.write(img)
            n += 1
            if on_frame:
                on_frame(n)
    finally:
        writer.release()
    return n
