"""validation/detect_correlation.py: the integrated autocorrelation time of an AR(1) series is
(1 + φ) / (1 − φ) (closed form), and sessions are split into still and moving frames as fuse
splits them (from the detections)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "validation"))
import detect_correlation as dc  # noqa: E402


def _ar1(rng, phi, n, runs):
    out = []
    for _ in range(runs):
        x = np.empty((n, 2))
        x[0] = rng.standard_normal(2) / np.sqrt(1 - phi**2)
        for k in range(1, n):
            x[k] = phi * x[k - 1] + rng.standard_normal(2)
        out.append(x)
    return out


def test_ar1_series_time_is_its_closed_form():
    rng = np.random.default_rng(3)
    for phi in (0.0, 0.5, 0.8):
        segs = _ar1(rng, phi, 400, 40)
        rho = dc.autocorrelation(segs)
        assert abs(rho[0] - phi) < 0.03
        assert abs(dc.integrated_time(rho) - (1 + phi) / (1 - phi)) < 0.15 * (1 + phi) / (1 - phi)


def test_time_stops_at_the_first_negative_correlation():
    assert dc.integrated_time(np.array([0.5, 0.25, -0.1, 0.4])) == 1 + 2 * 0.75
    assert dc.integrated_time(np.array([])) == 1.0


def test_still_and_moving_frames_come_from_the_detections(tmp_path):
    """Sessions whose patch rests for 60 frames (error held: AR(1), φ = 0.8, τ = 9) then moves
    3 px a frame (error white, τ = 1): the split is the detections', and each class's τ."""
    rng = np.random.default_rng(5)
    n, folders = 120, []
    px = np.c_[np.r_[np.full(60, 300.0), 300.0 + 3.0 * np.arange(1, 61)], np.full(n, 200.0)]
    for i in range(12):
        err = 0.2 * np.r_[_ar1(rng, 0.8, 60, 1)[0] * 0.6, rng.standard_normal((60, 2))]
        folder = tmp_path / f"s{i}"
        (folder / "armtrack").mkdir(parents=True)
        np.savez(tmp_path / f"s{i}.truth.npz", frame_t=np.arange(n) / 30.0, frame_wrist_px=px)
        rows = "\n".join(f"{k},{k / 30:.6f},{u:.6f},{v:.6f},1" for k, (u, v) in enumerate(px + err))
        (folder / "armtrack" / "detections.csv").write_text("frame,t,u,v,ok\n" + rows + "\n")
        folders.append(folder)
    c = dc.by_class(folders)
    # still: frames 1-58 (59 sees frame 60 move); moving: 59-119 (frame 0, an end, a run of 1)
    assert c["still"]["frames"] == 12 * 58 and c["moving"]["frames"] == 12 * 61
    assert abs(c["still"]["rho1"] - 0.8) < 0.1 and abs(c["moving"]["rho1"]) < 0.1
    assert 6 < c["still"]["tau"] < 12 and c["moving"]["tau"] < 1.5
    assert dc.still_tau(folders) == c["still"]["tau"]
