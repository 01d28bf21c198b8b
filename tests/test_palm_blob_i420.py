"""Palm blobs found on a frame's I420 planes (detect/palm_blob_i420.py, what `armtrack detect`
does with PyAV's frames) against OpenCV: each pixel converts as cv2.COLOR_YUV2BGR_I420
converts it, on every (Y, U, V); the luma-range prefilter keeps every candidate; and the
detector finds on the planes the same blobs (same order, values to 1e-9) as the OpenCV
reference path on the BGR image OpenCV converts them to, on the sample session, on a
simulated palm session (validation/palm.py's kind) and on random scenes."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from numba import njit

from armtrack_cli import pipeline
from armtrack_cli.detect import palm_blob_i420 as k
from armtrack_cli.detect.colour import range_mask
from armtrack_cli.detect.palm_blob_kernel import HDIV, SDIV
from armtrack_cli.detect.palm_blobs import PalmBlobDetector, PalmBlobSettings
from armtrack_cli.session.config import load_session
from armtrack_cli.session.video import iter_frames_i420, probe_video
from armtrack_cli.simulate.palm_session import PalmSimSettings
from armtrack_cli.vision.yuv import YuvFrame

from .test_palm_blob_kernel import RANDOM_SCENES, _scene

pytest.importorskip("av")

SAMPLE = Path(__file__).resolve().parents[1] / "sample_sessions" / "wrist-rom-01"


@pytest.fixture(scope="module")
def every_yuv() -> YuvFrame:
    """4096 x 4096 planes holding every (Y, U, V) once: block (by, bx) has chroma number
    (by * 2048 + bx) // 64 (U its high byte, V its low), its four pixels four luma values."""
    b = np.arange(1 << 22, dtype=np.int64).reshape(2048, 2048)
    uv, q = b // 64, b % 64
    y = np.empty((4096, 4096), np.uint8)
    for dy in range(2):
        for dx in range(2):
            y[dy::2, dx::2] = 4 * q + 2 * dy + dx
    return YuvFrame(y, (uv >> 8).astype(np.uint8), (uv & 255).astype(np.uint8))


@njit(cache=True)
def _convert(f_y, f_u, f_v, out):
    for y in range(f_y.shape[0]):
        for x in range(f_y.shape[1]):
            out[y, x, 0], out[y, x, 1], out[y, x, 2] = k.i420_bgr(
                np.int64(f_y[y, x]), np.int64(f_u[y >> 1, x >> 1]), np.int64(f_v[y >> 1, x >> 1]))


def test_every_yuv_converts_as_opencv_does(every_yuv):
    f = every_yuv
    ours = np.empty(f.shape, np.uint8)
    _convert(f.y, f.u, f.v, ours)
    assert np.array_equal(ours, f.bgr())  # vision.yuv: cv2.cvtColor(..., COLOR_YUV2BGR_I420)


@pytest.mark.parametrize("rng", [
    (88, 60, 30, 142, 255, 255),  # wrist-rom-01's candidate range (blue markers)
    (170, 80, 40, 10, 255, 255),  # red: the hue wraps
    (40, 30, 20, 80, 250, 240)])
