"""Palm-marker candidates (Cordella et al., section III-A).

The hand is located first by skin colour (YCrCb, robust to brightness); markers are then
looked for in a region around it. Candidate regions are connected components of pixels near
the marker colour; each is scored by the Bhattacharyya similarity of its hue-saturation
histogram to the reference marker histogram. Every candidate is kept, clutter included:
deciding which blob is which marker, or clutter, is the filter's job.

Speed: after a frame with blobs, the next is searched only in a window around them (grown by
``window_margin_px``), without the skin step. The whole frame (the hand's region by skin) is
searched again to re-acquire: when a blob in the window touches the window's edge (it may
extend beyond it), when the window finds fewer blobs than the frame before (one may have left
it), and every ``full_every`` frames (new clutter far from the markers). A blob wholly inside
the window is the same connected component, with the same centroid, area and score, as on
the whole frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from armtrack_cli.detect.colour import HS_BINS, HS_RANGES, hs_histogram, range_mask
from armtrack_cli.detect.regions import Regions
from armtrack_cli.vision.yuv import YuvFrame, whole_bgr

CENTROIDS = ("region", "core")  # PalmBlobSettings.centroid
SKIN_YCRCB = ((0, 135, 80), (255, 175, 130))  # Cr 135-175, Cb 80-130 (Chai & Ngan style bounds)


@dataclass(frozen=True)
class PalmBlobSettings:
    min_area_px: int = 8
    roi_margin: float = 1.0  # the hand's box grown by this share of its size on every side
    hue_slack: int = 12  # candidate pixels: the marker hue range widened by this much
    sat_floor: int = 60
    min_score: float = 0.2  # 1 − Bhattacharyya distance
    window_margin_px: int = 24  # the search window: the previous blobs' box grown by this
    full_every: int = 15  # frames between searches of the hand's whole region (0: always)
    centroid: str = "region"  # "core": from the region's pixels in the marker's own colour
    #                           range (docs/palm-ukf.md: less WRIST bias, but see there)


def skin_mask(bgr: np.ndarray) -> np.ndarray:
    ycc = cv2.cvtColor(bgr, cv2.COLOR_BGR2YCrCb)
    return cv2.inRange(ycc, SKIN_YCRCB[0], SKIN_YCRCB[1])


def hand_roi(bgr: np.ndarray, margin: float) -> tuple[int, int, int, int] | None:
    """(x0, y0, x1, y1) around the largest skin region, grown by ``margin``; None without skin.
    The region is found at half resolution: only its box is needed, and it is grown anyway."""
    small = cv2.resize(bgr, (bgr.shape[1] // 2, bgr.shape[0] // 2), interpolation=cv2.INTER_AREA)
    return roi_of_skin(skin_mask(small), margin, bgr.shape[:2])


def roi_of_skin(half: np.ndarray, margin: float, shape) -> tuple[int, int, int, int] | None:
    """hand_roi from the skin mask at half resolution ``half`` of an image of ``shape``."""
    m = cv2.morphologyEx(half, cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))
    regions = Regions(m)
    n, stats = regions.n, regions.stats
    if n < 2:
        return None
    k = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    x, y, w, h = (2 * int(v) for v in stats[k, :4])
    gx, gy = int(margin * max(w, h)), int(margin * max(w, h))
    H, W = shape[:2]
    return max(0, x - gx), max(0, y - gy), min(W, x + w + gx), min(H, y + h + gy)


def _planes_of(frame: YuvFrame) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """The kernel's I420 planes of a frame of even height and width; None for odd sizes (their
    last row or column is converted by padding: vision/yuv.py), searched in BGR."""
    if frame.y.shape[0] % 2 or frame.y.shape[1] % 2:
        return None
    return frame.y, frame.u, frame.v


class PalmBlobDetector:
    """compiled: boxes searched by detect/palm_blob_kernel.py (numba); False: by OpenCV
    (_search_reference, the reference the kernel is tested against)."""

    def __init__(self, low, high, settings: PalmBlobSettings = PalmBlobSettings(), *,
                 compiled: bool = True):
        assert settings.centroid in CENTROIDS, settings.centroid
        self.low, self.high, self.s = tuple(low), tuple(high), settings
        self.reference: np.ndarray | None = None
        self._window: tuple[int, int, int, int] | None = None
        self._last_n, self._since_full = 0, 0
        self.full_searches = 0  # frames searched over the hand's whole region
        lo = (max(0, self.low[0] - settings.hue_slack), settings.sat_floor, self.low[2] // 2)
        self._cand = (lo, (min(180, self.high[0] + settings.hue_slack), 255, 255))
        self._kernel = None
        if compiled:  # numba's: imported only when a detector is made
            from armtrack_cli.detect import palm_blob_i420, palm_blob_kernel, palm_blob_skin
            self._kernel, self._i420, self._skin = palm_blob_kernel, palm_blob_i420, palm_blob_skin
            self._skin_bounds = np.array([*SKIN_YCRCB[0], *SKIN_YCRCB[1]], np.int64)
            self._ytab = palm_blob_i420.y_table()
            cand = np.array([*self._cand[0], *self._cand[1]], np.int64)
            self._ranges = (cand, palm_blob_kernel.prefilter_bounds(cand),
                            np.array([*self.low, *self.high], np.int64))
            self._work = None

    def _candidates_mask(self, hsv: np.ndarray) -> np.ndarray:
        return range_mask(hsv, *self._cand)

    def warm(self) -> None:
        """Set the compiled kernel up now (numba's import was done in __init__; this loads the
        kernel's code from its cache) rather than at the first frame searched with it."""
        if self._kernel is not None:
            k, (cand, pre, core), w = self._kernel, self._ranges, self._kernel.Work(2, 2)
            k.window_of(np.zeros((1, 4)), 1, 2, 2)
            ref = np.ones(HS_BINS[0] * HS_BINS[1])
            k.search_box(np.zeros((2, 2, 3), np.uint8), 0, 0, 2, 2, cand, pre, core, ref, 1.0,
                         1.0, 0.0, True, False, k.SDIV, k.HDIV, w.label, w.px, w.py, w.parent,
                         w.bin, w.core, w.maybe)
            p, q = np.zeros((2, 2), np.uint8), np.zeros((1, 1), np.uint8)
            self._i420.search_box_i420(p, q, q, 0, 0, 2, 2, self._ytab, cand,
                                       core, ref, 1.0, 1.0, 0.0, True, False, k.SDIV, k.HDIV,
                                       w.label, w.px, w.py, w.parent, w.bin, w.core, w.lo,
                                       w.hi, w.maybe)
            self._skin.skin_half(p, q, q, self._skin_bounds, w.half)
            roi_of_skin(w.half, 1.0, (2, 2))  # OpenCV's first use, as re-acquiring makes it

    def detect(self, frame) -> np.ndarray:
        """(k, 4) candidate blobs: u, v (sub-pixel centroid), area (px), score in [0, 1].
        frame: a BGR image, or a vision.yuv.YuvFrame (its I420 planes: the window is converted
        by the kernel pixel by pixel as OpenCV's I420 conversion does, the whole frame by
        OpenCV only to search the hand's region) with the same blobs as its BGR image."""
        out = None
        if self._window is not None and self._since_full < self.s.full_every:
            out = self._search(frame, self._window, edge_fails=True)
            if out is not None and len(out) < self._last_n:
                out = None  # a blob may have left the window: search the hand's region
        if out is None:
            out = self._full(frame)
            self._since_full = 0
            self.full_searches += 1
        self._since_full += 1
        self._last_n = len(out)
        self._window = self._window_of(out, frame.shape) if len(out) else None
        return out

    def _window_of(self, blobs: np.ndarray, shape) -> tuple[int, int, int, int]:
        if self._kernel is not None:
            return self._kernel.window_of(blobs, self.s.window_margin_px, shape[1], shape[0])
        m = self.s.window_margin_px
        x0, y0 = np.floor(blobs[:, :2].min(axis=0)).astype(int) - m
        x1, y1 = np.ceil(blobs[:, :2].max(axis=0)).astype(int) + m + 1
        return max(0, x0) & ~1, max(0, y0) & ~1, min(shape[1], x1), min(shape[0], y1)

    def _full(self, frame) -> np.ndarray:
        """The hand's region by skin colour (re-acquisition), searched on the frame as given."""
        roi = self._hand_roi(frame)
        if roi is None:
            return np.zeros((0, 4))
        return self._search(frame, (roi[0] & ~1, roi[1] & ~1, roi[2], roi[3]), edge_fails=False)

    def _hand_roi(self, frame) -> tuple[int, int, int, int] | None:
        """hand_roi of the frame: compiled, a YuvFrame's skin mask straight from its planes
        (detect/palm_blob_skin.py: the same mask, without its BGR image)."""
        planes = _planes_of(frame) if isinstance(frame, YuvFrame) else None
        if self._kernel is None or planes is None:
            return hand_roi(whole_bgr(frame), self.s.roi_margin)
        half = self._work_for(frame.shape).half
        self._skin.skin_half(*planes, self._skin_bounds, half)
        return roi_of_skin(half, self.s.roi_margin, frame.shape)

    def _work_for(self, shape):
        """The kernels' work arrays (palm_blob_kernel.Work) for frames of this shape."""
        if self._work is None or self._work.shape != shape[:2]:
            self._work = self._kernel.Work(*shape[:2])
        return self._work

    def _search(self, frame, box, *, edge_fails: bool) -> np.ndarray | None:
        """Candidates in box (x0, y0, x1, y1), x0 and y0 even, of a BGR image or a YuvFrame;
        None if edge_fails and a candidate touches an edge of the box that is not the image's."""
        if self._kernel is None or self.reference is None:
            return self._search_reference(whole_bgr(frame), box, edge_fails=edge_fails)
        k, w, (cand, pre, core) = self._kernel, self._work_for(frame.shape), self._ranges
        args = (float(self.s.min_area_px), float(self.s.min_score), edge_fails,
                self.s.centroid == "core", k.SDIV, k.HDIV, w.label, w.px, w.py, w.parent, w.bin,
                w.core)
        planes = _planes_of(frame) if isinstance(frame, YuvFrame) else None
        if planes is not None:
            out, ok = self._i420.search_box_i420(*planes, *box, self._ytab, cand, core,
                                                 self.reference, self._ref_sum, *args, w.lo,
                                                 w.hi, w.maybe)
        else:
            out, ok = k.search_box(whole_bgr(frame), *box, cand, pre, core, self.reference,
                                   self._ref_sum, *args, w.maybe)
        return out if ok else None

    def _search_reference(self, bgr: np.ndarray, box, *, edge_fails: bool) -> np.ndarray | None:
        """Candidates in box (x0, y0, x1, y1), x0 and y0 even (OpenCV labels 2 × 2 blocks: on
        the same grid as the whole image, so the same order); None if edge_fails and a
        candidate touches an edge of the box that is not the image's."""
        x0, y0, x1, y1 = box
        hsv = cv2.cvtColor(bgr[y0:y1, x0:x1], cv2.COLOR_BGR2HSV)
        if self.reference is None:  # the reference: pixels of the marker colour range
            ref_mask = range_mask(hsv, self.low, self.high)
            if cv2.countNonZero(ref_mask) < self.s.min_area_px:
                return np.zeros((0, 4))
            self.reference = hs_histogram(hsv, ref_mask).astype(np.float64).ravel()
            self._ref_sum = float(self.reference.sum())
        mask = self._candidates_mask(hsv)
        bx, by, bw, bh = cv2.boundingRect(mask)  # of the candidate pixels
        if bw == 0:
            return np.zeros((0, 4))
        # labelled on the box around them only, from an even row and column of the box
        # searched: OpenCV labels 2 x 2 blocks, so the same regions in the same order as on the
        # whole box (detect/regions.py; tests check it), at the cost of the candidates' box
        cx, cy = bx & ~1, by & ~1
        hsv, mask = hsv[cy:by + bh, cx:bx + bw], mask[cy:by + bh, cx:bx + bw]
        n, labels, stats, cent = cv2.connectedComponentsWithStatsWithAlgorithm(
            mask, 8, cv2.CV_32S, cv2.CCL_GRANA)
        st = stats[1:]
        if edge_fails and n > 1:
            H, W = bgr.shape[:2]
            sx, sy = st[:, 0] + cx, st[:, 1] + cy  # in the box searched
            touch = (((sx == 0) & (x0 > 0)) | ((sy == 0) & (y0 > 0))
                     | ((sx + st[:, 2] == x1 - x0) & (x1 < W))
                     | ((sy + st[:, 3] == y1 - y0) & (y1 < H)))
            if touch.any():
                return None
        keep = np.flatnonzero(st[:, cv2.CC_STAT_AREA] >= self.s.min_area_px)
        if keep.size == 0:
            return np.zeros((0, 4))
        lab = labels.ravel()
        p = np.flatnonzero(mask)  # the labelled pixels (of the 1-byte mask: a quarter the reads)
        score = 1.0 - self._bhattacharyya(hsv, lab, p, n)[keep + 1]
        good = score >= self.s.min_score
        k = keep[good] + 1
        u, v = (self._core_centroids(hsv, lab, p, n, cent) if self.s.centroid == "core"
                else (cent[:, 0], cent[:, 1]))
        return np.column_stack([(x0 + cx) + u[k], (y0 + cy) + v[k],
                                stats[k, cv2.CC_STAT_AREA], score[good]])

    def _core_centroids(self, hsv, lab, p, n, cent) -> tuple[np.ndarray, np.ndarray]:
        """(n,) centroid of each region's pixels in the marker's own colour range (the region
        itself was grown by hue_slack and sat_floor to catch the marker whole; those rim
        pixels are the marker blended with what lies next to it, and a bluish sleeve beside
        the WRIST marker pulled its centroid by 0.75 px: docs/palm-ukf.md). A region without
        such pixels keeps its whole centroid."""
        core = range_mask(hsv, self.low, self.high).ravel()[p] > 0
        w = hsv.shape[1]
        L = lab[p][core]
        cnt = np.bincount(L, minlength=n)
        su = np.bincount(L, weights=(p[core] % w).astype(float), minlength=n)
        sv = np.bincount(L, weights=(p[core] // w).astype(float), minlength=n)
        has = cnt > 0
        c = np.maximum(cnt, 1)
        return np.where(has, su / c, cent[:, 0]), np.where(has, sv / c, cent[:, 1])

    def _bhattacharyya(self, hsv: np.ndarray, lab: np.ndarray, p: np.ndarray,
                       n: int) -> np.ndarray:
        """(n,) OpenCV's HISTCMP_BHATTACHARYYA, √(1 − Σ √(a b) / √(Σa Σb)), between the
        reference and each region's hue-saturation histogram (colour.HS_BINS over
        colour.HS_RANGES: H // 6, S // 8), all regions' histograms in one bincount; lab the
        flat labels, p the indices of the labelled pixels."""
        hs = hsv.reshape(-1, 3)[p]
        nb = HS_BINS[0] * HS_BINS[1]
        bins = (hs[:, 0] // (HS_RANGES[1] // HS_BINS[0])).astype(np.int64) * HS_BINS[1] + \
            hs[:, 1] // (HS_RANGES[3] // HS_BINS[1])
        h = np.bincount(lab[p].astype(np.int64) * nb + bins, minlength=n * nb).reshape(n, nb)
        ref = self.reference
        s = np.sqrt(h * ref).sum(axis=1) / np.sqrt(np.maximum(h.sum(axis=1), 1) * ref.sum())
        return np.sqrt(np.maximum(1.0 - s, 0.0))
