"""The fast paths of detection against their references: regions labelled on the box around
the mask's pixels = connectedComponentsWithStats on the whole mask (labels, order, stats); the
one-pass patch mask = hue back-projection masked by S and V."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from armtrack_cli.detect.colour import hue_histogram
from armtrack_cli.detect.patch_masks import back_projection, patch_mask, sparse_patch_mask
from armtrack_cli.detect.regions import Regions


def _blobs(seed: int, shape=(97, 131)) -> np.ndarray:
    """Random blobs and speckle, some touching the borders, at odd and even offsets."""
    rng = np.random.default_rng(seed)
    m = np.zeros(shape, np.uint8)
    for _ in range(rng.integers(0, 12)):
        c = (int(rng.integers(-5, shape[1] + 5)), int(rng.integers(-5, shape[0] + 5)))
        axes = (int(rng.integers(1, 15)), int(rng.integers(1, 15)))
        cv2.ellipse(m, c, axes, float(rng.uniform(0, 180)), 0, 360, 255, -1)
    m[rng.random(shape) < 0.01] = 255
    m[rng.integers(0, shape[0]), :3] = 255  # something on the edges
    m[-2:, rng.integers(0, shape[1])] = 255
    return m


@pytest.mark.parametrize("seed", range(40))
def test_regions_are_the_whole_mask_components(seed):
    m = _blobs(seed)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(m, 8)
    r = Regions(m)
    assert r.n == n
    np.testing.assert_array_equal(r.stats[1:], stats[1:])
    rows, cols = np.nonzero(m)
    assert [r.label_at(c + 0.5, v + 0.5) for v, c in zip(rows, cols)] == labels[rows, cols].tolist()
    for k in range(1, n):
        x, y, w, h = stats[k, :4]
        np.testing.assert_array_equal(r.mask_of(k), labels[y:y + h, x:x + w] == k)
    assert r.label_at(-1, -1) == 0 and r.label_at(m.shape[1] + 3, 0) == 0


def _random_hsv(rng, shape):
    """An HSV frame of uniform noise in every channel."""
    return np.dstack([rng.integers(0, 180, shape), rng.integers(0, 256, shape),
                      rng.integers(0, 256, shape)]).astype(np.uint8)


def _plain_and_blobs(hsv, seed):
    """A plain background of hsv's shape, and the mask of seed's blobs on it."""
    plain = np.zeros_like(hsv)
    plain[...] = (90, 30, 30)
    return plain, _blobs(seed, hsv.shape[:2]) > 0


@pytest.mark.parametrize("low,high", [((0, 140, 90), (12, 255, 255)),
                                      ((170, 140, 90), (10, 255, 255)),
                                      ((100, 60, 40), (130, 200, 255))])
@pytest.mark.parametrize("seed", range(12))
def test_patch_mask_is_the_masked_back_projection(low, high, seed):
    """Noise everywhere (seed 0), or a few patches and speckle on a plain background, some at
    the image's edges (the opening is done on their box only)."""
    rng = np.random.default_rng(seed)
    hsv = _random_hsv(rng, (120, 160))
    if seed:
        plain, keep = _plain_and_blobs(hsv, seed)
        plain[keep] = hsv[keep]
        hsv = plain
    hsv[40:70, 50:90] = (low[0], 200, 200)  # a patch
    hist = hue_histogram(low[0], high[0])
    np.testing.assert_array_equal(patch_mask(hsv, low, high),
                                  back_projection(hsv, hist, low, high))


@pytest.mark.parametrize("seed", range(10))
def test_centroids(seed):
    """Regions' centroids against the mean of each component's pixel coordinates."""
    m = _blobs(seed)
    n, labels, _, _ = cv2.connectedComponentsWithStats(m, 8)
    r = Regions(m)
    for k in range(1, n):
        rows, cols = np.nonzero(labels == k)
        np.testing.assert_allclose(r.centroids[k], (cols.mean(), rows.mean()), atol=1e-9)


@pytest.mark.parametrize("low,high", [((0, 140, 90), (12, 255, 255)),
                                      ((170, 140, 90), (10, 255, 255))])
@pytest.mark.parametrize("seed", range(12))
def test_sparse_patch_mask_is_the_patch_mask(low, high, seed):
    """The half-resolution-guided mask of the acquiring pass against patch_mask on the whole
    frame: noise everywhere (seed 0), or blobs of every size (down to single pixels and thin
    lines, at odd and even offsets, on the edges) in and out of the range."""
    rng = np.random.default_rng(seed)
    hsv = _random_hsv(rng, (121, 163))
    if seed:
        plain, keep = _plain_and_blobs(hsv, seed)
        plain[keep] = (low[0], 200, 200) if seed % 2 else hsv[keep]
        plain[rng.integers(0, 121), 5:150] = (low[0], 200, 200)  # a 1-px line
        plain[10:13, 20:23 + seed] = (high[0], 200, 200)  # a 3-px-high bar
        hsv = plain
    bgr = cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR)
    hsv = cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV)  # what the tracker sees
    mask, hsv_out = np.full(hsv.shape[:2], 7, np.uint8), np.zeros_like(hsv)
    sparse_patch_mask(bgr, low, high, hsv_out, mask)
    want = patch_mask(hsv, low, high)
    np.testing.assert_array_equal(mask, want)
    on = want > 0
    np.testing.assert_array_equal(hsv_out[on], hsv[on])
