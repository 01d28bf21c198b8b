"""Qualisys TSV variants, video containers and timestamps, camera YAML round trips."""

from __future__ import annotations

import subprocess
import sys

import cv2
import numpy as np
import pytest

from armtrack_cli.core.errors import GroundTruthError
from armtrack_cli.core.streams import CameraModel
from armtrack_cli.session.camera_yaml import read_camera_yaml, write_camera_yaml
from armtrack_cli.session.export.mcap import write_imu_mcap
from armtrack_cli.session.export.qualisys import format_qtm_tsv
from armtrack_cli.session.qualisys import read_qualisys, to_world
from armtrack_cli.session.video import iter_frames, probe_video

from .conftest import DATA


def _markers(n=120, seed=0):
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1, 1, (n, 2, 3))
    x[10:14, 0] = np.nan  # a gap
    return x


@pytest.mark.parametrize("gap", ["", "NaN", "0.000"])
@pytest.mark.parametrize("frame_time_row", [True, False])
@pytest.mark.parametrize("crlf", [True, False])
def test_qtm_variants(tmp_path, gap, frame_time_row, crlf):
    x = _markers()
    text = format_qtm_tsv(x, ["A", "B"], 200.0, gap=gap, frame_time_row=frame_time_row, crlf=crlf,
                          trailing_tab=True)
    (tmp_path / "q.tsv").write_bytes(text.encode())
    m = read_qualisys(tmp_path / "q.tsv")
    assert m.names == ("A", "B") and m.rate_hz == 200.0
    assert np.isnan(m.xyz[10:14, 0]).all() and np.isfinite(m.xyz[14:, 0]).all()  # gaps missing
    np.testing.assert_allclose(m.xyz, x, atol=5e-7)  # mm in the file -> m, 3 decimals
    np.testing.assert_allclose(m.t, np.arange(120) / 200.0, atol=1e-9)


def test_old_export_with_frame_and_time_columns_but_no_column_row(tmp_path):
    x = _markers()
    text = format_qtm_tsv(x, ["A", "B"], 100.0, frame_time_row=True)
    body = [ln for ln in text.splitlines() if not ln.startswith("Frame\t")]
    (tmp_path / "q.tsv").write_text("\n".join(body) + "\n")
    m = read_qualisys(tmp_path / "q.tsv")
    np.testing.assert_allclose(m.xyz, x, atol=5e-7)
    np.testing.assert_allclose(m.t, np.arange(120) / 100.0)


def test_to_world_moves_markers_and_keeps_gaps():
    T = np.array([[0, -1, 0, 0.5], [1, 0, 0, 0], [0, 0, 1, -0.7], [0, 0, 0, 1.0]])
    p = np.array([[1.0, 2.0, 3.0], [np.nan, np.nan, np.nan]])
    w = to_world(p, T)
    np.testing.assert_allclose(w[0], [-1.5, 1.0, 2.3])
    assert np.isnan(w[1]).all()


def test_6dof_export_is_named_as_such(tmp_path):
    (tmp_path / "q.tsv").write_text("NO_OF_FRAMES\t1\nFREQUENCY\t100\nNO_OF_BODIES\t1\n"
                                    "BODY_NAMES\thand\n1\t0\t1\t2\t3\n")
    with pytest.raises(GroundTruthError, match="6DOF"):
        read_qualisys(tmp_path / "q.tsv")


def _write_video(path, n=12, fps=30.0, size=(80, 60)):
    w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG" if path.suffix == ".avi"
                                                           else "mp4v"), fps, size)
    for i in range(n):
        img = np.zeros((size[1], size[0], 3), np.uint8)
        img[:, : 5 * (i + 1)] = 255  # frame i has a bar 5(i+1) px wide
        w.write(img)
    w.release()


