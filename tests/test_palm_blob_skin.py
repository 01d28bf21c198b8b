"""The hand's skin mask from I420 planes (detect/palm_blob_skin.py) against OpenCV: the YCrCb
range test equals cv2.cvtColor(COLOR_BGR2YCrCb) + cv2.inRange on every 8-bit colour, and the
mask equals OpenCV's (planes to BGR, cv2.resize INTER_AREA to half, YCrCb, inRange:
palm_blobs.hand_roi's steps) on random planes and on the sample session's frames."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from numba import njit

from armtrack_cli.detect import palm_blob_skin as k
from armtrack_cli.detect.palm_blobs import SKIN_YCRCB, skin_mask
from armtrack_cli.session.config import load_session
from armtrack_cli.session.video import iter_frames_i420, probe_video
from armtrack_cli.vision.yuv import YuvFrame

from .test_palm_blob_kernel import all_colours  # noqa: F401 (a fixture)

SAMPLE = Path(__file__).resolve().parents[1] / "sample_sessions" / "wrist-rom-01"
BOUNDS = np.array([*SKIN_YCRCB[0], *SKIN_YCRCB[1]], np.int64)


@njit(cache=True)
def _inside_image(bgr, b, out):
    for y in range(bgr.shape[0]):
        for x in range(bgr.shape[1]):
            out[y, x] = 255 * k.ycrcb_inside(np.int64(bgr[y, x, 0]), np.int64(bgr[y, x, 1]),
                                             np.int64(bgr[y, x, 2]), b[0], b[1], b[2], b[3],
                                             b[4], b[5])


@pytest.mark.parametrize("bounds", [SKIN_YCRCB, ((20, 0, 140), (230, 120, 255))])
def test_ycrcb_range_is_opencvs_on_every_colour(all_colours, bounds):  # noqa: F811
    ours = np.empty(all_colours.shape[:2], np.uint8)
    _inside_image(all_colours, np.array([*bounds[0], *bounds[1]], np.int64), ours)
    ycc = cv2.cvtColor(all_colours, cv2.COLOR_BGR2YCrCb)
    assert np.array_equal(ours, cv2.inRange(ycc, bounds[0], bounds[1]))


def _opencv_mask(f: YuvFrame) -> np.ndarray:
    bgr = f.bgr()
    return skin_mask(cv2.resize(bgr, (bgr.shape[1] // 2, bgr.shape[0] // 2),
                                interpolation=cv2.INTER_AREA))


def _mask(f: YuvFrame) -> np.ndarray:
    out = np.empty((f.shape[0] // 2, f.shape[1] // 2), np.uint8)
    k.skin_half(f.y, f.u, f.v, BOUNDS, out)
    return out


def test_mask_is_opencvs_on_random_planes():
    """Uniform planes (every rounding case of the 2 x 2 mean and of clipping) and planes near
    skin's chroma (so that both sides of each bound are met)."""
    rng = np.random.default_rng(5)
    for near_skin in (False, True):
        for _ in range(4):
            y = rng.integers(0, 256, (240, 320), dtype=np.uint8)
            if near_skin:  # skin's Cr 135-175, Cb 80-130, about U 95-140, V 140-185
                u = rng.integers(90, 145, (120, 160), dtype=np.uint8)
                v = rng.integers(135, 190, (120, 160), dtype=np.uint8)
            else:
                u, v = (rng.integers(0, 256, (120, 160), dtype=np.uint8) for _ in range(2))
            f = YuvFrame(y, u, v)
            want = _opencv_mask(f)
            assert np.array_equal(_mask(f), want)
            if near_skin:
                assert 0.05 < (want > 0).mean() < 0.95  # both kinds of block were met


def test_mask_is_opencvs_on_the_sample():
    video = probe_video(load_session(SAMPLE).camera.video)
    for i, _, f in iter_frames_i420(video):
        if i % 30 == 0:
            want = _opencv_mask(f)
            assert np.array_equal(_mask(f), want), i
            assert (want > 0).sum() > 1000  # the hand was there
