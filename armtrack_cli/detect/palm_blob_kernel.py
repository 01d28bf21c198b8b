"""The palm-blob search of one box compiled with numba: the same blobs as the OpenCV reference
(palm_blobs.PalmBlobDetector._search_reference: cv2.cvtColor to HSV, cv2.inRange,
cv2.connectedComponentsWithStats, one hue-saturation histogram per region), in one pass over
the box's pixels that converts, thresholds and links the candidate pixels as it goes, then one
pass over the candidate pixels for each region's statistics and score.

- HSV as OpenCV converts 8-bit BGR (its integer RGB2HSV_b with the sdiv/hdiv tables, H in
  0-179): tests/test_palm_blob_kernel.py holds it equal to cv2.cvtColor on all 2^24 colours.
- Regions are 8-connected, found by union-find over the candidate pixels only, and numbered
  in the order OpenCV's block-based labelling (Grana) numbers them: by the first 2 x 2 block of
  the region in raster order (a block's pixels are all neighbours, so each block belongs to
  one region; boxes start on even rows and columns, so the blocks are the whole image's).
- Scores: 1 − OpenCV's HISTCMP_BHATTACHARYYA, √(1 − Σ √(a b) / √(Σa Σb)), between the
  reference histogram and each region's (colour.HS_BINS: H // 6, S // 8).

Work arrays (a label image of the frame's size kept all zero between calls, candidate lists)
are allocated once per detector (Work); only the result is allocated per call.
``cache=True``: the compile happens once per install and is loaded from __pycache__.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_I = np.arange(1, 256, dtype=np.float64)
# OpenCV's RGB2HSV_b tables (hsv_shift = 12), saturate_cast<int> rounding half to even
SDIV = np.r_[0, np.rint((255 << 12) / _I)].astype(np.int64)
HDIV = np.r_[0, np.rint((180 << 12) / (6 * _I))].astype(np.int64)
H_DIV, S_DIV, S_BINS = 6, 8, 32  # colour.HS_BINS (30, 32) over colour.HS_RANGES


class Work:
    """Work arrays for frames of (height, width): the label image (int32, all zero between
    calls) and per-candidate-pixel lists, as long as a frame has pixels."""

    def __init__(self, height: int, width: int):
        n = height * width + 1
        self.shape = (height, width)
        self.label = np.zeros((height, width), np.int32)
        self.px, self.py = np.empty(n, np.int32), np.empty(n, np.int32)
        self.parent, self.bin = np.empty(n, np.int32), np.empty(n, np.int32)
        self.core = np.empty(n, np.uint8)
        self.maybe = np.zeros((width + 7) // 8 * 8, np.uint8)  # one row's prefilter
        self.lo, self.hi = (np.empty((width + 7) // 8 * 8, np.uint8) for _ in range(2))
        self.half = np.empty((height // 2, width // 2), np.uint8)  # the skin mask, halved


@njit(cache=True, inline="always")
def _hsv(b, g, r, sdiv, hdiv):
    """OpenCV's RGB2HSV_b for one 8-bit pixel: (h 0-179, s, v)."""
    v = max(b, g, r)
    diff = v - min(b, g, r)
    s = (diff * sdiv[v] + 2048) >> 12
    if v == r:
        h = g - b
    elif v == g:
        h = b - r + 2 * diff
    else:
        h = r - g + 4 * diff
    h = (h * hdiv[diff] + 2048) >> 12
    if h < 0:
        h += 180
    return h, s, v


@njit(cache=True, inline="always")
def _inside(h, s, v, rng):
    """cv2.inRange on (h, s, v) with rng = (h_lo, s_lo, v_lo, h_hi, s_hi, v_hi); the hue range
    wraps through red when h_lo > h_hi (colour.range_mask)."""
    if s < rng[1] or s > rng[4] or v < rng[2] or v > rng[5]:
        return False
    if rng[0] <= rng[3]:
        return rng[0] <= h <= rng[3]
    return h >= rng[0] or h <= rng[3]


@njit(cache=True, inline="always")
def _find(parent, i):
    while parent[i] != i:
        parent[i] = parent[parent[i]]  # path halving
        i = parent[i]
    return i


@njit(cache=True, inline="always")
def _union(parent, a, b):
    ra, rb = _find(parent, a), _find(parent, b)
    if ra < rb:
        parent[rb] = ra
    elif rb < ra:
        parent[ra] = rb