@pytest.mark.parametrize("suffix", [".mp4", ".avi", ".mkv"])
def test_video_containers(tmp_path, suffix):
    p = tmp_path / f"video{suffix}"
    _write_video(p)
    v = probe_video(p)
    assert (v.n_frames, v.width, v.height) == (12, 80, 60) and v.fps == pytest.approx(30.0)
    frames = list(iter_frames(v))
    assert [i for i, _, _ in frames] == list(range(12))
    assert frames[5][1] == pytest.approx(5 / 30.0)
    bar = [(img[30, :, 0] > 128).sum() for _, _, img in frames]
    assert all(abs(b - 5 * (i + 1)) <= 2 for i, b in enumerate(bar))  # order kept


def test_video_timestamps_override_fps(tmp_path):
    _write_video(tmp_path / "video.mp4")
    t = np.cumsum(np.r_[0, np.full(11, 0.034)])
    (tmp_path / "video_timestamps.csv").write_text(
        "frame,t\n" + "\n".join(f"{i},{v:.4f}" for i, v in enumerate(t)) + "\n")
    v = probe_video(tmp_path / "video.mp4")
    assert v.timestamps_from == "video_timestamps.csv"
    np.testing.assert_allclose(v.t, t, atol=1e-6)


@pytest.mark.parametrize("encoding", ["cdr", "json"])
def test_camera_images_in_mcap(tmp_path, encoding):
    imgs = []
    for i in range(6):
        img = np.full((40, 50, 3), 40 * i, np.uint8)
        imgs.append((i / 30.0, cv2.imencode(".jpg", img)[1].tobytes()))
    t = np.arange(50) / 100.0
    write_imu_mcap(tmp_path / "rec.mcap", t, np.tile([0, 0, 9.81], (50, 1)), np.zeros((50, 3)),
                   None, encoding=encoding, images=imgs)
    v = probe_video(tmp_path / "rec.mcap")
    assert (v.source, v.n_frames, v.width, v.height) == ("mcap", 6, 50, 40)
    assert v.fps == pytest.approx(30.0, rel=1e-4)
    means = [img.mean() for _, _, img in iter_frames(v)]
    np.testing.assert_allclose(means, [40 * i for i in range(6)], atol=2)


def test_camera_yaml_round_trip_readable_by_opencv(tmp_path):
    K = np.array([[612.5, 0, 318.2], [0, 611.9, 241.7], [0, 0, 1]])
    R = cv2.Rodrigues(np.array([2.5, 0.1, -0.2]))[0]
    cam = CameraModel(K, np.array([-0.21, 0.05, 0.001, -0.0005, 0.0]), 640, 480, R,
                      np.array([0.1, -0.2, 0.9]), 0.31)
    write_camera_yaml(tmp_path / "camera.yaml", cam)
    fs = cv2.FileStorage(str(tmp_path / "camera.yaml"), cv2.FILE_STORAGE_READ)
    np.testing.assert_allclose(fs.getNode("camera_matrix").mat(), K)
    np.testing.assert_allclose(fs.getNode("T_WC").mat().ravel(), [0.1, -0.2, 0.9])
    assert fs.getNode("image_width").real() == 640
    fs.release()
    back = read_camera_yaml(tmp_path / "camera.yaml")
    np.testing.assert_allclose(back.R_WC, R)
    assert back.reprojection_error_px == pytest.approx(0.31)
    assert [p.name for p in tmp_path.iterdir()] == ["camera.yaml"]  # no temp file left


def test_ffmpeg_noise_does_not_reach_the_terminal():
    """A process-level check: OpenCV/FFmpeg print to fd 2 directly, CliRunner cannot see it."""
    case = DATA / "bad" / "video-not-a-video"
    r = subprocess.run([sys.executable, "-m", "armtrack_cli.cli", "info", str(case)],
                       capture_output=True, text=True)
    assert r.returncode == 1
    assert r.stderr.strip().splitlines() == [
        f"error: {case / 'video.mp4'}: is not a video OpenCV's FFmpeg can open; use .mp4, .avi "
        "or .mkv, or check the file is complete"]
