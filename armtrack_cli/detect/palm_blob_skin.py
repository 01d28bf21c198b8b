"""The hand's skin mask at half resolution (palm_blobs.hand_roi) straight from a frame's I420
planes, compiled with numba: the mask OpenCV gives for the frame converted to BGR
(cv2.COLOR_YUV2BGR_I420), halved (cv2.resize, INTER_AREA) and thresholded in YCrCb
(cv2.COLOR_BGR2YCrCb, cv2.inRange), without the frame's BGR image, its half-size copy or
its YCrCb image, in one pass over the planes.

- Each pixel's BGR is OpenCV's I420 conversion (yuv_pixel.i420_bgr).
- INTER_AREA at a scale of exactly 1/2 is the mean of each 2 x 2 block rounded half up,
  (a + b + c + d + 2) >> 2 (OpenCV's resizeAreaFast).
- YCrCb is OpenCV's 8-bit RGB2YCrCb_i: 14-bit fixed point, Y = 0.299 R + 0.587 G + 0.114 B,
  Cr = 0.713 (R - Y) + 128, Cb = 0.564 (B - Y) + 128, each rounded and saturated.

tests/test_palm_blob_skin.py holds the YCrCb test equal to OpenCV's on all 2^24 colours and
the mask equal to OpenCV's on random planes and on the sample session's frames.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from armtrack_cli.detect.yuv_pixel import i420_bgr

# OpenCV's RGB2YCrCb_i coefficients x 2^14 (color_yuv: R2Y, G2Y, B2Y, YCRI, YCBI)
YCC_SHIFT, R2Y, G2Y, B2Y, CR, CB = 14, 4899, 9617, 1868, 11682, 9241


@njit(cache=True, inline="always")
def ycrcb_inside(b, g, r, y_lo, cr_lo, cb_lo, y_hi, cr_hi, cb_hi):
    """cv2.inRange(cv2.cvtColor(BGR, COLOR_BGR2YCrCb), low, high) of one 8-bit pixel, low =
    (y_lo, cr_lo, cb_lo), high = (y_hi, cr_hi, cb_hi)."""
    half, delta = 1 << (YCC_SHIFT - 1), 128 << YCC_SHIFT
    y = (b * B2Y + g * G2Y + r * R2Y + half) >> YCC_SHIFT
    cr = min(max(((r - y) * CR + delta + half) >> YCC_SHIFT, 0), 255)
    cb = min(max(((b - y) * CB + delta + half) >> YCC_SHIFT, 0), 255)
    return ((y_lo <= y) & (y <= y_hi) & (cr_lo <= cr) & (cr <= cr_hi) & (cb_lo <= cb)
            & (cb <= cb_hi))  # no branches: the loop vectorises


@njit(cache=True, inline="always")
def _block_sums(y00, y01, y10, y11, u, v):
    """The sums of the 2 x 2 block's BGR (luma y.., chroma u, v) + 2 each."""
    b0, g0, r0 = i420_bgr(y00, u, v)
    b1, g1, r1 = i420_bgr(y01, u, v)
    b2, g2, r2 = i420_bgr(y10, u, v)
    b3, g3, r3 = i420_bgr(y11, u, v)
    return b0 + b1 + b2 + b3 + 2, g0 + g1 + g2 + g3 + 2, r0 + r1 + r2 + r3 + 2


@njit(cache=True, nogil=True)
def skin_half(yp, up, vp, bounds, out):
    """out (H / 2, W / 2) uint8: 255 where the frame's 2 x 2 block (planes yp (H, W), up, vp
    (H / 2, W / 2), H and W even), converted to BGR and averaged as INTER_AREA halves it, is
    in the YCrCb range bounds (ycrcb_inside), else 0."""
    y_lo, cr_lo, cb_lo, y_hi, cr_hi, cb_hi = (bounds[0], bounds[1], bounds[2], bounds[3],
                                              bounds[4], bounds[5])
    for by in range(out.shape[0]):
        r0, r1 = yp[2 * by], yp[2 * by + 1]
        urow, vrow, orow = up[by], vp[by], out[by]
        for bx in range(out.shape[1]):
            sb, sg, sr = _block_sums(np.int64(r0[2 * bx]), np.int64(r0[2 * bx + 1]),
                                     np.int64(r1[2 * bx]), np.int64(r1[2 * bx + 1]),
                                     np.int64(urow[bx]), np.int64(vrow[bx]))
            orow[bx] = 255 * ycrcb_inside(sb >> 2, sg >> 2, sr >> 2, y_lo, cr_lo, cb_lo, y_hi,
                                         cr_hi, cb_hi)
