"""The compiled tracked frame (detect/patch_kernel.py) against its OpenCV reference
(patch_tracker.track_reference and the cv2 calls it makes): I420 → HSV on every (Y, U, V), the
range mask, the 3 x 3 opening, CamShift's box and window, the region under its centre, and
whole tracks of the bundled and a simulated distractor video."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from armtrack_cli.detect import patch_kernel as pk
from armtrack_cli.detect.camshift_kernel import camshift
from armtrack_cli.detect.colour import range_mask
from armtrack_cli.detect.palm_blob_kernel import prefilter_bounds
from armtrack_cli.detect.patch_masks import patch_mask
from armtrack_cli.detect.patch_tracker import TERM, PatchTracker, track_reference
from armtrack_cli.vision.yuv import YuvFrame

RANGES = [((35, 80, 60), (85, 255, 255)), ((170, 60, 40), (10, 230, 250)),
          ((0, 0, 0), (179, 255, 255)), ((100, 140, 20), (130, 200, 120))]


@pytest.fixture(scope="module")
def every_yuv():
    """An I420 frame holding every (Y, U, V): each 2 x 2 block one (U, V), 4 of the Y values;
    64 blocks per (U, V) pair (4096 x 4096 pixels)."""
    uv = np.arange(65536)
    blocks = np.repeat(uv, 64)  # (U, V) of each block, 2048 x 2048 blocks
    u = (blocks >> 8).astype(np.uint8).reshape(2048, 2048)
    v = (blocks & 255).astype(np.uint8).reshape(2048, 2048)
    ys = (np.arange(256, dtype=np.uint8).reshape(64, 4))  # block k of a pair: Y = 4k … 4k + 3
    yb = np.tile(ys, (65536, 1)).reshape(2048, 2048, 2, 2)  # (block row, block col, dy, dx)
    y = np.ascontiguousarray(yb.transpose(0, 2, 1, 3).reshape(4096, 4096))
    return YuvFrame(y, u, v)


@pytest.mark.parametrize("low, high", RANGES)
def test_hue_and_mask_of_every_yuv_equal_opencv(every_yuv, low, high):
    f = every_yuv
    H, W = f.y.shape
    i420 = np.concatenate([f.y.reshape(-1), f.u.reshape(-1), f.v.reshape(-1)]).reshape(-1, W)
    hsv = cv2.cvtColor(cv2.cvtColor(i420, cv2.COLOR_YUV2BGR_I420), cv2.COLOR_BGR2HSV)
    hue, mask = np.empty((H, W), np.uint8), np.empty((H, W), np.uint8)
    rng = np.array([*low, *high], np.int64)
    pre, row, maybe = prefilter_bounds(rng), np.empty(3 * W, np.uint8), np.empty(W, np.uint8)
    table, cols = pk.chroma_table(rng), np.empty(W // 2 + 2, np.int64)
    bounds = pk.chroma_bounds(table)
    pk.hsv_mask_i420(f.y, f.u, f.v, 0, 0, W, H, rng, table, bounds, hue, mask, cols)
    want = range_mask(hsv, low, high)
    np.testing.assert_array_equal(mask, want)
    np.testing.assert_array_equal(hue[want > 0], hsv[..., 0][want > 0])  # only there needed
    sub = (slice(1001, 1400), slice(2003, 2101))  # a window of odd corners, as tracking cuts
    inside = want[sub] > 0
    pk.hsv_mask_i420(f.y, f.u, f.v, 2003, 1001, 2101, 1400, rng, table, bounds, hue, mask,
                     cols)
    np.testing.assert_array_equal(mask[:399, :98], want[sub])
    np.testing.assert_array_equal(hue[:399, :98][inside], hsv[sub][..., 0][inside])
    bgr = cv2.cvtColor(i420, cv2.COLOR_YUV2BGR_I420)[sub]
    pk.hsv_mask_bgr(bgr, 0, 0, 98, 399, rng, pre, row, maybe, hue, mask)
    np.testing.assert_array_equal(mask[:399, :98], want[sub])
    np.testing.assert_array_equal(hue[:399, :98][inside], hsv[sub][..., 0][inside])


@pytest.mark.parametrize("low, high", RANGES[:2])
def test_whole_frame_mask_and_box_equal_opencv(every_yuv, low, high):
    """The acquiring pass's opened mask of a whole frame and its box, against patch_mask on
    OpenCV's HSV and cv2.boundingRect (the every-(Y, U, V) frame: noise, many regions)."""
    f = every_yuv
    H, W = f.y.shape
    i420 = np.concatenate([f.y.reshape(-1), f.u.reshape(-1), f.v.reshape(-1)]).reshape(-1, W)
    hsv = cv2.cvtColor(cv2.cvtColor(i420, cv2.COLOR_YUV2BGR_I420), cv2.COLOR_BGR2HSV)
    hue, mask, box = pk.WindowTracker(low, high).whole_mask(f)
    want = patch_mask(hsv, low, high)
    np.testing.assert_array_equal(mask, want)
    assert box == tuple(cv2.boundingRect(want))
    np.testing.assert_array_equal(hue[want > 0], hsv[..., 0][want > 0])


