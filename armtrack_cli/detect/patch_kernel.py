"""One tracked frame of the wrist patch compiled with numba: what patch_tracker's OpenCV path
(patch_tracker.track_reference) does on the search region, in a few passes over its pixels
with no per-frame allocation but the small Look it returns:

- I420 (or BGR) → HSV of the region only: OpenCV's YUV2BGR_I420 (ITU-R BT.601 limited range,
  its fixed-point coefficients, shift 20) then its integer BGR2HSV (palm_blob_kernel._hsv);
  tests hold both equal to cv2.cvtColor on every colour they can meet;
- the S/V-masked hue range mask (colour.range_mask) and its 3 x 3 opening (cv2.morphologyEx,
  the region's edge as the image's: pixels outside are ignored);
- CamShift (Bradski 1998; OpenCV's cv::meanShift and cv::CamShift, their roundings kept:
  detect/camshift_kernel.py);
- the region under CamShift's centre (8-connected, as detect/regions.py labels it), its area,
  centroid, box and hue counts for the appearance check (detect/patch_check.look);
- while re-acquiring, the whole frame's hue and opened mask (patch_masks.patch_mask) and its
  box, for the acquiring pass.

Most of the search window is not the patch's colour: a per-range table (chroma_table) says
which (U, V) can be in range at any luma, and only the 2 x 2 blocks it keeps are converted.

``cache=True``: the compile happens once per install and is loaded from __pycache__.
"""

from __future__ import annotations

import functools

import cv2
import numpy as np
from numba import njit

from armtrack_cli.detect.camshift_kernel import camshift, region_at
from armtrack_cli.detect.colour import HUE_BINS
from armtrack_cli.detect.palm_blob_kernel import HDIV, SDIV, _hsv, _maybe_row, prefilter_bounds
from armtrack_cli.detect.patch_acquire_kernel import FrameRegions, Labels, regions_of
from armtrack_cli.detect.patch_check import Look, aspect_of
from armtrack_cli.detect.yuv_pixel import i420_bgr
from armtrack_cli.vision.yuv import YuvFrame

NITERS = 10  # patch_tracker.TERM's iterations (its eps 0.5 rounds to 0 in cv::meanShift)
FAIL, OK = 0.0, 1.0
RES = 14  # status, cx, cy, width, height, angle, wx, wy, ww, wh, area, u, v, cut


