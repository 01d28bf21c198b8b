"""The ground truth's offset recovered from the data: a known shift of a simulated truth,
against an estimate with a constant bias and smooth (serially correlated) error."""

from __future__ import annotations

import numpy as np
import pytest

from armtrack_cli.compare.sync import estimate_offset


def _motion(t):
    return np.c_[0.15 + 0.1 * np.cos(1.3 * t), 0.25 + 0.08 * np.sin(1.3 * t + 0.3 * np.sin(0.7 * t)),
                 0.07 + 0.02 * np.sin(2.1 * t)]


def _session(true_offset, wander_m, seed=11):
    rng = np.random.default_rng(seed)
    t = np.arange(600) / 30.0  # video frames, session clock
    smooth = np.cumsum(rng.normal(0, wander_m, (600, 3)), axis=0)
    smooth -= np.linspace(0, 1, 600)[:, None] * smooth[-1]
    est = _motion(t) + np.array([0.004, -0.005, 0.003]) + smooth + rng.normal(0, 0.002, (600, 3))
    est[200:230] = np.nan  # a lost stretch
    truth_t = np.arange(-150, 2400) / 100.0  # Qualisys at 100 Hz on its own clock
    truth = _motion(truth_t + true_offset)  # session time = truth time + offset
    truth[500:530] = np.nan  # a gap
    return estimate_offset(t, est, truth_t, truth, 100.0)


@pytest.mark.parametrize("true_offset", [-0.5, -0.2, 0.05, 0.2, 0.5])
def test_recovers_a_known_offset_within_5_ms(true_offset):
    """A tracker whose error wanders by a few millimetres."""
    off = _session(true_offset, wander_m=0.0002)
    assert abs(off.estimate_s - true_offset) < 0.005, off


@pytest.mark.parametrize("seed", range(6))
def test_its_sd_covers_the_error_when_the_tracker_wanders(seed):
    """A wander of 1-2 cm over the session: the offset is less sure, and the SD says so."""
    off = _session(0.2, wander_m=0.0008, seed=seed)
    assert abs(off.estimate_s - 0.2) < 3 * off.sd_s and off.sd_s < 0.02, off


def test_no_overlap_gives_none():
    t = np.arange(100) / 30.0
    assert estimate_offset(t, _motion(t), np.arange(100) / 100.0 + 50.0, _motion(t)[:100], 100.0,
                           search_s=1.0) is None


def test_compare_with_auto_and_with_a_wrong_declared_offset(tmp_path):
    """circle-01's Qualisys runs 1.5 s ahead of the video (declared -1.5): "auto" finds it
    within 3 SD, and a declared -1.2 s is warned about in one line."""
    import json
    import shutil
    import warnings

    from armtrack_cli import pipeline

    from .conftest import REPO

    s = tmp_path / "s"
    shutil.copytree(REPO / "sample_sessions" / "circle-01", s)
    toml = s / "session.toml"
    toml.write_text(toml.read_text().replace("groundtruth_offset_s = -1.5",
                                             'groundtruth_offset_s = "auto"'))
    r = pipeline.run(s, through="compare")
    off = r["results"]["compare"]["groundtruth_offset_s"]
    assert off["from"] == "auto" and abs(off["value"] + 1.5) < 3 * off["sd"] and off["sd"] < 0.03
    meta = json.loads((s / "armtrack" / "errors.meta.json").read_text())
    assert meta["settings"]["groundtruth_offset_s"]["value"] == off["value"]
    toml.write_text(toml.read_text().replace('groundtruth_offset_s = "auto"',
                                             "groundtruth_offset_s = -1.2"))
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        pipeline.compare(s)
    assert [str(w.message) for w in seen if "not the declared -1.200 s" in str(w.message)]


def test_an_along_ray_lag_does_not_pull_the_offset_across_the_rays():
    """A one-camera tracker whose depth lags the motion by 80 ms (its error along the camera
    ray only) pulls the whole-residual offset; across the rays (the camera's centre given)
    the image pins it: recovered within 5 ms."""
    eye = np.array([0.2, -0.6, 0.8])
    t = np.arange(600) / 30.0
    p, lag = _motion(t), _motion(t - 0.08)
    u = (p - eye) / np.linalg.norm(p - eye, axis=1, keepdims=True)
    est = p + u * np.sum((lag - p) * u, axis=1, keepdims=True)
    truth_t = np.arange(-150, 2400) / 100.0
    truth = _motion(truth_t + 0.2)
    whole = estimate_offset(t, est, truth_t, truth, 100.0)
    across = estimate_offset(t, est, truth_t, truth, 100.0, eye=eye)
    assert abs(across.estimate_s - 0.2) < 0.005, across
    assert abs(whole.estimate_s - 0.2) > abs(across.estimate_s - 0.2)