@njit(cache=True)
def _maybe_row(row, n, pre, out):
    """out[i] = 1 where pixel i of a row (flat BGR, n pixels) may be in the range that pre
    bounds (prefilter_bounds), 0 where it is not: a superset of the exact test, without tables
    or branches, in float32 (every product here is an integer below 2^24, so exact) so that
    it compiles to wide vector instructions."""
    v_lo, v_hi, s_lo1, s_hi1, h_lo1, h_hi1 = pre[0], pre[1], pre[2], pre[3], pre[4], pre[5]
    wrap = pre[6] > 0
    for i in range(n):
        b, g, r = np.float32(row[3 * i]), np.float32(row[3 * i + 1]), np.float32(row[3 * i + 2])
        v = max(b, max(g, r))
        d = v - min(b, min(g, r))
        hn = g - b if v == r else (b - r + np.float32(2) * d if v == g else
                                   r - g + np.float32(4) * d)
        h30 = np.float32(30) * hn  # 30 hn / d: the hue before OpenCV's rounding (within 0.66)
        hw = h30 + np.float32(180) * d  # the same wrapped, for hn < 0
        lo, hi, d255 = h_lo1 * d, h_hi1 * d, np.float32(255) * d
        # below -1 the hue is certain to wrap (OpenCV adds 180 to it): only hw is tested
        if wrap:
            in0 = ((h30 >= lo) | (h30 <= hi)) & (h30 >= -d)
            inw = ((hw >= lo) | (hw <= hi)) & (hn < 0)
        else:
            in0 = (h30 >= lo) & (h30 <= hi) & (h30 >= -d)
            inw = (hw >= lo) & (hw <= hi) & (hn < 0)
        out[i] = ((v >= v_lo) & (v <= v_hi) & (d255 >= s_lo1 * v) & (d255 <= s_hi1 * v)
                  & (in0 | inw))


def prefilter_bounds(rng: np.ndarray) -> np.ndarray:
    """_maybe_row's bounds for an inRange range (h_lo, s_lo, v_lo, h_hi, s_hi, v_hi): V exact;
    S = 255 d / v and H = 30 hn / d each widened by 1, more than OpenCV's rounding of them
    moves them (S: 0.53, H: 0.66; tests check the superset on all 2^24 colours)."""
    h_lo, s_lo, v_lo, h_hi, s_hi, v_hi = (int(x) for x in rng)
    return np.array([v_lo, v_hi, s_lo - 1, s_hi + 1, h_lo - 1, h_hi + 1, h_lo > h_hi],
                    np.float32)


