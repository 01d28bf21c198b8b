"""Palm-marker candidates (Cordella et al., section III-A).

The hand is located first by skin colour (YCrCb, robust to brightness); markers are then
looked for in a region around it. Candidate regions are connected components of pixels near
the marker colour; each is scored by the Bhattacharyya similarity of its hue-saturation
histogram to the reference marker histogram. Every candidate is kept, clutter included:
deciding which blob is which marker, or clutter, is the filter's job.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from armtrack_cli.detect.colour import hs_histogram, range_mask
from armtrack_cli.detect.regions import Regions

SKIN_YCRCB = ((0, 135, 80), (255, 175, 130))  # Cr 135-175, Cb 80-130 (Chai & Ngan style bounds)


@dataclass(frozen=True)
class PalmBlobSettings:
    min_area_px: int = 8
    roi_margin: float = 1.0  # the hand's box grown by this share of its size on every side
    hue_slack: int = 12  # candidate pixels: the marker hue range widened by this much
    sat_floor: int = 60
    min_score: float = 0.2  # 1 − Bhattacharyya distance


def skin_mask(bgr: np.ndarray) -> np.ndarray:
    ycc = cv2.cvtColor(bgr, cv2.COLOR_BGR2YCrCb)
    return cv2.inRange(ycc, SKIN_YCRCB[0], SKIN_YCRCB[1])


def hand_roi(bgr: np.ndarray, margin: float) -> tuple[int, int, int, int] | None:
    """(x0, y0, x1, y1) around the largest skin region, grown by ``margin``; None without skin.
    The region is found at half resolution: only its box is needed, and it is grown anyway."""
    small = cv2.resize(bgr, (bgr.shape[1] // 2, bgr.shape[0] // 2), interpolation=cv2.INTER_AREA)
    m = cv2.morphologyEx(skin_mask(small), cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))
    regions = Regions(m)
    n, stats = regions.n, regions.stats
    if n < 2:
        return None
    k = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    x, y, w, h = (2 * int(v) for v in stats[k, :4])
    gx, gy = int(margin * max(w, h)), int(margin * max(w, h))
    H, W = bgr.shape[:2]
    return max(0, x - gx), max(0, y - gy), min(W, x + w + gx), min(H, y + h + gy)


class PalmBlobDetector:
    def __init__(self, low, high, settings: PalmBlobSettings = PalmBlobSettings()):
        self.low, self.high, self.s = tuple(low), tuple(high), settings
        self.reference: np.ndarray | None = None

    def _candidates_mask(self, hsv: np.ndarray) -> np.ndarray:
        lo = (max(0, self.low[0] - self.s.hue_slack), self.s.sat_floor, self.low[2] // 2)
        hi = (min(180, self.high[0] + self.s.hue_slack), 255, 255)
        return range_mask(hsv, lo, hi)

    def detect(self, bgr: np.ndarray) -> np.ndarray:
        """(k, 4) candidate blobs: u, v (sub-pixel centroid), area (px), score in [0, 1]."""
        roi = hand_roi(bgr, self.s.roi_margin)
        if roi is None:
            return np.zeros((0, 4))
        x0, y0, x1, y1 = roi
        hsv = cv2.cvtColor(bgr[y0:y1, x0:x1], cv2.COLOR_BGR2HSV)
        if self.reference is None:  # the reference: pixels of the marker colour range
            ref_mask = range_mask(hsv, self.low, self.high)
            if cv2.countNonZero(ref_mask) < self.s.min_area_px:
                return np.zeros((0, 4))
            self.reference = hs_histogram(hsv, ref_mask)
        cand = self._candidates_mask(hsv)
        regions = Regions(cand)
        n, stats = regions.n, regions.stats
        rows = []
        for k in range(1, n):
            area = int(stats[k, cv2.CC_STAT_AREA])
            if area < self.s.min_area_px:
                continue
            x, y, w, h = (int(v) for v in stats[k, :4])
            sub = regions.mask_of(k)
            hist = hs_histogram(hsv[y:y + h, x:x + w], sub * 255)
            score = 1.0 - cv2.compareHist(self.reference, hist, cv2.HISTCMP_BHATTACHARYYA)
            if score < self.s.min_score:
                continue
            m = cv2.moments(sub, binaryImage=True)
            rows.append((x0 + x + m["m10"] / m["m00"], y0 + y + m["m01"] / m["m00"], area, score))
        return np.array(rows, float).reshape(-1, 4)
