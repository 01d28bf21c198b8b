"""A decoded video frame kept as its I420 planes (Y at full resolution, U and V at half), so
that a detector converts to BGR only the window it searches, not the whole image.

Most camera videos (MPEG-4, H.264 at 4:2:0) decode to I420; converting a whole 640 x 480
frame to BGR costs about as much as a windowed detector's own work. The conversion here is
OpenCV's I420 one (ITU-R BT.601, limited range, each 2 x 2 block sharing its chroma): a
window with even corners converts exactly as the same pixels of the whole frame do (tests
check it), and the whole frame differs from FFmpeg's swscale conversion by at most a few
levels (rounding).
"""

from __future__ import annotations

import cv2
import numpy as np


class YuvFrame:
    """One frame's Y (H, W), U and V ((H + 1) // 2, (W + 1) // 2) planes, uint8, any row
    strides. ``shape`` is that of its BGR image, (H, W, 3)."""

    __slots__ = ("y", "u", "v", "shape", "_bgr")

    def __init__(self, y: np.ndarray, u: np.ndarray, v: np.ndarray):
        self.y, self.u, self.v = y, u, v
        self.shape = (y.shape[0], y.shape[1], 3)
        self._bgr: np.ndarray | None = None

    def bgr(self) -> np.ndarray:
        """The whole frame in BGR (converted once, then kept)."""
        if self._bgr is None:
            self._bgr = crop_to_bgr(self, 0, 0, self.shape[1], self.shape[0])
        return self._bgr


def _i420_buffer(f: YuvFrame, x0: int, y0: int, x1: int, y1: int) -> np.ndarray:
    """The planes of [y0:y1, x0:x1] (even corners, even sizes) packed as one I420 image."""
    h, w = y1 - y0, x1 - x0
    buf = np.empty((h * 3 // 2, w), np.uint8)
    buf[:h] = f.y[y0:y1, x0:x1]
    flat = buf.reshape(-1)
    q = (h // 2) * (w // 2)
    flat[h * w:h * w + q].reshape(h // 2, w // 2)[:] = f.u[y0 // 2:y1 // 2, x0 // 2:x1 // 2]
    flat[h * w + q:].reshape(h // 2, w // 2)[:] = f.v[y0 // 2:y1 // 2, x0 // 2:x1 // 2]
    return buf


def crop_to_bgr(f: YuvFrame, x0: int, y0: int, x1: int, y1: int) -> np.ndarray:
    """BGR (y1 - y0, x1 - x0, 3) of the frame's pixels [y0:y1, x0:x1]: the box is grown to even
    corners (inside the image; an odd-sized image's last row or column is converted by
    repeating its neighbour) for the 2 x 2 chroma blocks, converted, and cut back."""
    H, W = f.shape[:2]
    ex0, ey0 = x0 & ~1, y0 & ~1
    ex1, ey1 = min(x1 + (x1 & 1), W & ~1), min(y1 + (y1 & 1), H & ~1)
    if ex1 < x1 or ey1 < y1:  # odd image size: the last row/column is outside any even box
        return _odd_crop(f, x0, y0, x1, y1)
    bgr = cv2.cvtColor(_i420_buffer(f, ex0, ey0, ex1, ey1), cv2.COLOR_YUV2BGR_I420)
    return bgr[y0 - ey0:y1 - ey0, x0 - ex0:x1 - ex0]


def _odd_crop(f: YuvFrame, x0: int, y0: int, x1: int, y1: int) -> np.ndarray:
    """crop_to_bgr for an image of odd width or height: its planes padded to even size first."""
    H, W = f.shape[:2]
    he, we = H + (H & 1), W + (W & 1)
    y = np.pad(f.y, ((0, he - H), (0, we - W)), mode="edge")
    padded = YuvFrame(y, f.u[:he // 2, :we // 2], f.v[:he // 2, :we // 2])
    return crop_to_bgr(padded, x0, y0, x1, y1)


def window_bgr(frame, x0: int, y0: int, x1: int, y1: int) -> np.ndarray:
    """[y0:y1, x0:x1] of a frame given as a BGR image or as a YuvFrame, in BGR."""
    if isinstance(frame, YuvFrame):
        return crop_to_bgr(frame, x0, y0, x1, y1)
    return frame[y0:y1, x0:x1]


def whole_bgr(frame) -> np.ndarray:
    """A frame given as a BGR image or as a YuvFrame, in BGR."""
    return frame.bgr() if isinstance(frame, YuvFrame) else frame
