"""The acquiring pass's regions compiled with numba: what patch_tracker's OpenCV path does
with the whole frame's opened mask (detect/regions.Regions, then for each region of
``min_area`` pixels or more region_rect's CamShift on the region alone and patch_check.look's
hue counts), in one labelling pass over the mask's box and one pass over each such region's
box:

- 8-connected labelling by union-find (Rosenheld's two-pass scheme on pixels), the regions
  numbered as OpenCV's block-based labelling numbers them (by their first 2 x 2 block in
  raster order, the blocks aligned to the box's even corner, as Regions aligns them);
- each region's stats (x, y, w, h, area) and centroid, computed as OpenCV computes them (the
  coordinate sums from the even corner, divided by the area, plus the corner);
- for each region of ``min_area`` pixels or more, CamShift (detect/camshift_kernel.py, equal
  to cv2.CamShift) on its 0/1 mask inside its box from the whole box, and its hue counts.

tests/test_patch_acquire.py holds every number equal to the OpenCV path's.
``cache=True``: the compile happens once per install and is loaded from __pycache__.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from armtrack_cli.detect.camshift_kernel import box_of
from armtrack_cli.detect.colour import HUE_BINS
from armtrack_cli.detect.palm_blob_kernel import _find, _union
from armtrack_cli.detect.patch_check import Look, aspect_of

STATS = 5  # x, y, w, h, area: cv2.connectedComponentsWithStats' columns
RECT = 5  # CamShift's box in whole-image px: centre u, v, width, height, angle (deg)


class Labels:
    """Work arrays for frames of up to (height, width) pixels: provisional labels, union-find
    parents and CamShift's result row."""

    def __init__(self, height: int, width: int):
        self.shape = (height, width)
        self.labels = np.empty((height, width), np.int32)
        self.parent = np.empty(height * width // 2 + 2, np.int32)
        self.res = np.zeros(14)


@njit(cache=True, nogil=True)
def _label(mask, x, y, w, h, labels, parent):
    """Provisional labels (1 …) of mask's non-zero pixels in the box, 8-connected neighbours
    already scanned (west, north-west, north, north-east) joined in ``parent``; returns how
    many were given. ``labels`` is read only where ``mask`` is non-zero."""
    n = 0
    for r in range(y, y + h):
        for c in range(x, x + w):
            if mask[r, c] == 0:
                continue
            lab = labels[r, c - 1] if c > x and mask[r, c - 1] else 0
            if r > y:
                for cc in range(max(c - 1, x), min(c + 2, x + w)):
                    if mask[r - 1, cc]:
                        up = labels[r - 1, cc]
                        if lab == 0:
                            lab = up
                        elif up != lab:
                            _union(parent, lab, up)
            if lab == 0:
                n += 1
                parent[n] = n
                lab = n
            labels[r, c] = lab
    return n


@njit(cache=True, nogil=True)
def _components(n, mask, hue, x, y, w, h, labels, parent):
    """Each pixel's component (0 …, written over its label), and the components' count m,
    (m, 10) sums: area, box (x0, y0, x1, y1 inclusive), Σu, Σv, Σu², Σuv, Σv² (whole-image
    pixels, exact integers); (m,) the index of each one's first 2 x 2 block in raster order
    (blocks from the box's even corner); (m, HUE_BINS) its hue counts."""
    comp = np.empty(n + 1, np.int32)
    m = 0
    for i in range(1, n + 1):  # a root is the least label of its set, so seen before the rest
        root = _find(parent, i)
        if root == i:
            comp[i] = m
            m += 1
        else:
            comp[i] = comp[root]
    bx, by = x & ~1, y & ~1
    blocks = (x + w - bx + 1) // 2
    acc = np.zeros((m, 10), np.int64)
    acc[:, 1], acc[:, 2] = x + w, y + h
    key = np.full(m, np.iinfo(np.int64).max, np.int64)
    counts = np.zeros((m, HUE_BINS), np.int64)
    for r in range(y, y + h):
        for c in range(x, x + w):
            if mask[r, c] == 0:
                continue
            k = comp[labels[r, c]]
            labels[r, c] = k
            acc[k, 0] += 1
            acc[k, 1], acc[k, 2] = min(acc[k, 1], c), min(acc[k, 2], r)
            acc[k, 3], acc[k, 4] = max(acc[k, 3], c), max(acc[k, 4], r)
            acc[k, 5] += c
            acc[k, 6] += r
            acc[k, 7] += c * c
            acc[k, 8] += c * r
            acc[k, 9] += r * r
            counts[k, hue[r, c]] += 1
            b = ((r - by) >> 1) * blocks + ((c - bx) >> 1)
            if b < key[k]:
                key[k] = b
    return m, acc, key, counts


@njit(cache=True, nogil=True)
def regions_of(mask, hue, x, y, w, h, min_area, labels, parent, res):
    """The regions of mask's non-zero pixels, all inside the box (x, y, w, h) (as
    cv2.boundingRect gives it; w = 0: none), in OpenCV's order, row 0 the background as
    OpenCV's: stats (n, 5) int32, centroids (n, 2), rects (n, 5) (CamShift's box of each region
    of min_area pixels or more on its own pixels; NaN for the others), counts (n, HUE_BINS)
    (the hue counts of each region's pixels; ``hue`` is read only where ``mask`` is set)."""
    if w == 0:
        return (np.zeros((1, 5), np.int32), np.zeros((1, 2)), np.full((1, RECT), np.nan),
                np.zeros((1, HUE_BINS), np.int64))
    m, acc, key, found = _components(_label(mask, x, y, w, h, labels, parent), mask, hue, x, y,
                                     w, h, labels, parent)
    order = np.argsort(key)
    stats = np.zeros((m + 1, STATS), np.int32)
    cent = np.zeros((m + 1, 2))
    rects = np.full((m + 1, RECT), np.nan)
    counts = np.zeros((m + 1, HUE_BINS), np.int64)
    bx, by = x & ~1, y & ~1
    for j in range(m):
        k, out = order[j], j + 1
        area, x0, y0, su, sv = acc[k, 0], acc[k, 1], acc[k, 2], acc[k, 5], acc[k, 6]
        rw, rh = acc[k, 3] - x0 + 1, acc[k, 4] - y0 + 1
        stats[out, 0], stats[out, 1], stats[out, 2], stats[out, 3] = x0, y0, rw, rh
        stats[out, 4] = area
        cent[out, 0], cent[out, 1] = (su - bx * area) / area + bx, (sv - by * area) / area + by
        counts[out] = found[k]
        if area < min_area:
            continue
        # the raw moments in the region's box (u - x0, v - y0), exact integers, as cv::moments
        # gives them on its 0/1 mask there; CamShift on that mask is box_of on them
        m10, m01 = su - x0 * area, sv - y0 * area
        m20 = acc[k, 7] - 2 * x0 * su + x0 * x0 * area
        m11 = acc[k, 8] - x0 * sv - y0 * su + x0 * y0 * area
        m02 = acc[k, 9] - 2 * y0 * sv + y0 * y0 * area
        box_of(float(area), float(m10), float(m01), float(m20), float(m11), float(m02), 0, 0,
               rw, rh, rh, rw, res)
        rects[out, 0], rects[out, 1] = res[1] + x0, res[2] + y0
        rects[out, 2], rects[out, 3], rects[out, 4] = res[3], res[4], res[5]
    return stats, cent, rects, counts


class FrameRegions:
    """regions_of's regions of a frame of ``shape`` (H, W): ``n``, ``stats`` and ``centroids``
    as detect/regions.Regions has them, and ``describe`` as patch_tracker.ReferenceRegions."""

    def __init__(self, found, shape):
        self.stats, self.centroids, self._rects, self._counts = found
        self.n = self.stats.shape[0]
        self._shape = shape[:2]

    def describe(self, k: int):
        """Region k's CamShift box and window (its box) and its patch_check.Look."""
        x, y, w, h, area = (int(v) for v in self.stats[k])
        cu, cv, rw, rh, ang = (float(v) for v in self._rects[k])
        hist = self._counts[k].astype(np.float32)  # as colour.hue_distribution normalises
        total = float(hist.sum())
        H, W = self._shape
        seen = Look(float(area), aspect_of(rw, rh), hist / total if total > 0 else hist,
                    (float(self.centroids[k, 0]), float(self.centroids[k, 1])),
                    x == 0 or y == 0 or x + w >= W or y + h >= H)
        return ((cu, cv), (rw, rh), ang), (x, y, w, h), seen
