"""The I420 frame path of detect (issue 15): PyAV's planes, converted to BGR only where the
patch tracker looks. Against OpenCV's reader: the same frames at the same indices and times;
a window converted alone equals the same pixels of the whole frame converted; the tracker
finds the same detections on the planes as on the whole frames converted."""

from __future__ import annotations

import sys

import cv2
import numpy as np
import pytest

from armtrack_cli.detect.patch_tracker import PatchTracker
from armtrack_cli.session.config import load_session
from armtrack_cli.session.video import iter_frames, iter_frames_ahead, iter_frames_i420, probe_video
from armtrack_cli.vision.yuv import YuvFrame, crop_to_bgr

from .conftest import REPO

SAMPLES = REPO / "sample_sessions"

pytest.importorskip("av")


def _planes(rng, h, w):
    return (rng.integers(0, 256, (h, w), np.uint8), rng.integers(0, 256, ((h + 1) // 2,
            (w + 1) // 2), np.uint8), rng.integers(0, 256, ((h + 1) // 2, (w + 1) // 2),
            np.uint8))


def _whole_bgr(y, u, v):
    """OpenCV's I420 conversion of the whole image (even sizes), planes concatenated."""
    h, w = y.shape
    return cv2.cvtColor(np.concatenate([y.ravel(), u.ravel(), v.ravel()]).reshape(
        h * 3 // 2, w), cv2.COLOR_YUV2BGR_I420)


@pytest.mark.parametrize("h,w", [(48, 64), (47, 63)])
def test_a_window_converts_as_the_whole_frame_does(h, w):
    rng = np.random.default_rng(3)
    y, u, v = _planes(rng, h, w)
    if h % 2 or w % 2:  # odd sizes: the last row / column shares the chroma of the one before
        ye = np.pad(y, ((0, h % 2), (0, w % 2)), mode="edge")
        whole = _whole_bgr(ye, u, v)[:h, :w]
    else:
        whole = _whole_bgr(y, u, v)
    f = YuvFrame(y, u, v)
    assert np.array_equal(f.bgr(), whole)
    for _ in range(40):
        x0, x1 = sorted(rng.integers(0, w + 1, 2))
        y0, y1 = sorted(rng.integers(0, h + 1, 2))
        x1, y1 = max(x1, x0 + 1), max(y1, y0 + 1)
        if x1 > w or y1 > h:
            continue
        assert np.array_equal(crop_to_bgr(f, x0, y0, x1, y1), whole[y0:y1, x0:x1]), (x0, y0, x1,
                                                                                     y1)


@pytest.mark.parametrize("name", ["circle-01", "wrist-rom-01"])
def test_same_frames_indices_and_times_as_opencv(name):
    """Each plane frame is OpenCV's frame of that index: within FFmpeg's and OpenCV's rounding
    of the same colour conversion (a few levels), far closer than to its neighbours (so no
    frame is dropped, repeated or shifted)."""
    video = probe_video(load_session(SAMPLES / name).camera.video)
    ref = list(iter_frames(video))
    got = list(iter_frames_i420(video))
    assert len(got) == len(ref) == video.n_frames
    assert [(i, t) for i, t, _ in got] == [(i, t) for i, t, _ in ref]
    assert all(isinstance(f, YuvFrame) for _, _, f in got)
    for k in range(0, len(ref), 3):  # every third frame: a shift would show on any of them
        d = np.abs(ref[k][2].astype(np.int16) - got[k][2].bgr())
        assert d.max() <= 8 and d.mean() < 1.5, (k, d.max(), d.mean())
    step = [np.abs(ref[k][2].astype(np.int16) - ref[k + 1][2]).mean() for k in range(20)]
    assert max(step) > 1.5  # consecutive frames differ more than the conversions do


def test_without_pyav_or_i420_opencv_reads_it(tmp_path, monkeypatch):
    """A video PyAV does not give as yuv420p (here MJPEG: full-range yuvj420p) comes as BGR
    images, and so does every video when PyAV is not installed: exactly iter_frames'."""
    path = tmp_path / "v.avi"
    out = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30.0, (64, 48))
    rng = np.random.default_rng(0)
    for _ in range(5):
        out.write(rng.integers(0, 256, (48, 64, 3), np.uint8))
    out.release()
    video = probe_video(path)
    ref = [f for _, _, f in iter_frames(video)]
    got = [f for _, _, f in iter_frames_i420(video)]
    assert len(got) == 5 and all(isinstance(f, np.ndarray) for f in got)
    assert all(np.abs(a.astype(int) - b).max() <= 8 for a, b in zip(ref, got))
    monkeypatch.setitem(sys.modules, "av", None)  # import av fails
    got = [f for _, _, f in iter_frames_i420(video)]
    assert all(np.array_equal(a, b) for a, b in zip(ref, got))


def test_ahead_in_batches_keeps_every_frame_in_order():
    video = probe_video(load_session(SAMPLES / "circle-01").camera.video)
    assert [i for i, _, _ in iter_frames_ahead(video, i420=True)] == list(range(video.n_frames))


def test_tracker_on_planes_equals_tracker_on_their_bgr():
    """Windows converted alone (tracking) and whole frames (acquiring) give exactly what the
    tracker finds on the whole frames converted first."""
    session = load_session(SAMPLES / "circle-01")
    video = probe_video(session.camera.video)
    c = session.camera.patch
    a, b = PatchTracker(c.low, c.high, fps=video.fps), PatchTracker(c.low, c.high, fps=video.fps)
    for i, _, f in iter_frames_i420(video):
        a.step(i, YuvFrame(f.y, f.u, f.v))
        b.step(i, f.bgr())
    da, db = a.detections(), b.detections()
    assert da[:, 5].sum() >= 0.95 * video.n_frames
    np.testing.assert_array_equal(da, db)
