"""The acquiring pass's mask of the patch's colour over the whole frame (patch_tracker): the
S/V-masked hue back-projection, opened, computed at full resolution only where a
half-resolution pass finds the colour."""

from __future__ import annotations

import cv2
import numpy as np

from armtrack_cli.detect.colour import range_mask

OPEN3 = np.ones((3, 3), np.uint8)  # the opening that drops speckle


def back_projection(hsv: np.ndarray, hist: np.ndarray, low, high) -> np.ndarray:
    """Hue back-projection masked by the S and V limits (and opened to drop speckle)."""
    bp = cv2.calcBackProject([hsv], [0], hist, [0, 180], 1)
    sv = cv2.inRange(hsv, (0, int(low[1]), int(low[2])), (180, int(high[1]), int(high[2])))
    return cv2.morphologyEx(cv2.bitwise_and(bp, sv), cv2.MORPH_OPEN, OPEN3)


def patch_mask(hsv: np.ndarray, low, high) -> np.ndarray:
    """back_projection with the patch's histogram (255 on its hue range, 0 elsewhere:
    colour.hue_histogram) in one pass: the back-projection is then 255 exactly where the hue
    is in range, so masked by S and V it is the HSV range mask. The opening (3 x 3) is done on
    the box around the mask's pixels grown by 2 px, outside which it is 0 anyway (tests check
    the equality with back_projection)."""
    raw = range_mask(hsv, low, high)
    x, y, w, h = cv2.boundingRect(raw)
    if w == 0:
        return raw
    H, W = raw.shape
    y0, y1, x0, x1 = max(0, y - 2), min(H, y + h + 2), max(0, x - 2), min(W, x + w + 2)
    out = np.zeros_like(raw)
    out[y0:y1, x0:x1] = cv2.morphologyEx(raw[y0:y1, x0:x1], cv2.MORPH_OPEN, OPEN3)
    return out


def sparse_patch_mask(bgr: np.ndarray, low, high, hsv_out: np.ndarray,
                      mask_out: np.ndarray) -> None:
    """patch_mask(cvtColor(bgr)) into ``mask_out``, computed at full resolution only in boxes
    around what a half-resolution pass (every other row and column) finds; ``hsv_out`` gets
    the HSV image inside those boxes (elsewhere it is stale). Exact: a pixel the 3 x 3
    opening keeps lies in a 3 x 3 block of in-range pixels, which holds a pixel of even row
    and column, so within 2 px of one the half-resolution pass sees; each box covers those by
    2 px more, for the opening's own reach (tests check the equality with patch_mask)."""
    mask_out.fill(0)
    H, W = mask_out.shape
    # nearest-neighbour halving takes one pixel of every 2 x 2 block (even row and column)
    small = cv2.cvtColor(cv2.resize(bgr, ((W + 1) // 2, (H + 1) // 2),
                                    interpolation=cv2.INTER_NEAREST), cv2.COLOR_BGR2HSV)
    seen = cv2.dilate(range_mask(small, low, high), OPEN3)  # neighbours share a box
    outlines, _ = cv2.findContours(seen, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    for x, y, w, h in map(cv2.boundingRect, outlines):  # each 8-connected group's box
        # sampled pixels at full-res 2x (or 2x + 1) … 2(x + w - 1) (+ 1); kept pixels within 2
        # of them (inner), the opening reads 2 px further (outer)
        ix0, iy0, ix1, iy1 = max(2 * x - 2, 0), max(2 * y - 2, 0), min(2 * (x + w) + 2, W), \
            min(2 * (y + h) + 2, H)
        ox0, oy0, ox1, oy1 = max(ix0 - 2, 0), max(iy0 - 2, 0), min(ix1 + 2, W), min(iy1 + 2, H)
        hsv = cv2.cvtColor(bgr[oy0:oy1, ox0:ox1], cv2.COLOR_BGR2HSV)
        hsv_out[oy0:oy1, ox0:ox1] = hsv
        opened = cv2.morphologyEx(range_mask(hsv, low, high), cv2.MORPH_OPEN, OPEN3)
        inner = opened[iy0 - oy0:iy1 - oy0, ix0 - ox0:ix1 - ox0]
        np.bitwise_or(mask_out[iy0:iy1, ix0:ix1], inner, out=mask_out[iy0:iy1, ix0:ix1])
