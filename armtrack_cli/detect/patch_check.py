"""Is this window the patch? The appearance check of the patch tracker (issue 14).

CamShift follows whatever mass of the patch's hue lies under its window; a same-hue object
(another sleeve, a cup) can hold the window for hundreds of frames. The window is taken as
the patch only if what it holds looks like the patch did:

- its hue histogram is within a Bhattacharyya distance of the reference (the patch's hue
  histogram over its first accepted frames);
- its mass (pixels of the patch's colour) is within a band around the running median of the
  accepted masses, and its aspect (long over short side of CamShift's box) is within a factor
  of their running median and below an absolute limit;
- it holds one region, not two (a window straddling the patch and a neighbour is neither).
"""

from __future__ import annotations

from collections import deque
from statistics import median
from dataclasses import dataclass

import cv2
import numpy as np

from armtrack_cli.detect.colour import bhattacharyya, hue_distribution

HISTORY = 8  # accepted frames in the running medians: the patch's image changes 2× in 1.5 s


@dataclass(frozen=True)
class Look:
    """What a window holds: mass (px), aspect (≥ 1), hue histogram, number of regions."""

    mass: float
    aspect: float
    hist: np.ndarray
    regions: int


def aspect_of(rw: float, rh: float) -> float:
    return max(rw, rh) / max(min(rw, rh), 1.0)


SPECK_PX = 4  # a region this small in a window is noise; anything larger is something there


def look(hsv: np.ndarray, mask: np.ndarray, window, rect) -> Look:
    """What the window (x, y, w, h) of ``mask`` (opened: no speckle) holds; ``rect`` is
    CamShift's rotated box. A sliver of a neighbour at the window's edge counts as a region:
    it pulls CamShift's centre by pixels."""
    x, y, w, h = window
    m = mask[y:y + h, x:x + w]
    n, _, stats, _ = cv2.connectedComponentsWithStats(m, connectivity=8)
    big = int((stats[1:, cv2.CC_STAT_AREA] >= SPECK_PX).sum())
    return Look(float(cv2.countNonZero(m)), aspect_of(*rect[1]),
                hue_distribution(hsv[y:y + h, x:x + w], m), big)


class Reference:
    """The patch as it has looked: hue histogram from its first ``ref_frames`` accepted frames,
    running medians of mass and aspect over the last HISTORY."""

    def __init__(self, ref_frames: int):
        self.ref_frames = ref_frames
        self.hist_sum = np.zeros((0, 1), np.float32)
        self.n_hist = 0
        self.masses: deque[float] = deque(maxlen=HISTORY)
        self.aspects: deque[float] = deque(maxlen=HISTORY)

    @property
    def hist(self) -> np.ndarray | None:
        return self.hist_sum / self.n_hist if self.n_hist else None

    def add(self, seen: Look) -> None:
        if self.n_hist < self.ref_frames:
            self.hist_sum = seen.hist.copy() if self.n_hist == 0 else self.hist_sum + seen.hist
            self.n_hist += 1
        self.masses.append(seen.mass)
        self.aspects.append(seen.aspect)

    def failure(self, seen: Look, s) -> str:
        """'' when ``seen`` looks like the patch under settings ``s``; else what differs."""
        if seen.regions != 1:
            return "regions"
        if seen.aspect > s.max_aspect:
            return "aspect"
        if self.masses:
            ref = median(self.masses)
            if not s.lost_fraction * ref <= seen.mass <= s.max_growth * ref:
                return "mass"
            if seen.aspect > s.max_aspect_change * median(self.aspects):
                return "aspect"
        ref_hist = self.hist
        if ref_hist is not None and bhattacharyya(ref_hist, seen.hist) > s.max_hue_distance:
            return "hue"
        return ""
