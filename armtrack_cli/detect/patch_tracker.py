"""The wrist patch by CamShift (Tao & Hu 2008, section III-B; Bradski 1998), with an
appearance check so that ``ok = 1`` means "this is the patch" (issue 14).

Tracking: CamShift on the hue back-projection (masked by the S/V limits) of a search region
around the patch's last window only (HSV conversion included), so a frame costs the region,
not the image. The window is accepted when its region looks like the patch did
(detect/patch_check.py: hue histogram, mass, aspect) and has not jumped; the region's
sub-pixel centroid is reported.

Acquiring (the first frames, and whenever the check fails): the whole frame (its mask from
the I420 planes in one compiled pass, or guided by a half-resolution pass; its regions, each
one's CamShift box and look by detect/patch_acquire_kernel.py, or by OpenCV on the reference
path: ReferenceRegions). Every region is followed as a tracklet (frame to frame, to the
region nearest where it was heading), each frame marked by whether it looks like the patch. A
tracklet that looks like the patch now is taken as the patch when it moves (the patch moves
with the arm: a same-hue cup on the table never does), or when it appears soon after the
patch was lost, no farther from where it went than the arm can have carried it in the time
(it came back at rest, after a card). Because detect runs offline, its earlier frames that
looked like the patch are then reported too, and so are those of the tracklets that lead to
it (the patch at rest, crossed by the other arm, seen again where it was: one tracklet per
stretch in view). Until then frames are ``ok = 0`` with no position. If nothing ever moves,
the largest region of the first frame is the patch.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from armtrack_cli.detect.colour import hue_histogram, range_mask
from armtrack_cli.detect.frame_rows import FrameRows
from armtrack_cli.detect.patch_check import HISTORY, Reference, look
from armtrack_cli.detect.patch_masks import OPEN3, sparse_patch_mask
from armtrack_cli.detect.regions import Regions
from armtrack_cli.vision.yuv import YuvFrame, whole_bgr, window_bgr

TERM = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 10, 0.5)
RELINK_FRAMES = 3  # a tracklet is taken only once its next frames can vouch for its first
RELINK_SAME_PX = 10.0  # a region present when the patch was lost is the patch only this close
TRACK_MASS_STEP = 1.5  # a tracklet's region changing mass by more than this in a frame ends it


@dataclass(frozen=True)
class PatchSettings:
    min_area_px: int = 25  # smallest region taken as a candidate
    max_jump_px: float = 60.0  # a window (a tracklet's region) moving farther in a frame: lost
    lost_fraction: float = 0.7  # region mass below this share of what its trend predicts: lost
    max_growth: float = 1.3  # … above this share: something else joined it: lost
    max_aspect: float = 3.0  # a window longer than this times its width is not the patch
    max_aspect_change: float = 1.4  # … nor one this much longer than its running median
    max_hue_distance: float = 0.5  # Bhattacharyya distance to the reference hue histogram
    ref_frames: int = 15  # the reference hue histogram: the patch's first accepted frames
    search_px: int = 40  # the search region: the last window grown by this on every side
    move_px: float = 12.0  # a tracklet whose positions spread farther than this moves
    relink_px: float = 40.0  # a still tracklet starting this close to where the patch was lost
    relink_s: float = 2.0  # within this time is the patch come back (at rest)
    relink_px_per_s: float = 100.0  # … and relink_px grows by this per second it was lost


@dataclass
class Tracklet:
    id: int
    window: tuple[int, int, int, int]
    frames: list[int] = field(default_factory=list)
    rects: list[tuple[float, float, float, float, float]] = field(default_factory=list)
    masses: list[float] = field(default_factory=list)
    looks: list = field(default_factory=list)
    good: list[bool] = field(default_factory=list)  # looked like the patch in that frame
    alive: bool = True
    box: tuple = ((0.0, 0.0), (0.0, 0.0))  # (min u, min v), (max u, max v) of the positions

    def spread(self) -> float:
        """Farthest position from the median position, px."""
        p = np.array([r[:2] for r in self.rects])
        return float(np.max(np.linalg.norm(p - np.median(p, axis=0), axis=1))) if len(p) else 0.0

    def moves(self, move_px: float) -> bool:
        """spread() > move_px; the positions' box is checked first: no position is farther
        from the median than the box's diagonal."""
        (u0, v0), (u1, v1) = self.box
        return np.hypot(u1 - u0, v1 - v0) > move_px and self.spread() > move_px

    def heading(self) -> tuple[float, float]:
        """Where it should be next frame: its last position plus its last step (px)."""
        u, v = self.rects[-1][:2]
        if len(self.frames) > 1 and self.frames[-2] == self.frames[-1] - 1:
            return 2 * u - self.rects[-2][0], 2 * v - self.rects[-2][1]
        return u, v

    def add(self, frame: int, rect, mass: float, seen, good: bool) -> None:
        (cx, cy), (rw, rh), ang = rect
        (u0, v0), (u1, v1) = self.box if self.rects else ((cx, cy), (cx, cy))
        self.box = ((min(u0, cx), min(v0, cy)), (max(u1, cx), max(v1, cy)))
        self.frames.append(frame)
        self.rects.append((cx, cy, rw, rh, ang))
        self.masses.append(mass)
        self.looks.append(seen)
        self.good.append(good)


