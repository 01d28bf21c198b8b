"""compare measures the ground truth as labs do: its markers low-passed at their own rate
(6 Hz, zero lag) before being sampled at the trajectory's frames (compare/score.lowpassed), so
Qualisys noise (0.3 mm, the simulator's and a typical system's) does not fold into the path
measures. Checked on an analytic out-and-back minimum-jerk reach with a rest between."""

from __future__ import annotations

import numpy as np
import pytest

from armtrack_cli.compare.score import Truth, lowpassed, truth_markers
from armtrack_cli.measures import Inputs, measure_rows

D, T = 0.15, 2.5  # m, s: peak speed 1.875·D/T = 0.1125 m/s, slow like the reach sessions


def _min_jerk(t, t0):
    tau = np.clip((t - t0) / T, 0, 1)
    return 10 * tau**3 - 15 * tau**4 + 6 * tau**5


def _session_measures(truth: Truth) -> dict:
    t = np.arange(0, 12, 1 / 30)  # the trajectory's frames, 30 fps
    w = truth_markers(t, truth)["wrist"]
    return {r["measure"]: r["value"] for r in measure_rows(Inputs(t=t, wrist=w))
            if r["segment"] == "session"}


def test_marker_noise_is_filtered_at_the_capture_rate_before_measuring():
    tq = np.arange(0, 12, 0.01)  # Qualisys, 100 Hz
    x = np.zeros((tq.size, 3))
    x[:, 0] = D * (_min_jerk(tq, 1.0) - _min_jerk(tq, 5.0))  # out 1-3.5 s, rest, back 5-7.5 s
    noisy = x + np.random.default_rng(0).normal(0, 0.0003, x.shape)
    noisy[700:703] = np.nan  # a gap stays a gap
    raw = Truth(tq, {"wrist": noisy}, 100.0)
    filt = lowpassed(raw, 6.0)
    assert np.isnan(filt.xyz["wrist"][700:703]).all() and np.isfinite(filt.xyz["wrist"][:700]).all()
    got, unfiltered = _session_measures(filt), _session_measures(raw)
    path_err = got["wrist_path_length"] / (2 * D) - 1
    peak_err = got["wrist_peak_speed"] / (1.875 * D / T) - 1
    assert abs(path_err) < 0.025 and abs(peak_err) < 0.03, (path_err, peak_err)
    # sampled at the frames without it, the same noise adds twice as much path
    assert unfiltered["wrist_path_length"] / (2 * D) - 1 > 2 * path_err


def test_exact_markers_are_unchanged_by_the_filter():
    tq = np.arange(0, 12, 0.01)
    x = np.zeros((tq.size, 3))
    x[:, 0] = D * _min_jerk(tq, 1.0)
    got = lowpassed(Truth(tq, {"wrist": x}, 100.0), 6.0).xyz["wrist"]
    np.testing.assert_allclose(got, x, atol=2e-4)  # the reach's band lies far below 6 Hz
    m = _session_measures(Truth(tq, {"wrist": got}, 100.0))
    assert m["wrist_peak_speed"] == pytest.approx(1.875 * D / T, rel=0.01)
    assert m["wrist_path_length"] == pytest.approx(D, rel=0.01)
