"""Is this window the patch? The appearance check of the patch tracker (issue 14).

CamShift follows whatever mass of the patch's hue lies under its window; a same-hue object
(another sleeve, a cup) can hold the window for hundreds of frames. The window is taken as
the patch only if what it holds looks like the patch did:

- its hue histogram is within a Bhattacharyya distance of the reference (the patch's hue
  histogram over its first accepted frames);
- its mass (pixels of the patch's colour) is within a band around the mass its recent
  accepted frames predict, and its aspect (long over short side of CamShift's box) is within a
  factor of their running median and below an absolute limit. The mass predicted follows
  their trend (``trend``, over the latest unbroken run of accepted frames): a real patch
  turning from edge-on to face-on while the hand comes towards the camera grows up to 15 % a
  frame (the UE-ADL reaches, docs/validation-from-mocap.md), which a running median lags by
  half its window and takes for a neighbour joining; a neighbour joining or a cover sliding
  over it is a jump against the trend, which stays outside the band;
- it lies whole inside the image (a region cut by the edge is not all of anything).

What is checked and reported is the region under the window's centre, so a neighbour reaching
into the window does not move the reported centre (the region's sub-pixel centroid; CamShift
rounds its own); a neighbour touching the patch makes one region, too large to pass.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from statistics import median

import cv2
import numpy as np

from armtrack_cli.detect.colour import bhattacharyya, hue_distribution

HISTORY = 8  # accepted frames the prediction of mass and aspect is made from
DOUBLING_S = 1.5  # while lost, its area may have changed 2× per this time (the bands widen)
MAX_STEP_RATIO = 1.25  # the trend followed is at most this factor per accepted frame


@dataclass(frozen=True)
class Look:
    """What a window holds: its region's mass (px), aspect (≥ 1), hue histogram and centroid
    (u, v, sub-pixel)."""

    mass: float
    aspect: float
    hist: np.ndarray
    centroid: tuple[float, float]
    cut: bool  # the region reaches the edge of the image searched: part of it may be outside


def trend(values) -> float:
    """The next value that a run of positive ``values`` (accepted frames, oldest first)
    predicts: the Theil–Sen line of their logarithms (the median of the pairwise slopes,
    clipped to ±MAX_STEP_RATIO per frame; Sen 1968) carried one frame on from each value, and
    the median of those. A steady trend gives the last value times its step; pixel jitter
    (masses alternating by a few %) and one outlier hardly move it. (Plain Python: at most
    HISTORY values, where numpy's per-call cost would be most of a tracked frame's time.)"""
    v = [math.log(x) for x in values]
    n = len(v)
    if n < 3:
        return math.exp(median(v))
    limit = math.log(MAX_STEP_RATIO)
    step = min(max(median([(v[j] - v[i]) / (j - i) for i in range(n) for j in range(i + 1, n)]),
                   -limit), limit)
    return math.exp(median([x + step * (n - k) for k, x in enumerate(v)]))


def aspect_of(rw: float, rh: float) -> float:
    return max(rw, rh) / max(min(rw, rh), 1.0)


def look(hsv: np.ndarray, regions, k: int, window, rect) -> Look:
    """What CamShift's window (``rect`` its rotated box) holds: region k of ``regions``
    (detect/regions.py, on the same pixels as ``hsv``), the one under its centre."""
    x, y, w, h = (int(v) for v in regions.stats[k, :4])
    hist = hue_distribution(hsv[y:y + h, x:x + w], regions.mask_of(k))
    c = regions.centroids[k]
    H, W = hsv.shape[:2]
    return Look(float(regions.stats[k, cv2.CC_STAT_AREA]), aspect_of(*rect[1]), hist,
                (float(c[0]), float(c[1])), x == 0 or y == 0 or x + w >= W or y + h >= H)


class Reference:
    """The patch as it has looked: hue histogram from its first ``ref_frames`` accepted frames,
    mass and aspect of the last HISTORY (their ``trend`` is what the next frame should show)."""

    def __init__(self, ref_frames: int):
        self.ref_frames = ref_frames
        self.hist_sum = np.zeros((0, 1), np.float32)
        self.n_hist = 0
        self.masses: deque[float] = deque(maxlen=HISTORY)
        self.aspects: deque[float] = deque(maxlen=HISTORY)
        self.frames: deque[int] = deque(maxlen=HISTORY)
        self.hist: np.ndarray | None = None  # hist_sum / n_hist, None before the first frame
        self._expected: tuple[float, float] | None = None  # _expect()'s, until the next add

    def _expect(self) -> tuple[float, float]:
        """The mass the next frame should show (``trend`` over the latest unbroken run) and
        the median aspect, computed once per accepted frame (the acquiring pass asks for every
        region)."""
        if self._expected is None:
            k = self.run()
            self._expected = (trend(list(self.masses)[-k:]), median(self.aspects))
        return self._expected

    def add(self, seen: Look, frame: int) -> None:
        """Frame ``frame`` (accepted frames in order) looked like ``seen``."""
        if self.n_hist < self.ref_frames:
            self.hist_sum = seen.hist.copy() if self.n_hist == 0 else self.hist_sum + seen.hist
            self.n_hist += 1
            self.hist = self.hist_sum / self.n_hist
        self._expected = None
        self.masses.append(seen.mass)
        self.aspects.append(seen.aspect)
        self.frames.append(frame)

    def run(self) -> int:
        """How many of the last accepted frames follow one another without a gap."""
        f = self.frames
        k = len(f) - 1
        while k > 0 and f[k] - f[k - 1] == 1:
            k -= 1
        return len(f) - k

    def failure(self, seen: Look, s, lost_s: float = 0.0) -> str:
        """'' when ``seen`` looks like the patch under settings ``s``; else what differs. After
        ``lost_s`` seconds without the patch, its size may have changed by 2^(lost_s /
        DOUBLING_S): the mass and aspect bands widen by that much."""
        slack = 2.0 ** (lost_s / DOUBLING_S)
        if seen.cut:  # its centroid is not the patch's centre, if it is the patch at all
            return "cut"
        if seen.aspect > s.max_aspect:
            return "aspect"
        if self.masses:
            ref, aspect = self._expect()
            if not s.lost_fraction * ref / slack <= seen.mass <= s.max_growth * ref * slack:
                return "mass"
            if seen.aspect > s.max_aspect_change * slack * aspect:
                return "aspect"
        ref_hist = self.hist
        if ref_hist is not None and bhattacharyya(ref_hist, seen.hist) > s.max_hue_distance:
            return "hue"
        return ""