def region_rect(regions: Regions, k: int):
    """CamShift's rotated box and window (whole-image px) of region k alone: its moments on
    its own pixels, so a neighbour does not stretch it."""
    x, y, w, h = (int(v) for v in regions.stats[k, :4])
    (cx, cy), size, ang = cv2.CamShift(regions.mask_of(k), (0, 0, w, h), TERM)[0]
    return ((cx + x, cy + y), size, ang), (x, y, w, h)


class ReferenceRegions:
    """The acquiring pass's regions by OpenCV (``regions``: detect/regions.Regions of the
    whole frame's mask, ``hsv`` its HSV image): n, stats and centroids, and ``describe``."""

    def __init__(self, hsv: np.ndarray, regions: Regions):
        self.hsv, self.regions = hsv, regions
        self.n, self.stats, self.centroids = regions.n, regions.stats, regions.centroids

    def describe(self, k: int):
        """Region k's CamShift box and window (region_rect) and its patch_check.Look."""
        rect, window = region_rect(self.regions, k)
        return rect, window, look(self.hsv, self.regions, k, window, rect)


def track_reference(frame, box, start, low, high):
    """The tracked frame by OpenCV (the reference patch_kernel.WindowTracker equals): in the
    search region ``box`` (x0, y0, x1, y1) of the frame, CamShift from window ``start``
    (region pixels) on the opened range mask, and the region under its centre; returns
    (CamShift's box, its window, patch_check.Look of that region), or None."""
    x0, y0, x1, y1 = box
    hsv = cv2.cvtColor(window_bgr(frame, x0, y0, x1, y1), cv2.COLOR_BGR2HSV)
    mask = cv2.morphologyEx(range_mask(hsv, low, high), cv2.MORPH_OPEN, OPEN3)
    rect, win = cv2.CamShift(mask, start, TERM)
    (cx, cy), _, _ = rect
    if not (0 <= cx < x1 - x0 and 0 <= cy < y1 - y0) or mask[int(cy), int(cx)] == 0:
        return None
    regions = Regions(mask)
    k = regions.label_at(cx, cy)
    return rect, win, look(hsv, regions, k, win, rect)  # cut: at the search region's edge