def _blobs(rng, h, w, n):
    """A mask of n random filled ellipses plus speckle, 0/255."""
    m = np.zeros((h, w), np.uint8)
    for _ in range(n):
        c = (int(rng.integers(0, w)), int(rng.integers(0, h)))
        axes = (int(rng.integers(1, max(2, w // 3))), int(rng.integers(1, max(2, h // 3))))
        cv2.ellipse(m, c, axes, float(rng.uniform(0, 180)), 0, 360, 255, -1)
    m[rng.random((h, w)) < 0.02] = 255
    return m


def test_opening_equals_opencv():
    rng = np.random.default_rng(3)
    for h, w in [(1, 1), (1, 7), (5, 1), (2, 2), (37, 51), (120, 96)]:
        m = _blobs(rng, h, w, 3)
        m[rng.random((h, w)) < 0.3] = 255
        want = cv2.morphologyEx(m, cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))
        big, tmp = np.zeros((130, 130), np.uint8), np.empty((130, 130), np.uint8)
        big[:h, :w] = m
        pk.open3(big, tmp, h, w)
        np.testing.assert_array_equal(big[:h, :w], want)


def test_camshift_equals_opencv():
    """Box within 1e-6 px (and degree), window identical, on 400 random masks and windows
    (among them windows at the edges and windows over no mass)."""
    rng = np.random.default_rng(11)
    res = np.zeros(pk.RES)
    empty = 0
    for k in range(400):
        h, w = int(rng.integers(20, 140)), int(rng.integers(20, 140))
        m = _blobs(rng, h, w, int(rng.integers(0, 4)))
        if k % 10 == 0:  # a window over no mass
            m[:] = 0
        x, y = int(rng.integers(0, w)), int(rng.integers(0, h))
        ww, wh = int(rng.integers(1, w - x + 1)), int(rng.integers(1, h - y + 1))
        (c, size, ang), win = cv2.CamShift(m, (x, y, ww, wh), TERM)
        ok = camshift(m, h, w, x, y, ww, wh, pk.NITERS, res)
        if not ok:  # OpenCV's empty box
            empty += 1
            assert size == (0.0, 0.0) and c == (0.0, 0.0)
            continue
        np.testing.assert_allclose(res[1:6], [*c, *size, ang], atol=1e-6, rtol=0)
        assert tuple(int(v) for v in res[6:10]) == tuple(win)
    assert empty == 40


def _video_frames(path, n):
    from armtrack_cli.session.video import iter_frames_i420, probe_video
    out = []
    for i, _, f in iter_frames_i420(probe_video(path)):
        if i >= n:
            break
        out.append(f)
    return out


def _compare_tracks(frames, low, high, fps):
    """The tracker with the kernel and with the OpenCV reference: the same windows frame by
    frame and the same detections; each of the kernel's tracked frames also computed by
    track_reference from the same start and compared. Returns how many were compared."""
    fast, ref = PatchTracker(low, high, fps=fps), PatchTracker(low, high, fps=fps, kernel=False)
    kernel_track, compared = fast._kernel.track, []

    def both(frame, box, start):
        a, b = kernel_track(frame, box, start), track_reference(frame, box, start, low, high)
        assert (a is None) == (b is None)
        if a is not None:
            np.testing.assert_allclose([*a[0][0], *a[0][1], a[0][2]],
                                       [*b[0][0], *b[0][1], b[0][2]], atol=1e-6, rtol=0)
            assert a[1] == tuple(b[1]) and a[2].mass == b[2].mass and a[2].cut == b[2].cut
            assert a[2].centroid == b[2].centroid and a[2].aspect == b[2].aspect
            np.testing.assert_array_equal(a[2].hist, b[2].hist)
            compared.append(1)
        return a

    fast._kernel.track = both
    for i, f in enumerate(frames):
        fast.step(i, f)
        ref.step(i, f)
        assert fast.window == ref.window, i
    np.testing.assert_array_equal(fast.detections(), ref.detections())
    return len(compared)


def test_tracks_equal_the_reference_on_the_bundled_video():
    from armtrack_cli.session.config import load_session
    session = load_session(Path(__file__).resolve().parents[1] / "sample_sessions" / "circle-01")
    c = session.camera.patch
    frames = _video_frames(session.camera.video, 300)
    assert _compare_tracks(frames, c.low, c.high, 30.0) > 200


def test_tracks_equal_the_reference_with_a_moving_distractor(tmp_path):
    from armtrack_cli import pipeline
    from armtrack_cli.session.config import load_session
    from armtrack_cli.simulate.arm_session import ArmSimSettings
    folder = tmp_path / "md"
    pipeline.simulate(folder, ArmSimSettings(task="rectangle", seed=4, duration_s=8.0,
                                             moving_distractor=True, clutter=True,
                                             distractor=True))
    session = load_session(folder)
    c = session.camera.patch
    frames = _video_frames(session.camera.video, 240)
    assert _compare_tracks(frames, c.low, c.high, 30.0) > 100


def test_tracks_on_bgr_frames_equal_the_reference():
    """Frames given as BGR images (as a caller without I420 planes gives them): the kernel's
    BGR pass, the same windows and detections as the reference."""
    from armtrack_cli.session.config import load_session
    session = load_session(Path(__file__).resolve().parents[1] / "sample_sessions" / "circle-01")
    c = session.camera.patch
    frames = [f.bgr() for f in _video_frames(session.camera.video, 120)]
    assert _compare_tracks(frames, c.low, c.high, 30.0) > 30
