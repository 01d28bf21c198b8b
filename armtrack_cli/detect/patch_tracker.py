"""The wrist patch by CamShift (Tao & Hu 2008, section III-B; Bradski 1998).

Each frame: the hue back-projection of the patch's histogram, masked by the saturation/value
limits. Every candidate region is followed by its own CamShift window (a tracklet), carried
from frame to frame. A tracklet ends when its window loses its mass (occlusion, leaving the
image), jumps, or merges with another's. Because detect runs offline over the whole video,
the patch is then chosen among tracklets by what only it does: it moves with the arm. A
region that never moves (a cup of the same hue on the table) is a distractor and is never
reported. Frames without the patch's tracklet are ``ok = 0`` with no position.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from armtrack_cli.detect.colour import hue_histogram, range_mask
from armtrack_cli.detect.regions import Regions

TERM = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 10, 0.5)
_OPEN = np.ones((3, 3), np.uint8)


@dataclass(frozen=True)
class PatchSettings:
    min_area_px: int = 25  # smallest region taken as a candidate
    max_jump_px: float = 60.0  # a window moving farther in one frame is a new tracklet
    lost_fraction: float = 0.35  # window mass below this share of its running median: lost
    move_px: float = 12.0  # a tracklet whose positions spread farther than this moves
    relink_px: float = 40.0  # a still tracklet starting this close to where the patch was lost
    relink_s: float = 2.0  # within this time is the patch come back (at rest)


@dataclass
class Tracklet:
    id: int
    window: tuple[int, int, int, int]
    frames: list[int] = field(default_factory=list)
    rects: list[tuple[float, float, float, float, float]] = field(default_factory=list)
    masses: list[float] = field(default_factory=list)
    alive: bool = True

    def spread(self) -> float:
        p = np.array([r[:2] for r in self.rects])
        return float(np.max(np.linalg.norm(p - np.median(p, axis=0), axis=1))) if len(p) else 0.0


def back_projection(hsv: np.ndarray, hist: np.ndarray, low, high) -> np.ndarray:
    """Hue back-projection masked by the S and V limits (and opened to drop speckle)."""
    bp = cv2.calcBackProject([hsv], [0], hist, [0, 180], 1)
    sv = cv2.inRange(hsv, (0, int(low[1]), int(low[2])), (180, int(high[1]), int(high[2])))
    return cv2.morphologyEx(cv2.bitwise_and(bp, sv), cv2.MORPH_OPEN, _OPEN)


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
    out[y0:y1, x0:x1] = cv2.morphologyEx(raw[y0:y1, x0:x1], cv2.MORPH_OPEN, _OPEN)
    return out


class PatchTracker:
    """Feed frames in order with ``step``; read per-frame detections with ``detections``."""

    def __init__(self, low, high, settings: PatchSettings = PatchSettings()):
        self.low, self.high, self.s = low, high, settings
        self.hist = hue_histogram(int(low[0]), int(high[0]))
        self.tracklets: list[Tracklet] = []
        self.active: list[Tracklet] = []  # the live ones, in creation order
        self.n_frames = 0

    def step(self, frame_index: int, bgr: np.ndarray) -> None:
        hsv = cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV)
        bp = patch_mask(hsv, self.low, self.high)
        regions = Regions(bp)
        n, stats = regions.n, regions.stats
        claimed: dict[int, Tracklet] = {}
        h, w = bp.shape
        for tr in self.active:
            rect, window = cv2.CamShift(bp, tr.window, TERM)
            (cx, cy), (rw, rh), ang = rect
            x, y, ww, wh = window
            mass = float(bp[y:y + wh, x:x + ww].sum()) / 255.0 if ww > 0 and wh > 0 else 0.0
            ref = np.median(tr.masses[-30:]) if tr.masses else mass
            inside = 0 <= cx < w and 0 <= cy < h
            lab = regions.label_at(cx, cy) if inside else 0
            jump = np.hypot(cx - tr.rects[-1][0], cy - tr.rects[-1][1]) if tr.rects else 0.0
            if (mass < self.s.min_area_px or mass < self.s.lost_fraction * ref or lab == 0
                    or jump > self.s.max_jump_px):
                tr.alive = False
                continue
            if lab in claimed:  # two windows on one region: neither identity can be trusted
                claimed[lab].alive = False
                tr.alive = False
                continue
            claimed[lab] = tr
            tr.window = window
            tr.frames.append(frame_index)
            tr.rects.append((cx, cy, rw, rh, ang))
            tr.masses.append(mass)
        for lab in range(1, n):
            if lab in claimed or stats[lab, cv2.CC_STAT_AREA] < self.s.min_area_px:
                continue
            x, y, ww, wh = (int(v) for v in stats[lab, :4])
            rect, window = cv2.CamShift(bp, (x, y, ww, wh), TERM)
            (cx, cy), (rw, rh), ang = rect
            if not (0 <= cx < w and 0 <= cy < h) or regions.label_at(cx, cy) != lab:
                cx, cy = x + ww / 2, y + wh / 2
            tr = Tracklet(len(self.tracklets), window)
            tr.frames.append(frame_index)
            tr.rects.append((cx, cy, rw, rh, ang))
            tr.masses.append(float(stats[lab, cv2.CC_STAT_AREA]))
            self.tracklets.append(tr)
            self.active.append(tr)
        self.active = [t for t in self.active if t.alive]
        self.n_frames = max(self.n_frames, frame_index + 1)

    def patch_tracklets(self, fps: float) -> list[Tracklet]:
        """The tracklets that are the patch: the moving ones, and a still one that begins
        where and soon after the patch was lost (it came back while the arm rested)."""
        moving = [t for t in self.tracklets if t.spread() > self.s.move_px]
        if not moving:  # nothing ever moved: the largest region of the first frame
            first = [t for t in self.tracklets if t.frames and t.frames[0] == 0]
            return [max(first, key=lambda t: np.median(t.masses))] if first else []
        chosen = {t.id for t in moving}
        for t in sorted(self.tracklets, key=lambda t: t.frames[0]):
            if t.id in chosen:
                continue
            before = [c for c in self.tracklets if c.id in chosen and c.frames[-1] < t.frames[0]]
            if not before:
                continue
            last = max(before, key=lambda c: c.frames[-1])
            gap = (t.frames[0] - last.frames[-1]) / fps
            d = np.hypot(t.rects[0][0] - last.rects[-1][0], t.rects[0][1] - last.rects[-1][1])
            if gap <= self.s.relink_s and d <= self.s.relink_px:
                chosen.add(t.id)
        return [t for t in self.tracklets if t.id in chosen]

    def detections(self, fps: float) -> np.ndarray:
        """(n_frames, 6): u, v, width, height, angle (deg), ok — NaN position where not ok."""
        out = np.full((self.n_frames, 6), np.nan)
        out[:, 5] = 0
        for t in self.patch_tracklets(fps):
            for f, r in zip(t.frames, t.rects):
                if out[f, 5] == 1:  # two patch tracklets in one frame: keep the steadier one
                    continue
                out[f] = (*r, 1)
        return out
