"""The acquiring pass's compiled regions (detect/patch_acquire_kernel.py) against the OpenCV
path they replace (patch_tracker.ReferenceRegions: connectedComponentsWithStats through
detect/regions.Regions, cv2.CamShift on each region alone, calcHist of its hues): the same
regions in the same order, the same stats, centroids, CamShift boxes, windows and looks, on
random masks with blobs touching each other and the edges, speckle and one-pixel regions."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from armtrack_cli.detect.patch_kernel import WindowTracker
from armtrack_cli.detect.patch_tracker import ReferenceRegions
from armtrack_cli.detect.regions import Regions
from tests.test_detect_regions import _blobs


def _scene(seed: int, shape=(121, 163)):
    """An HSV image of random hues and a mask of random ellipses and speckle (test_detect_regions'
    blobs, regions on every edge) with thin bars and a one-pixel diagonal (8-connected only)."""
    rng = np.random.default_rng(seed + 1000)
    mask = _blobs(seed, shape)
    for _ in range(rng.integers(0, 4)):  # thin bars: long, one or two pixels wide
        r, c = int(rng.integers(0, shape[0])), int(rng.integers(0, shape[1] - 30))
        mask[r:r + int(rng.integers(1, 3)), c:c + 30] = 255
    diag = int(rng.integers(0, shape[0] - 12))
    mask[np.arange(diag, diag + 10), np.arange(5, 15)] = 255
    hsv = np.dstack([rng.integers(0, 180, shape), rng.integers(0, 256, shape),
                     rng.integers(0, 256, shape)]).astype(np.uint8)
    return hsv, mask


@pytest.mark.parametrize("seed", range(30))
def test_regions_equal_the_opencv_path(seed):
    hsv, mask = _scene(seed)
    min_area = 25 if seed % 3 else 1
    ref = ReferenceRegions(hsv, Regions(mask))
    fast = WindowTracker((0, 0, 0), (179, 255, 255)).whole_regions(hsv, min_area, (hsv, mask))
    n, _, stats, cent = cv2.connectedComponentsWithStats(mask, 8)
    assert fast.n == ref.n == n
    np.testing.assert_array_equal(fast.stats[1:], stats[1:])  # order and stats
    np.testing.assert_array_equal(fast.centroids[1:], ref.centroids[1:])
    np.testing.assert_allclose(fast.centroids[1:], cent[1:], rtol=0, atol=1e-9)
    described = 0
    for k in range(1, n):
        if stats[k, cv2.CC_STAT_AREA] < min_area:
            continue
        (a_c, a_size, a_ang), a_win, a = fast.describe(k)
        (b_c, b_size, b_ang), b_win, b = ref.describe(k)
        assert (a_c, a_size, a_ang, a_win) == (b_c, tuple(b_size), b_ang, tuple(b_win)), k
        assert (a.mass, a.aspect, a.centroid, a.cut) == (b.mass, b.aspect, b.centroid, b.cut)
        np.testing.assert_array_equal(a.hist.ravel(), b.hist.ravel())
        described += 1
    assert described > 0 or n == 1 or min_area > 1


def test_an_empty_mask_has_only_the_background():
    hsv, mask = np.zeros((40, 60, 3), np.uint8), np.zeros((40, 60), np.uint8)
    fast = WindowTracker((0, 0, 0), (179, 255, 255)).whole_regions(hsv, 25, (hsv, mask))
    assert fast.n == Regions(mask).n == 1