class Work:
    """Work arrays for search regions of up to (height, width) pixels: hue, mask, opening's
    scratch, the region's flood-fill marks and stack, its hue counts and the result row."""

    def __init__(self, height: int, width: int):
        self.shape = (height, width)
        self.hue = np.empty((height, width), np.uint8)
        self.mask = np.empty((height, width), np.uint8)
        self.tmp = np.empty((height, width), np.uint8)
        self.seen = np.zeros((height, width), np.uint8)  # all zero between calls
        self.stack = np.empty(height * width, np.int32)
        self.counts = np.zeros(HUE_BINS, np.int64)
        self.row = np.empty(3 * width + 8, np.uint8)
        self.maybe = np.zeros(width + 8, np.uint8)
        self.cols = np.empty(width // 2 + 2, np.int64)
        self.res = np.zeros(RES)


@njit(cache=True, inline="always")
def _in_range(h, s, v, rng):
    """colour.range_mask on one pixel: rng = (h_lo, s_lo, v_lo, h_hi, s_hi, v_hi), the hue
    range wrapping through red when h_lo > h_hi."""
    if s < rng[1] or s > rng[4] or v < rng[2] or v > rng[5]:
        return False
    if rng[0] <= rng[3]:
        return rng[0] <= h <= rng[3]
    return h >= rng[0] or h <= rng[3]


@njit(cache=True)
def chroma_table(rng):
    """(256, 256) uint8: 1 where some luma Y makes (Y, U, V) in range rng (the 2 x 2 blocks
    of other chroma hold no pixel of the patch's colour and are skipped), 0 elsewhere.
    Exact: every Y is tried (below 16 all convert as 16)."""
    out = np.zeros((256, 256), np.uint8)
    for u in range(256):
        for v in range(256):
            for yy in range(16, 256):
                b, g, r = i420_bgr(yy, u, v)
                h, s, val = _hsv(b, g, r, SDIV, HDIV)
                if _in_range(h, s, val, rng):
                    out[u, v] = 1
                    break
    return out


def chroma_bounds(table: np.ndarray) -> np.ndarray:
    """(u0, du, v0, dv) int64: every 1 of ``table`` (chroma_table) has u0 ≤ U ≤ u0 + du and
    v0 ≤ V ≤ v0 + dv (du = dv = -1 when it has none)."""
    us, vs = np.nonzero(table)
    if us.size == 0:
        return np.array([0, -1, 0, -1], np.int64)
    return np.array([us.min(), us.max() - us.min(), vs.min(), vs.max() - vs.min()], np.int64)


@njit(cache=True, nogil=True)
def hsv_mask_i420(yp, up, vp, x0, y0, x1, y1, rng, table, bounds, hue, mask, cols):
    """hue[:h, :w] and the range mask (255 in range) of the frame's [y0:y1, x0:x1], the hue
    only where the mask is 255: each pixel converted (OpenCV's YUV2BGR_I420, then BGR2HSV)
    only where its chroma's ``table`` (chroma_table(rng)) entry is 1, looked up only for
    chroma inside ``bounds`` (chroma_bounds(table): most of a frame is outside, and the
    test costs less than the table's read) (``cols``: scratch of a chroma row's length).
    Returns the box (c0, r0, c1, r1) of the mask's pixels (c1 = 0 when there are none)."""
    c0, r0, c1, r1 = x1 - x0, y1 - y0, 0, 0
    for r in range(y1 - y0):
        mask[r, :x1 - x0] = 0
    # the bounds as uint8: U - u0 wraps below u0, so one unsigned test each (vectorised); with
    # no bounds (du = -1: 255) every block is looked up in the table
    u0, du = np.uint8(bounds[0]), np.uint8(bounds[1] & 255)
    v0, dv = np.uint8(bounds[2]), np.uint8(bounds[3] & 255)
    ca, cb = x0 >> 1, ((x1 - 1) >> 1) + 1  # the chroma columns
    for cy in range(y0 >> 1, ((y1 - 1) >> 1) + 1):
        urow, vrow = up[cy], vp[cy]
        some = 0
        for j in range(cb - ca):  # the 2 x 2 blocks inside the bounds, flagged in cols
            f = (np.uint8(urow[ca + j] - u0) <= du) & (np.uint8(vrow[ca + j] - v0) <= dv)
            cols[j] = f
            some |= f
        n = 0
        if some:
            for j in range(cb - ca):  # … and kept where the table has them (n <= j: in place)
                if cols[j] and table[urow[ca + j], vrow[ca + j]]:
                    cols[n] = ca + j
                    n += 1
        for y in range(max(2 * cy, y0), min(2 * cy + 2, y1)):
            r = y - y0
            for k in range(n):
                cx = cols[k]
                u, v = np.int64(urow[cx]), np.int64(vrow[cx])
                for x in range(max(2 * cx, x0), min(2 * cx + 2, x1)):
                    b, g, rr = i420_bgr(np.int64(yp[y, x]), u, v)
                    h, s, val = _hsv(b, g, rr, SDIV, HDIV)
                    if _in_range(h, s, val, rng):
                        c = x - x0
                        hue[r, c], mask[r, c] = h, 255
                        c0, r0, c1, r1 = min(c0, c), min(r0, r), max(c1, c + 1), max(r1, r + 1)
    return c0, r0, c1, r1


@njit(cache=True, nogil=True)
def _mask_row(row, n, rng, pre, maybe, hue, mask, r):
    """Hue and range mask (255 in range) of a flat BGR row of n pixels into hue[r], mask[r]:
    palm_blob_kernel._maybe_row's vectorised superset first, the exact test on what it
    keeps (elsewhere the mask is 0 and the hue is not needed)."""
    _maybe_row(row, n, pre, maybe)
    for c in range(n):
        if not maybe[c]:
            mask[r, c] = 0
            continue
        h, s, v = _hsv(np.int64(row[3 * c]), np.int64(row[3 * c + 1]), np.int64(row[3 * c + 2]),
                       SDIV, HDIV)
        hue[r, c] = h
        mask[r, c] = 255 if _in_range(h, s, v, rng) else 0


@njit(cache=True, nogil=True)
def hsv_mask_bgr(bgr, x0, y0, x1, y1, rng, pre, row, maybe, hue, mask):
    """hsv_mask_i420 for a BGR image."""
    for r in range(y1 - y0):
        for c in range(3 * (x1 - x0)):
            row[c] = bgr[y0 + r, x0 + c // 3, c % 3]
        _mask_row(row, x1 - x0, rng, pre, maybe, hue, mask, r)
    c0, r0, c1, r1 = x1 - x0, y1 - y0, 0, 0
    for r in range(y1 - y0):
        for c in range(x1 - x0):
            if mask[r, c]:
                c0, r0, c1, r1 = min(c0, c), min(r0, r), max(c1, c + 1), max(r1, r + 1)
    return c0, r0, c1, r1


@njit(cache=True, nogil=True)
def _across(src, dst, h, w, erode):
    """dst[:h, :w] = the minimum (erode) or maximum of each pixel of src and its left and right
    neighbours (those outside ignored); branch-free inner loops, which LLVM vectorises."""
    for r in range(h):
        a, d = src[r], dst[r]
        if w == 1:
            d[0] = a[0]
            continue
        if erode:
            d[0], d[w - 1] = min(a[0], a[1]), min(a[w - 2], a[w - 1])
            for c in range(1, w - 1):
                d[c] = min(a[c - 1], min(a[c], a[c + 1]))
        else:
            d[0], d[w - 1] = max(a[0], a[1]), max(a[w - 2], a[w - 1])
            for c in range(1, w - 1):
                d[c] = max(a[c - 1], max(a[c], a[c + 1]))


@njit(cache=True, nogil=True)
def _down(src, dst, h, w, erode):
    """dst[:h, :w] = the minimum (erode) or maximum of each pixel of src and its upper and
    lower neighbours (those outside ignored), row by row (contiguous, vectorised)."""
    for r in range(h):
        up, mid, dn = src[max(r - 1, 0)], src[r], src[min(r + 1, h - 1)]
        d = dst[r]
        if erode:
            for c in range(w):
                d[c] = min(up[c], min(mid[c], dn[c]))
        else:
            for c in range(w):
                d[c] = max(up[c], max(mid[c], dn[c]))


@njit(cache=True, nogil=True)
def open3(mask, tmp, h, w):
    """mask[:h, :w] opened by a 3 x 3 square in place (erode, then dilate; pixels outside the
    region are ignored, as cv2.morphologyEx's default border does): each a pass across the
    rows and one down the columns (the square is separable), through ``tmp``."""
    _across(mask, tmp, h, w, True)
    _down(tmp, mask, h, w, True)
    _across(mask, tmp, h, w, False)
    _down(tmp, mask, h, w, False)


@njit(cache=True, nogil=True)
def opened_box(mask, tmp, H, W, box):
    """mask[:H, :W] opened (open3) on ``box`` (c0, r0, c1, r1: its pixels' box) grown by 2 px,
    outside which the opening is 0 anyway; returns the opened mask's box (x, y, w, h), as
    cv2.boundingRect gives it ((0, 0, 0, 0) when empty)."""
    c0, r0, c1, r1 = box
    if c1 == 0:
        return 0, 0, 0, 0
    c0, r0, c1, r1 = max(c0 - 2, 0), max(r0 - 2, 0), min(c1 + 2, W), min(r1 + 2, H)
    open3(mask[r0:r1, c0:c1], tmp[r0:r1, c0:c1], r1 - r0, c1 - c0)
    x0, y0, x1, y1 = W, H, 0, 0
    for r in range(r0, r1):
        for c in range(c0, c1):
            if mask[r, c]:
                x0, y0, x1, y1 = min(x0, c), min(y0, r), max(x1, c + 1), max(y1, r + 1)
    if x1 == 0:
        return 0, 0, 0, 0
    return x0, y0, x1 - x0, y1 - y0


@njit(cache=True, nogil=True)
def track_tail(hue, mask, tmp, H, W, box, sx, sy, sw, sh, niters, seen, stack, counts, res):
    """After the HSV pass (``box``: its mask's box): the opening, CamShift from window (sx,
    sy, sw, sh), and the region under its centre (res as camshift and region_at fill it;
    res[0] = OK, or FAIL when there is no mass or the centre is outside the region or off the
    mask). The opening is done on the box grown by 2 px, outside which it is 0 anyway (as
    patch_masks.patch_mask does)."""
    res[0] = FAIL
    c0, r0, c1, r1 = box
    if c1 == 0:
        return
    c0, r0, c1, r1 = max(c0 - 2, 0), max(r0 - 2, 0), min(c1 + 2, W), min(r1 + 2, H)
    open3(mask[r0:r1, c0:c1], tmp[r0:r1, c0:c1], r1 - r0, c1 - c0)
    if not camshift(mask, H, W, sx, sy, sw, sh, niters, res):
        return
    cx, cy = res[1], res[2]
    if not (0 <= cx < W and 0 <= cy < H) or mask[int(cy), int(cx)] == 0:
        return
    counts[:] = 0
    region_at(mask, H, W, int(cx), int(cy), seen, stack, counts, hue, res, (c0, r0, c1, r1))
    res[0] = OK


@functools.lru_cache(maxsize=8)
def _chroma_table(rng: tuple) -> tuple[np.ndarray, np.ndarray]:
    """chroma_table and its chroma_bounds, once per colour range in a process (about 0.1 s)."""
    table = chroma_table(np.array(rng, np.int64))
    table.flags.writeable = False
    return table, chroma_bounds(table)


@njit(cache=True, nogil=True)
def track_i420(yp, up, vp, x0, y0, x1, y1, rng, table, bounds, hue, mask, tmp, cols, start,
               niters, seen, stack, counts, res):
    """hsv_mask_i420 then track_tail, in one call (one dispatch from Python a frame)."""
    box = hsv_mask_i420(yp, up, vp, x0, y0, x1, y1, rng, table, bounds, hue, mask, cols)
    track_tail(hue, mask, tmp, y1 - y0, x1 - x0, box, start[0], start[1], start[2], start[3],
               niters, seen, stack, counts, res)


class WindowTracker:
    """PatchTracker's tracked frame by the kernel: ``track`` returns what
    patch_tracker.track_reference returns (CamShift's box and window in the search region's
    pixels, and patch_check.Look of the region under its centre), or None."""

    def __init__(self, low, high):
        self.rng = np.array([*(int(v) for v in low), *(int(v) for v in high)], np.int64)
        self.pre = prefilter_bounds(self.rng)
        self.table, self.bounds = _chroma_table(tuple(self.rng))
        self.work: Work | None = None
        self.labels: Labels | None = None

    def _work(self, frame) -> Work:
        k = self.work
        if k is None or k.shape[0] < frame.shape[0] or k.shape[1] < frame.shape[1]:
            k = self.work = Work(*frame.shape[:2])
        return k

    def whole_mask(self, frame: YuvFrame) -> tuple[np.ndarray, np.ndarray, tuple]:
        """The whole frame's hue (valid where the mask is 255), its opened range mask
        (patch_masks.patch_mask of its HSV; views of work arrays, valid until the next call)
        and the mask's box (x, y, w, h) as cv2.boundingRect gives it."""
        k, (H, W) = self._work(frame), frame.shape[:2]
        box = hsv_mask_i420(frame.y, frame.u, frame.v, 0, 0, W, H, self.rng, self.table,
                            self.bounds, k.hue, k.mask, k.cols)
        return k.hue[:H, :W], k.mask[:H, :W], opened_box(k.mask, k.tmp, H, W, box)

    def whole_regions(self, frame, min_area: int, hsv_mask=None) -> FrameRegions:
        """The acquiring pass on the whole frame: the regions of its opened mask (whole_mask
        of a YuvFrame, else ``hsv_mask`` = (HSV image, its opened mask) as given) with the
        CamShift box and look of each of min_area pixels or more."""
        H, W = frame.shape[:2]
        if hsv_mask is None:
            hue, mask, box = self.whole_mask(frame)
        else:
            hue, mask = hsv_mask[0][:, :, 0], hsv_mask[1]
            box = cv2.boundingRect(mask)
        lab = self.labels
        if lab is None or lab.shape[0] < H or lab.shape[1] < W:
            lab = self.labels = Labels(H, W)
        found = regions_of(mask, hue, *box, min_area, lab.labels, lab.parent, lab.res)
        return FrameRegions(found, (H, W))

    def track(self, frame, box, start):
        x0, y0, x1, y1 = box
        H, W = y1 - y0, x1 - x0
        k = self._work(frame)
        if isinstance(frame, YuvFrame):
            track_i420(frame.y, frame.u, frame.v, x0, y0, x1, y1, self.rng, self.table,
                       self.bounds, k.hue, k.mask, k.tmp, k.cols, start, NITERS, k.seen, k.stack,
                       k.counts, k.res)
        else:
            box = hsv_mask_bgr(frame, x0, y0, x1, y1, self.rng, self.pre, k.row, k.maybe,
                               k.hue, k.mask)
            track_tail(k.hue, k.mask, k.tmp, H, W, box, *start, NITERS, k.seen, k.stack,
                       k.counts, k.res)
        res = k.res
        if res[0] == FAIL:
            return None
        hist = k.counts.astype(np.float32)  # the shape calcHist gives for one channel
        total = float(hist.sum())  # as colour.hue_distribution normalises calcHist's counts
        seen = Look(float(res[10]), aspect_of(res[3], res[4]), hist / total if total > 0
                    else hist, (float(res[11]), float(res[12])), bool(res[13]))
        rect = ((float(res[1]), float(res[2])), (float(res[3]), float(res[4])), float(res[5]))
        return rect, (int(res[6]), int(res[7]), int(res[8]), int(res[9])), seen
