"""The palm-blob search of one box (palm_blob_kernel.search_box) on a frame's I420 planes, so
that the frame is never converted to BGR where the search does not look: the same blobs as
search_box on the BGR image OpenCV converts the planes to (cv2.COLOR_YUV2BGR_I420).

- Each pixel's BGR is OpenCV's I420 conversion (color_yuv: ITU-R BT.601 limited range, fixed
  point with 20 fraction bits, each 2 x 2 block sharing its chroma; tests hold it equal to
  cv2.cvtColor on every (Y, U, V)), its HSV then OpenCV's (palm_blob_kernel._hsv).
- Prefilter: a 2 x 2 block shares its chroma (U, V), so which luma values Y can make a pixel
  of that chroma a candidate is a property of (U, V) alone. The range [lowest, highest] of
  them is worked out (over all 256 Y) the first time a chroma is met, and kept in a table
  of the detector's (y_table, both bounds in one 16-bit word: one load, no branch on an
  empty range): a pixel outside its block's range cannot be a candidate; one inside is
  converted and tested exactly. Most blocks (skin, background) have no such Y at all, and
  cost one look-up.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from armtrack_cli.detect.palm_blob_kernel import _hsv, _inside, add, blobs_of
from armtrack_cli.detect.yuv_pixel import i420_bgr

# y_table's words: highest luma << 8 | lowest; no luma at all as lowest 1 > highest 0, and a
# chroma not worked out yet as lowest 255 > highest 0 (an empty range is never stored so)
EMPTY, UNSET = 0x0001, 0x00FF


def y_table() -> np.ndarray:
    """(65536,) uint16: for each chroma (U * 256 + V) the lowest and highest luma of a
    candidate pixel (highest << 8 | lowest; EMPTY: none); UNSET until first met. One per
    colour range."""
    return np.full(1 << 16, UNSET, np.uint16)


@njit(cache=True)
def _luma_range(u, v, cand, sdiv, hdiv):
    """The lowest and highest Y making a pixel of chroma (u, v) a candidate (256, -1: none)."""
    lo, hi = 256, -1
    for y in range(256):
        b, g, r = i420_bgr(y, u, v)
        h, s, val = _hsv(b, g, r, sdiv, hdiv)
        if _inside(h, s, val, cand):
            lo, hi = min(lo, y), max(hi, y)
    return lo, hi


@njit(cache=True)
def _row_ranges(up, vp, cy, cx0, cx1, ytab, cand, sdiv, hdiv, lo, hi):
    """lo[i], hi[i] (i = 2 (cx - cx0) and the one after it): the luma range of the candidates
    of the row's blocks cx0 <= cx < cx1, from ytab (filled in where a chroma is new); an
    empty range as 1, 0 (uint8)."""
    urow, vrow = up[cy], vp[cy]
    for cx in range(cx0, cx1):
        u, v = np.int64(urow[cx]), np.int64(vrow[cx])
        t = ytab[u * 256 + v]
        if t == UNSET:
            a, b = _luma_range(u, v, cand, sdiv, hdiv)
            t = np.uint16(b << 8 | a) if a <= b else np.uint16(EMPTY)
            ytab[u * 256 + v] = t
        i, a, b = 2 * (cx - cx0), np.uint8(t & 255), np.uint8(t >> 8)
        lo[i], lo[i + 1], hi[i], hi[i + 1] = a, a, b, b


@njit(cache=True)
def _scan_i420(yp, up, vp, x0, y0, x1, y1, ytab, cand, core, sdiv, hdiv, label, px, py,
               parent, binv, coref, lo, hi, maybe):
    """palm_blob_kernel._scan on I420 planes: the box's candidate pixels in raster order
    (1-based), each linked to its candidate neighbours visited before it; returns how many.
    lo, hi and maybe (uint8): work rows of the frame's width rounded up to 8."""
    n, w = 0, x1 - x0
    words = maybe.view(np.uint64)  # the row's flags eight at a time: most are all zero
    nw = (w + 7) // 8
    for y in range(y0, y1):
        if y == y0 or y % 2 == 0:
            _row_ranges(up, vp, y >> 1, x0 >> 1, (x1 + 1) >> 1, ytab, cand, sdiv, hdiv, lo, hi)
        row = yp[y, x0:x1]  # a 1-D slice: the loop below compiles to vector instructions
        for j in range(w):  # a superset of the candidates
            maybe[j] = (row[j] >= lo[j]) & (row[j] <= hi[j])
        maybe[w:nw * 8] = 0
        for wj in range(nw):
            if words[wj] == 0:
                continue
            for j in range(8 * wj, 8 * wj + 8):
                if not maybe[j]:
                    continue
                x = x0 + j
                b, g, r = i420_bgr(np.int64(yp[y, x]), np.int64(up[y >> 1, x >> 1]),
                                   np.int64(vp[y >> 1, x >> 1]))
                h, s, val = _hsv(b, g, r, sdiv, hdiv)
                if not _inside(h, s, val, cand):
                    continue
                n += 1
                add(n, x, y, h, s, _inside(h, s, val, core), x0, y0, x1, label, px, py, parent,
                    binv, coref)
    return n


@njit(cache=True, nogil=True)
def search_box_i420(yp, up, vp, x0, y0, x1, y1, ytab, cand, core, ref, ref_sum, min_area,
                    min_score, edge_fails, core_centroid, sdiv, hdiv, label, px, py, parent,
                    binv, coref, lo, hi, maybe):
    """palm_blob_kernel.search_box on the I420 planes yp (H, W), up, vp (H / 2, W / 2), H and W
    even, with ytab the detector's y_table() for the candidate range cand."""
    n = _scan_i420(yp, up, vp, x0, y0, x1, y1, ytab, cand, core, sdiv, hdiv, label, px, py,
                   parent, binv, coref, lo, hi, maybe)
    return blobs_of(n, x0, y0, x1, y1, ref, ref_sum, min_area, min_score, edge_fails,
                    core_centroid, label, px, py, parent, binv, coref)