def test_luma_ranges_hold_every_candidate(every_yuv, rng):
    """Every pixel OpenCV's HSV puts in the range has its luma inside its chroma's range."""
    f = every_yuv
    exact = range_mask(cv2.cvtColor(f.bgr(), cv2.COLOR_BGR2HSV), rng[:3], rng[3:]) > 0
    cand = np.array(rng, np.int64)
    table = np.array([k._luma_range(u, v, cand, SDIV, HDIV) for u in range(0, 256, 15)
                      for v in range(256)])  # a sample of chromas: the python loop is slow
    u_of = f.u.repeat(2, 0).repeat(2, 1).astype(np.int64)
    v_of = f.v.repeat(2, 0).repeat(2, 1).astype(np.int64)
    sampled = (u_of % 15 == 0)
    row = (u_of // 15) * 256 + v_of
    lo, hi = table[row[sampled], 0], table[row[sampled], 1]
    yv = f.y[sampled]
    inside = (yv >= lo) & (yv <= hi)
    assert not (exact[sampled] & ~inside).any()  # a superset
    assert inside.sum() <= 1.5 * exact[sampled].sum() + 10  # and not a loose one


def _same_blobs(frames, low, high, settings) -> int:
    """The compiled detector on the planes against the OpenCV reference on the BGR image."""
    fast = PalmBlobDetector(low, high, settings)
    ref = PalmBlobDetector(low, high, settings, compiled=False)
    found = 0
    for i, f in enumerate(frames):
        assert isinstance(f, YuvFrame)
        a, b = fast.detect(f), ref.detect(f.bgr())
        assert a.shape == b.shape, (i, a, b)
        assert np.abs(a - b).max(initial=0.0) < 1e-9, (i, a, b)
        found += len(a)
    assert fast.full_searches == ref.full_searches
    return found


def _planes(folder: Path) -> tuple[list[YuvFrame], tuple, tuple]:
    s = load_session(folder)
    frames = [f for _, _, f in iter_frames_i420(probe_video(s.camera.video))]
    return frames, s.palm.colour.low, s.palm.colour.high


@pytest.mark.parametrize("settings", [PalmBlobSettings(),
                                      PalmBlobSettings(full_every=0, centroid="core")])
def test_planes_give_the_reference_blobs_on_the_sample(settings):
    frames, lo, hi = _planes(SAMPLE)
    if settings.full_every == 0:
        frames = frames[::4]
    assert _same_blobs(frames, lo, hi, settings) > 6 * len(frames)


def test_planes_give_the_reference_blobs_on_a_simulated_palm_session(tmp_path):
    """validation/palm.py's kind of session: clutter on the table, a second clutter blob
    appearing, a marker hidden (the window lost and the hand's region searched again)."""
    pipeline.simulate(tmp_path / "s", PalmSimSettings(
        task="reach-grasp", seed=2, duration_s=4.0, hide=((3, 1.0, 1.0),), clutter2_s=2.0))
    frames, lo, hi = _planes(tmp_path / "s")
    assert _same_blobs(frames, lo, hi, PalmBlobSettings()) > 6 * len(frames)


def _scene_planes(rng: np.random.Generator, hues) -> YuvFrame:
    """A noisy 240 x 320 scene (discs of the given hues on a skin-coloured hand, some clipped,
    some touching) as I420 planes, by OpenCV's BGR -> I420."""
    img = _scene(rng, hues)  # the BGR scene test_palm_blob_kernel searches
    i420 = cv2.cvtColor(img, cv2.COLOR_BGR2YUV_I420).reshape(-1)
    y = i420[:240 * 320].reshape(240, 320)
    u = i420[240 * 320:240 * 320 * 5 // 4].reshape(120, 160)
    return YuvFrame(y, u, i420[240 * 320 * 5 // 4:].reshape(120, 160))


@pytest.mark.parametrize("low, high, hues", RANDOM_SCENES)
def test_planes_give_the_reference_blobs_on_random_scenes(low, high, hues):
    rng = np.random.default_rng(11)
    frames = [_scene_planes(rng, hues) for _ in range(30)]
    for centroid in ("region", "core"):  # every region scored, the window used
        settings = PalmBlobSettings(full_every=5, centroid=centroid, min_score=0.0)
        assert _same_blobs(frames, low, high, settings) > 3 * len(frames)


def test_detect_writes_the_reference_blobs_of_the_decoded_frames(tmp_path):
    """`armtrack detect` on the sample (PyAV's planes on a second thread, the compiled search)
    writes, row for row, what the OpenCV reference finds on the frames converted to BGR."""
    import pandas as pd

    frames, lo, hi = _planes(SAMPLE)
    ref = PalmBlobDetector(lo, hi, compiled=False)
    want = [(i, b) for i, f in enumerate(frames) for b in ref.detect(f.bgr())]
    pipeline.detect(SAMPLE, out=tmp_path)
    got = pd.read_csv(tmp_path / "detections.csv", comment="#")
    assert len(got) == len(want) > 6 * len(frames)
    assert np.array_equal(got["frame"].to_numpy(), [i for i, _ in want])
    b = np.array([b for _, b in want])
    assert np.allclose(got[["u", "v", "score"]].to_numpy(), b[:, [0, 1, 3]], rtol=0, atol=1e-6)
    assert np.array_equal(got["area"].to_numpy(), b[:, 2].astype(int))