@njit(cache=True, inline="always")
def add(n, x, y, h, s, is_core, x0, y0, x1, label, px, py, parent, binv, coref):
    """Candidate pixel n (1-based, in raster order) at (x, y) of the box from x0, y0 to x1 with
    hue h and saturation s: recorded, and linked to its candidate 8-neighbours visited before
    it (outside the box the label image is 0)."""
    px[n], py[n], parent[n] = x, y, n
    binv[n] = (h // H_DIV) * S_BINS + s // S_DIV
    coref[n] = is_core
    label[y, x] = n
    # the neighbour above, when set, was already joined to the other three (they touch it)
    up = label[y - 1, x] if y > y0 else 0
    if up:
        _union(parent, n, up)
        return
    left = label[y, x - 1] if x > x0 else 0
    if left:
        _union(parent, n, left)
    if y > y0:
        if x > x0 and label[y - 1, x - 1]:
            _union(parent, n, label[y - 1, x - 1])
        if x + 1 < x1 and label[y - 1, x + 1]:
            _union(parent, n, label[y - 1, x + 1])


@njit(cache=True)
def _scan(bgr, x0, y0, x1, y1, cand, pre, core, sdiv, hdiv, label, px, py, parent, binv,
          coref, maybe):
    """Candidate pixels of the box in raster order (1-based: index 0 unused), each linked to
    its candidate neighbours above and to the left; returns how many."""
    n, flat, W = 0, bgr.reshape(-1), bgr.shape[1]
    words = maybe.view(np.uint64)  # the row's flags eight at a time: most are all zero
    nw = (x1 - x0 + 7) // 8
    for y in range(y0, y1):
        _maybe_row(flat[3 * (y * W + x0):3 * (y * W + x1)], x1 - x0, pre, maybe)
        maybe[x1 - x0:nw * 8] = 0
        for wj in range(nw):
            if words[wj] == 0:
                continue
            for j in range(8 * wj, 8 * wj + 8):
                if not maybe[j]:
                    continue
                x = x0 + j
                h, s, v = _hsv(np.int64(bgr[y, x, 0]), np.int64(bgr[y, x, 1]),
                               np.int64(bgr[y, x, 2]), sdiv, hdiv)
                if not _inside(h, s, v, cand):
                    continue
                n += 1
                add(n, x, y, h, s, _inside(h, s, v, core), x0, y0, x1, label, px, py, parent, binv,
                    coref)
    return n


@njit(cache=True)
def _regions(n, px, py, parent, width):
    """Region of each candidate pixel (0-based, OpenCV's order) and the number of regions."""
    comp = np.empty(n + 1, np.int32)
    key = np.empty(n, np.int64)
    m = 0
    for i in range(1, n + 1):  # a root is its region's first pixel in raster order
        r = _find(parent, i)
        if r == i:
            comp[i] = m
            key[m] = (py[i] // 2) * (width // 2 + 1) + px[i] // 2
            m += 1
        else:
            comp[i] = comp[r]
        k = (py[i] // 2) * (width // 2 + 1) + px[i] // 2  # its 2 x 2 block in raster order
        if k < key[comp[i]]:
            key[comp[i]] = k
    rank = np.empty(m, np.int32)
    rank[np.argsort(key[:m])] = np.arange(m, dtype=np.int32)
    for i in range(1, n + 1):
        comp[i] = rank[comp[i]]
    return comp, m


@njit(cache=True, nogil=True)
def search_box(bgr, x0, y0, x1, y1, cand, pre, core, ref, ref_sum, min_area, min_score,
               edge_fails, core_centroid, sdiv, hdiv, label, px, py, parent, binv, coref, maybe):
    """Blobs of the box [x0, x1) × [y0, y1) (x0, y0 even) in the candidate colour range cand
    (h_lo, s_lo, v_lo, h_hi, s_hi, v_hi; core: the marker's own range, for core_centroid):
    ((k, 4) u, v, area, score of the regions of min_area pixels or more scoring min_score or
    more, True); ((0, 4), False) when edge_fails and a region touches an edge of the box that
    is not the frame's. ref: the reference histogram (flat, colour.HS_BINS), ref_sum its sum."""
    n = _scan(bgr, x0, y0, x1, y1, cand, pre, core, sdiv, hdiv, label, px, py, parent, binv,
              coref, maybe)
    return blobs_of(n, x0, y0, x1, y1, ref, ref_sum, min_area, min_score, edge_fails,
                    core_centroid, label, px, py, parent, binv, coref)


@njit(cache=True)
def blobs_of(n, x0, y0, x1, y1, ref, ref_sum, min_area, min_score, edge_fails, core_centroid,
             label, px, py, parent, binv, coref):
    """search_box's result from the box's n candidate pixels (_scan's lists)."""
    H, W = label.shape
    comp, m = _regions(n, px, py, parent, W)
    st = np.zeros((m, 6))  # area, Σx, Σy, and the same over the core pixels (box coordinates)
    ext = np.empty((m, 4), np.int64)  # min x, max x, min y, max y
    ext[:, 0], ext[:, 1], ext[:, 2], ext[:, 3] = W, -1, H, -1
    for i in range(1, n + 1):
        c, x, y = comp[i], px[i] - x0, py[i] - y0
        st[c, 0] += 1.0
        st[c, 1] += x
        st[c, 2] += y
        if coref[i]:
            st[c, 3] += 1.0
            st[c, 4] += x
            st[c, 5] += y
        ext[c, 0], ext[c, 1] = min(ext[c, 0], px[i]), max(ext[c, 1], px[i])
        ext[c, 2], ext[c, 3] = min(ext[c, 2], py[i]), max(ext[c, 3], py[i])
        label[py[i], px[i]] = 0  # the label image back to zero for the next call
    if edge_fails:
        for c in range(m):
            if ((ext[c, 0] == x0 and x0 > 0) or (ext[c, 2] == y0 and y0 > 0)
                    or (ext[c, 1] == x1 - 1 and x1 < W) or (ext[c, 3] == y1 - 1 and y1 < H)):
                return np.zeros((0, 4)), False
    # each region's pixels together (a counting sort by region), then its histogram
    start = np.zeros(m + 1, np.int64)
    for i in range(1, n + 1):
        start[comp[i] + 1] += 1
    for c in range(m):
        start[c + 1] += start[c]
    order, fill = np.empty(n, np.int64), start[:m].copy()
    for i in range(1, n + 1):
        order[fill[comp[i]]] = i
        fill[comp[i]] += 1
    hist = np.zeros(ref.size)
    out = np.empty((m, 4))
    k = 0
    for c in range(m):
        area = st[c, 0]
        if area < min_area:
            continue
        s = 0.0
        for j in range(start[c], start[c + 1]):
            hist[binv[order[j]]] += 1.0
        for j in range(start[c], start[c + 1]):
            b = binv[order[j]]
            if hist[b] > 0.0:
                s += math.sqrt(hist[b] * ref[b])
                hist[b] = 0.0
        score = 1.0 - math.sqrt(max(1.0 - s / math.sqrt(max(area, 1.0) * ref_sum), 0.0))
        if score < min_score:
            continue
        if core_centroid and st[c, 3] > 0:
            u, v = st[c, 4] / st[c, 3], st[c, 5] / st[c, 3]
        else:
            u, v = st[c, 1] / area, st[c, 2] / area
        out[k, 0], out[k, 1], out[k, 2], out[k, 3] = x0 + u, y0 + v, area, score
        k += 1
    return out[:k], True


@njit(cache=True)
def window_of(blobs, margin, width, height):
    """The next search window: the blobs' box (u, v of each row) grown by margin, inside the
    frame, starting on an even row and column (palm_blobs.PalmBlobDetector._window_of)."""
    u0, v0, u1, v1 = blobs[0, 0], blobs[0, 1], blobs[0, 0], blobs[0, 1]
    for i in range(1, blobs.shape[0]):
        u0, u1 = min(u0, blobs[i, 0]), max(u1, blobs[i, 0])
        v0, v1 = min(v0, blobs[i, 1]), max(v1, blobs[i, 1])
    x0, y0 = int(math.floor(u0)) - margin, int(math.floor(v0)) - margin
    x1, y1 = int(math.ceil(u1)) + margin + 1, int(math.ceil(v1)) + margin + 1
    return max(0, x0) & ~1, max(0, y0) & ~1, min(width, x1), min(height, y1)