class PatchTracker:
    """Feed frames in order with ``step``; read per-frame detections with ``detections``, or
    as they become final with ``take`` (detect writes a long session's rows as it goes)."""

    def __init__(self, low, high, settings: PatchSettings = PatchSettings(), *,
                 fps: float = 30.0, kernel: bool = True, frames: int = 1024):
        """``kernel``: track with the compiled patch_kernel (False: the OpenCV reference);
        ``frames``: the rows to hold at first (a block's, where ``take`` hands them out as it
        goes; else the video's frame count, when known: the table then never grows)."""
        self.low, self.high, self.s, self.fps = low, high, settings, fps
        self._kernel = None
        if kernel:  # numba's: imported only when a tracker is made
            from armtrack_cli.detect.patch_kernel import WindowTracker
            self._kernel = WindowTracker(low, high)
        self.hist = hue_histogram(int(low[0]), int(high[0]))
        self.ref = Reference(settings.ref_frames)
        self.rows = FrameRows(frames)  # u, v, w, h, angle, ok of the frames not yet taken
        self.window: tuple[int, int, int, int] | None = None  # set while tracking
        self.last = (np.nan, np.nan, -1)  # u, v and frame of the last accepted detection
        self.vel = (0.0, 0.0)  # px per frame
        self.tracklets: list[Tracklet] = []  # this acquisition's, while acquiring
        self.active: list[Tracklet] = []
        self.patches = 0  # tracklets taken as the patch so far
        self._lost_s = 0.0  # time since the patch was last seen, while acquiring
        self._episode = 0  # first frame of the current acquisition
        self._hsv = self._bp = None  # whole-frame buffers of the acquiring pass, reused

    # --- per frame
    def step(self, frame_index: int, frame) -> None:
        """Frame ``frame_index``, a BGR image or a vision.yuv.YuvFrame (only the search region
        is converted to BGR while tracking, the whole frame while acquiring)."""
        self.rows.start(frame_index)
        if self.window is not None and self._track(frame_index, frame):
            return
        self.window = None
        self._acquire(frame_index, frame)

    def _search_region(self, shape) -> tuple[int, int, int, int]:
        x, y, w, h = self.window
        dx, dy = int(round(self.vel[0])), int(round(self.vel[1]))
        m = self.s.search_px
        H, W = shape[:2]
        return (max(0, x + dx - m), max(0, y + dy - m), min(W, x + dx + w + m),
                min(H, y + dy + h + m))

    def _track(self, i: int, frame) -> bool:
        """CamShift in the search region around the last window; True if the patch is there."""
        x0, y0, x1, y1 = self._search_region(frame.shape)
        x, y, w, h = self.window
        sx, sy = x + int(round(self.vel[0])) - x0, y + int(round(self.vel[1])) - y0
        sx0, sy0 = max(sx, 0), max(sy, 0)  # the start window, inside the search region
        sw, sh = min(sx + w, x1 - x0) - sx0, min(sy + h, y1 - y0) - sy0
        if sw <= 0 or sh <= 0:  # predicted out of the image
            return False
        found = self._kernel.track(frame, (x0, y0, x1, y1), (sx0, sy0, sw, sh)) \
            if self._kernel else track_reference(frame, (x0, y0, x1, y1), (sx0, sy0, sw, sh),
                                                 self.low, self.high)
        if found is None:
            return False
        (_, size, ang), (wx, wy, ww, wh), seen = found
        u, v = seen.centroid[0] + x0, seen.centroid[1] + y0
        if np.hypot(u - self.last[0], v - self.last[1]) > self.s.max_jump_px or \
                self.ref.failure(seen, self.s):
            return False
        self._accept(i, ((u, v), size, ang), (wx + x0, wy + y0, ww, wh), seen)
        return True

    def _accept(self, i: int, rect, window, seen) -> None:
        (u, v), (rw, rh), ang = rect
        if self.last[2] == i - 1:
            self.vel = (u - self.last[0], v - self.last[1])
        else:
            self.vel = (0.0, 0.0)
        self.rows.set(i, (u, v, rw, rh, ang, 1))
        self.last = (u, v, i)
        self.window = tuple(int(c) for c in window)
        self.ref.add(seen, i)

    # --- acquiring
    def _whole_regions(self, frame):
        """The whole frame's regions of the patch's colour (patch_masks.patch_mask of its
        HSV), each with ``describe``: by the kernels (the mask from I420 planes in one pass,
        else by sparse_patch_mask; patch_acquire_kernel's regions), else by OpenCV
        (ReferenceRegions)."""
        if self._kernel and isinstance(frame, YuvFrame):
            return self._kernel.whole_regions(frame, self.s.min_area_px)
        bgr = whole_bgr(frame)
        if self._hsv is None or self._hsv.shape != bgr.shape:
            self._hsv, self._bp = np.empty_like(bgr), np.empty(bgr.shape[:2], np.uint8)
        sparse_patch_mask(bgr, self.low, self.high, self._hsv, self._bp)
        if self._kernel:
            return self._kernel.whole_regions(bgr, self.s.min_area_px, (self._hsv, self._bp))
        return ReferenceRegions(self._hsv, Regions(self._bp))

    def _acquire(self, i: int, frame) -> None:
        if self.last[2] >= self._episode:  # the first frame of this acquisition (the patch
            self._episode = i  # was seen since the last one began)
        self._lost_s = (i - self.last[2]) / self.fps if self.last[2] >= 0 else 0.0
        regions = self._whole_regions(frame)
        claimed = self._follow(i, regions)
        self._start(i, regions, claimed)
        self.active = [t for t in self.active if t.alive]
        for t in self.active:
            if self._is_patch(t):
                self._adopt(t)
                return

    def _candidate(self, seen) -> bool:
        """Whether a region that looks like ``seen`` looks like the patch (before it has been
        seen: any compact one)."""
        if self.ref.hist is None:
            return seen.aspect <= self.s.max_aspect and not seen.cut
        return not self.ref.failure(seen, self.s, self._lost_s)

    def _follow(self, i: int, regions) -> dict[int, Tracklet]:
        """Carry every tracklet one frame on to the region nearest where it is heading (its
        last centroid plus its last step): a tracklet is one connected region, so it is
        never dragged onto a larger same-hue neighbour, as a CamShift window over the whole
        frame is. It ends when no region lies within max_jump_px, when its region's mass
        changes by more than TRACK_MASS_STEP in a frame (merged, or half covered), or when two
        tracklets reach one region (neither identity can be trusted)."""
        claimed: dict[int, Tracklet] = {}
        area, cent = regions.stats[:, cv2.CC_STAT_AREA], regions.centroids
        big = np.flatnonzero(area[1:] >= self.s.min_area_px) + 1
        for tr in self.active:
            pu, pv = tr.heading()
            dist = np.hypot(cent[big, 0] - pu, cent[big, 1] - pv)
            if big.size == 0 or dist.min() > self.s.max_jump_px:
                tr.alive = False
                continue
            lab = int(big[np.argmin(dist)])
            ratio = float(area[lab]) / tr.masses[-1]
            if not 1.0 / TRACK_MASS_STEP <= ratio <= TRACK_MASS_STEP:
                tr.alive = False
                continue
            if lab in claimed:
                claimed[lab].alive = False
                tr.alive = False
                continue
            rect, window, seen = regions.describe(lab)
            ok = self._candidate(seen)
            claimed[lab] = tr
            tr.window = window
            tr.add(i, (seen.centroid, *rect[1:]), float(area[lab]), seen, ok)
        return claimed

    def _start(self, i: int, regions, claimed) -> None:
        """A new tracklet on every unclaimed region."""
        for lab in range(1, regions.n):
            if lab in claimed or regions.stats[lab, cv2.CC_STAT_AREA] < self.s.min_area_px:
                continue
            (_, size, ang), window, seen = regions.describe(lab)
            ok = self._candidate(seen)
            tr = Tracklet(len(self.tracklets), window)
            tr.add(i, (seen.centroid, size, ang), float(regions.stats[lab, cv2.CC_STAT_AREA]),
                   seen, ok)
            self.tracklets.append(tr)
            self.active.append(tr)

    def _reach_px(self, gap_frames: int, there: bool) -> float:
        """How far from where it was last seen the patch may reappear after ``gap_frames``: a
        region that already looked like the patch when the patch was lost is something else
        unless it is where the patch was heading (RELINK_SAME_PX); otherwise relink_px, plus
        what the arm can cover in the time (relink_px_per_s)."""
        if there:
            return RELINK_SAME_PX
        return self.s.relink_px + self.s.relink_px_per_s * gap_frames / self.fps

    def _is_patch(self, t: Tracklet) -> bool:
        """It looks like the patch now, and it moves, or it appeared close to where and soon
        after the patch was lost (_reach_px); one that did not look like it when the patch
        was lost may be the patch, partly hidden then."""
        if not t.good[-1] or len(t.frames) < RELINK_FRAMES:
            return False
        if t.moves(self.s.move_px):
            return True
        u, v, last = self.last
        if last < 0 or (t.frames[0] - last) / self.fps > self.s.relink_s:
            return False
        there = t.frames[0] == self._episode and t.good[0]  # looked like it as the patch went
        return np.hypot(t.rects[0][0] - u - self.vel[0], t.rects[0][1] - v - self.vel[1]) \
            <= self._reach_px(t.frames[0] - last, there)

    def _chain(self, t: Tracklet) -> list[Tracklet]:
        """t and the ended tracklets of this acquisition that lead to it, oldest first: the
        latest that ended before the head began, within relink_s and _reach_px of where the
        head began, having looked like the patch (the patch seen at rest for a while, then
        crossed by the other arm, then seen again where it was: each stretch is the patch)."""
        chain, seen = [t], self.last[2] >= 0  # before the patch was ever seen, none was lost
        while True:
            h = chain[-1]
            u, v = h.rects[0][:2]
            prev = [d for d in self.tracklets if not d.alive and any(d.good)
                    and d.frames[-1] < h.frames[0]
                    and (h.frames[0] - d.frames[-1]) / self.fps <= self.s.relink_s
                    and np.hypot(d.rects[-1][0] - u, d.rects[-1][1] - v) <= self._reach_px(
                        h.frames[0] - d.frames[-1], seen and d.frames[0] == self._episode
                        and d.good[0])]
            if not prev:
                return chain[::-1]
            chain.append(max(prev, key=lambda d: d.frames[-1]))

    def _adopt(self, t: Tracklet) -> None:
        """Report the frames of the tracklet and of those leading to it (_chain) as the patch
        and track it from its last window. Their frames were checked against the patch as it
        was when lost (with a slack for the time since); each is now also checked against the
        chain's own next frames, which drops those where it was still partly hidden
        (coming out from under something)."""
        chain = self._chain(t)
        mass = np.array([seen.mass for piece in chain for seen in piece.looks])
        k = -1
        for piece in chain:
            for f, r, seen, good in zip(piece.frames, piece.rects, piece.looks, piece.good):
                k += 1
                after = mass[k + 1:k + 1 + HISTORY] if k + 1 < mass.size else mass[-HISTORY:]
                ref = float(np.median(after))
                if good and self.s.lost_fraction * ref <= mass[k] <= self.s.max_growth * ref:
                    self.rows.set(f, (*r, 1))
                    self.ref.add(seen, f)
        self.last = (t.rects[-1][0], t.rects[-1][1], t.frames[-1])
        consecutive = len(t.frames) > 1 and t.frames[-2] == t.frames[-1] - 1
        self.vel = (t.rects[-1][0] - t.rects[-2][0], t.rects[-1][1] - t.rects[-2][1]) \
            if consecutive else (0.0, 0.0)
        self.window = tuple(int(c) for c in t.window)
        self.tracklets, self.active = [], []
        self.patches += 1

    def detections(self, fps: float | None = None) -> np.ndarray:
        """(n_frames, 6): u, v, width, height, angle (deg), ok — NaN position where not ok
        (of the frames ``take`` has not handed out: all, if it was never called).
        (``fps`` is the tracker's own, given at construction; kept for callers.)"""
        self._settle()
        return self.rows.held()

    def _settle(self) -> None:
        """The video ended: if nothing ever moved, the largest region of frame 0 is the patch."""
        if self.patches == 0:
            first = [t for t in self.tracklets if t.frames and t.frames[0] == 0]
            if first:
                self._adopt(max(first, key=lambda t: np.median(t.masses)))

    def take(self, *, final: bool = False) -> tuple[int, np.ndarray]:
        """(first frame, rows as ``detections``') of the frames no later frame can change,
        handed out and dropped: every frame before the earliest of this acquisition's
        tracklets (_adopt may yet report theirs; until a patch was taken, frame 0's hold all);
        with ``final`` (the video ended: _settle), every frame left."""
        if final:
            self._settle()
        stop = self.rows.n if final or not self.tracklets else \
            min(t.frames[0] for t in self.tracklets)
        return self.rows.take(stop)
