"""Colour ranges in OpenCV's HSV (H 0-180, S and V 0-255), with a hue range that may wrap
through red (low H > high H)."""

from __future__ import annotations

import cv2
import numpy as np


def range_mask(hsv: np.ndarray, low, high) -> np.ndarray:
    """uint8 mask (255 inside) of pixels within [low, high]; hue wraps when low[0] > high[0]."""
    lo, hi = tuple(int(v) for v in low), tuple(int(v) for v in high)
    if lo[0] <= hi[0]:
        return cv2.inRange(hsv, lo, hi)
    return cv2.inRange(hsv, (lo[0], lo[1], lo[2]), (180, hi[1], hi[2])) | cv2.inRange(
        hsv, (0, lo[1], lo[2]), (hi[0], hi[1], hi[2]))


def hue_histogram(low_h: int, high_h: int) -> np.ndarray:
    """(180, 1) float32 hue histogram, 255 on the patch's hue range (wrapping), 0 elsewhere."""
    hist = np.zeros((180, 1), np.float32)
    if low_h <= high_h:
        hist[low_h:high_h + 1] = 255
    else:
        hist[low_h:] = 255
        hist[:high_h + 1] = 255
    return hist


HS_BINS = (30, 32)
HS_RANGES = [0, 180, 0, 256]


def hs_histogram(hsv: np.ndarray, mask: np.ndarray | None) -> np.ndarray:
    """Normalised 2-D hue-saturation histogram of the masked pixels (for Bhattacharyya)."""
    h = cv2.calcHist([hsv], [0, 1], mask, list(HS_BINS), HS_RANGES)
    total = float(h.sum())
    return h / total if total > 0 else h


HUE_BINS = 180  # one bin per OpenCV hue unit (2°): a slightly other dye falls in other bins


def hue_distribution(hsv: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """(HUE_BINS, 1) float32 hue histogram of the masked pixels, summing to 1 (all zero
    without pixels)."""
    h = cv2.calcHist([hsv], [0], mask, [HUE_BINS], [0, 180])
    total = float(h.sum())
    return h / total if total > 0 else h


def bhattacharyya(a: np.ndarray, b: np.ndarray) -> float:
    """Bhattacharyya distance √(1 − Σ √(a·b)) of two histograms that each sum to 1: 0 for the
    same distribution, 1 for disjoint ones (OpenCV's HISTCMP_BHATTACHARYYA)."""
    return float(cv2.compareHist(a, b, cv2.HISTCMP_BHATTACHARYYA))
