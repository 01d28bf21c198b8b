"""OpenCV's I420 → BGR of one pixel, compiled (the fixed-point arithmetic of its YUV2BGR_I420,
ITU-R BT.601 limited range), for the kernels that convert only the pixels they look at: the
patch tracker's window (patch_kernel.py) and the palm blobs' (palm_blob_i420.py). Tested equal
to cv2.cvtColor on every (Y, U, V)."""

from __future__ import annotations

from numba import njit

# OpenCV's YUV420 -> RGB, coefficients x 2^20: R = 1.164 (Y - 16) + 1.596 (V - 128),
# G = 1.164 (Y - 16) - 0.813 (V - 128) - 0.391 (U - 128), B = 1.164 (Y - 16) + 2.018 (U - 128)
SHIFT, CY, CUB, CUG, CVG, CVR = 20, 1220542, 2116026, -409993, -852492, 1673527


@njit(cache=True, inline="always")
def i420_bgr(y, u, v):
    """OpenCV's I420 -> BGR of one pixel: luma y, its block's chroma u, v (0-255 each)."""
    yy = max(y - 16, 0) * CY
    half = 1 << (SHIFT - 1)
    b = (yy + CUB * (u - 128) + half) >> SHIFT
    g = (yy + CVG * (v - 128) + CUG * (u - 128) + half) >> SHIFT
    r = (yy + CVR * (v - 128) + half) >> SHIFT
    return min(max(b, 0), 255), min(max(g, 0), 255), min(max(r, 0), 255)
