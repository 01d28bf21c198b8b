"""The compiled palm-blob search (detect/palm_blob_kernel.py) against OpenCV: its HSV equals
cv2.cvtColor on every 8-bit colour, its prefilter keeps every pixel cv2.inRange keeps, and the
detector finds the same blobs (same order, values to 1e-9) as the OpenCV reference path
(compiled=False) on the sample session's frames and on random scenes with a hue range that
wraps through red."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from numba import njit

from armtrack_cli.detect import palm_blob_kernel as k
from armtrack_cli.detect.colour import range_mask
from armtrack_cli.detect.palm_blobs import PalmBlobDetector, PalmBlobSettings
from armtrack_cli.session.config import load_session
from armtrack_cli.session.video import iter_frames, probe_video

SAMPLE = Path(__file__).resolve().parents[1] / "sample_sessions" / "wrist-rom-01"


@pytest.fixture(scope="module")
def all_colours() -> np.ndarray:
    """(4096, 4096, 3) uint8: every BGR colour once."""
    a = np.arange(1 << 24, dtype=np.uint32)
    return np.stack([(a >> 16) & 255, (a >> 8) & 255, a & 255], -1).astype(
        np.uint8).reshape(4096, 4096, 3)


@njit(cache=True)
def _hsv_image(bgr, out):
    for y in range(bgr.shape[0]):
        for x in range(bgr.shape[1]):
            out[y, x, 0], out[y, x, 1], out[y, x, 2] = k._hsv(
                np.int64(bgr[y, x, 0]), np.int64(bgr[y, x, 1]), np.int64(bgr[y, x, 2]),
                k.SDIV, k.HDIV)


def test_hsv_is_opencvs_on_every_colour(all_colours):
    ours = np.empty_like(all_colours)
    _hsv_image(all_colours, ours)
    assert np.array_equal(ours, cv2.cvtColor(all_colours, cv2.COLOR_BGR2HSV))


@pytest.mark.parametrize("rng", [
    (88, 60, 30, 142, 255, 255),  # wrist-rom-01's candidate range (blue markers)
    (100, 150, 60, 130, 255, 255),  # its markers' own range
    (170, 80, 40, 10, 255, 255),  # red: the hue wraps
    (0, 0, 0, 10, 200, 200),  # from hue 0, with upper S and V bounds
    (40, 30, 20, 80, 250, 240)])
def test_prefilter_keeps_every_pixel_in_range(all_colours, rng):
    exact = range_mask(cv2.cvtColor(all_colours, cv2.COLOR_BGR2HSV), rng[:3], rng[3:]) > 0
    maybe = np.zeros(1 << 24, np.uint8)
    k._maybe_row(all_colours.reshape(-1), 1 << 24, k.prefilter_bounds(np.array(rng)), maybe)
    maybe = maybe.reshape(4096, 4096) > 0
    assert not (exact & ~maybe).any()  # a superset
    assert maybe.sum() < 1.1 * exact.sum()  # and a tight one: the exact test runs on few more


def _same_blobs(frames, low, high, settings):
    fast = PalmBlobDetector(low, high, settings)
    ref = PalmBlobDetector(low, high, settings, compiled=False)
    found = 0
    for i, img in enumerate(frames):
        a, b = fast.detect(img), ref.detect(img)
        assert a.shape == b.shape, (i, a, b)
        assert np.abs(a - b).max(initial=0.0) < 1e-9, (i, a, b)
        found += len(a)
    assert fast.full_searches == ref.full_searches
    return found


@pytest.mark.parametrize("settings", [PalmBlobSettings(),
                                      PalmBlobSettings(full_every=0, centroid="core")])
def test_compiled_search_equals_the_opencv_reference_on_the_sample(settings):
    s = load_session(SAMPLE)
    frames = [img for _, _, img in iter_frames(probe_video(s.camera.video))]
    if settings.full_every == 0:  # every frame searched alone: a quarter of them is enough
        frames = frames[::4]
    assert _same_blobs(frames, s.palm.colour.low, s.palm.colour.high, settings) > 6 * len(frames)


def _scene(rng: np.random.Generator, hues) -> np.ndarray:
    """A noisy 240 x 320 scene: a skin-coloured hand with discs of the given hues (OpenCV
    units) on it, some touching each other, some clipped by the hand's edge, and clutter."""
    img = np.full((240, 320, 3), (60, 90, 70), np.uint8)
    cv2.ellipse(img, (150, 120), (80, 60), 0, 0, 360, (120, 150, 210), -1)  # skin (BGR)
    for _ in range(14):
        h = int(rng.choice(hues)) % 180
        bgr = cv2.cvtColor(np.uint8([[[h, rng.integers(120, 256), rng.integers(90, 256)]]]),
                           cv2.COLOR_HSV2BGR)[0, 0]
        centre = (int(rng.integers(60, 260)), int(rng.integers(50, 200)))
        cv2.circle(img, centre, int(rng.integers(2, 8)), tuple(int(c) for c in bgr), -1)
    noise = rng.normal(0, 6, img.shape)
    return np.clip(img + noise, 0, 255).astype(np.uint8)


# colour ranges (low, high) and the disc hues drawn in a random scene: one wraps through red
RANDOM_SCENES = [((172, 120, 80), (6, 255, 255), (170, 175, 178, 0, 3, 8, 30, 100)),
                 ((50, 100, 60), (70, 255, 255), (45, 55, 60, 68, 75, 120))]


@pytest.mark.parametrize("low, high, hues", RANDOM_SCENES)
def test_compiled_search_equals_the_opencv_reference_on_random_scenes(low, high, hues):
    rng = np.random.default_rng(7)
    frames = [_scene(rng, hues) for _ in range(40)]
    for centroid in ("region", "core"):  # every region scored: min_score 0
        settings = PalmBlobSettings(full_every=0, centroid=centroid, min_score=0.0)
        assert _same_blobs(frames, low, high, settings) > 4 * len(frames)
