"""What tries to fool the patch detector (issue 14): the subject's other arm, in a sleeve of
the patch's colour, crossing over and near the patch; and a cluttered table.

The other arm waits at the side of the workspace, then sweeps across it and back every few
seconds a little above the working hand (nearer the camera: it passes over the patch and
hides it), at a distance from the patch's path that changes from pass to pass (so it also
passes close by without touching). Its sleeve's hue lies inside the patch's hue range, a
few units from the patch's own, with the same saturation: to the HSV range it is the patch.
"""

from __future__ import annotations

import cv2
import numpy as np

SLEEVE_BGR = np.array([25.0, 60.0, 215.0])  # H ≈ 5.5 (OpenCV units) against the patch's ≈ 1.5
ENTER_S = 3.0  # the other arm starts moving (after detect has found the patch)
PERIOD_S = 5.0  # one sweep across and back (± 20 % by seed)
SWEEP_M = 0.30  # half-width of the sweep about the workspace centre, m
HEIGHT_M = 0.17  # the other wrist above the table, m
FOREARM_M = 0.26
SLEEVE_RADIUS_M = 0.035
HAND_M, HAND_RADIUS_M = 0.085, 0.03
ELBOW_TOWARDS = np.array([0.24, 0.37, 0.11])  # from the workspace centre: the other shoulder's side

# table clutter: hues kept this far (OpenCV units) outside the patch's hue range, except the
# pale objects of the patch's own hue whose saturation lies below the range's floor
CLUTTER_HUE_GAP = 6
CLUTTER_COUNT = 30


def other_arm(t: np.ndarray, centre: np.ndarray,
              rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """(elbow, wrist), each (N, 3) in W, of the other arm at session times t (s); its pace,
    path and height vary with the draws from ``rng``."""
    t = np.asarray(t, float)
    period = PERIOD_S * rng.uniform(0.8, 1.2)
    off, wobble = rng.uniform(-0.04, 0.04), rng.uniform(0, 2 * np.pi)
    moving = np.clip(t - ENTER_S, 0.0, None)
    phase = 2 * np.pi * moving / period
    wrist = np.stack([
        centre[0] + SWEEP_M * np.cos(phase),  # parked at the far side, then across and back
        centre[1] + off + 0.08 * np.sin(phase / 2.3 + wobble),  # each pass at another distance
        np.full_like(t, HEIGHT_M) + 0.02 * np.sin(phase / 1.7 + wobble),
    ], -1)
    towards = centre + ELBOW_TOWARDS - wrist
    elbow = wrist + FOREARM_M * towards / np.linalg.norm(towards, axis=1, keepdims=True)
    return elbow, wrist


def other_arm_segments(elbow: np.ndarray, wrist: np.ndarray, skin: np.ndarray) -> list[tuple]:
    """(a, b, radius, colour) of the sleeve and the hand, for render._limb."""
    d = (wrist - elbow) / np.linalg.norm(wrist - elbow)
    return [(elbow, wrist, SLEEVE_RADIUS_M, SLEEVE_BGR),
            (wrist, wrist + HAND_M * d, HAND_RADIUS_M, skin)]


def clutter_texture(tex: np.ndarray, patch_hue: tuple[int, int], sat_floor: int,
                    keep_out_px: tuple[int, int, int, int], rng: np.random.Generator) -> None:
    """Paint CLUTTER_COUNT objects (boxes and ellipses, 2-9 cm) of many colours onto the table
    texture ``tex`` (BGR, in place), none over the ``keep_out_px`` box (x0, y0, x1, y1: the
    board). None has the patch's hue and saturation together."""
    h, w = tex.shape[:2]
    lo, hi = patch_hue
    inside = (np.arange(180) >= lo) | (np.arange(180) <= hi) if lo > hi else \
        (np.arange(180) >= lo) & (np.arange(180) <= hi)
    far = np.flatnonzero(~np.convolve(np.r_[inside[-CLUTTER_HUE_GAP:], inside,
                                            inside[:CLUTTER_HUE_GAP]].astype(int),
                                      np.ones(2 * CLUTTER_HUE_GAP + 1), "valid").astype(bool))
    placed = 0
    while placed < CLUTTER_COUNT:
        cx, cy = int(rng.integers(0, w)), int(rng.integers(0, h))
        a, b = (int(v) for v in rng.integers(10, 45, 2))
        x0, y0, x1, y1 = keep_out_px
        if x0 - a - b < cx < x1 + a + b and y0 - a - b < cy < y1 + a + b:
            continue
        if placed % 5 == 0:  # pale, of the patch's own hue: saturation under the floor
            hue, sat = int(rng.integers(lo, lo + 3)) % 180, int(rng.integers(40, sat_floor - 30))
        else:
            hue, sat = int(rng.choice(far)), int(rng.integers(60, 256))
        hsv = np.uint8([[[hue, sat, int(rng.integers(70, 240))]]])
        colour = tuple(int(c) for c in cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR)[0, 0])
        if rng.random() < 0.5:
            cv2.ellipse(tex, (cx, cy), (a, b), float(rng.uniform(0, 180)), 0, 360, colour, -1,
                        cv2.LINE_AA)
        else:
            cv2.rectangle(tex, (cx - a, cy - b), (cx + a, cy + b), colour, -1, cv2.LINE_AA)
        placed += 1
