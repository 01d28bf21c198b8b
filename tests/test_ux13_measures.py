"""ux13: a movement cut by the start or end of the wrist's data has no onset or offset.

A circle session whose patch was hidden until 16.0 s (the arm smoother's trajectory empty
before it) gave "time to peak speed 0.000 s", "movement units 0" beside "movements found 1",
and a peak speed of 0.181 m/s at its first sample (the task's true peak: 0.21): a cut
movement measured as a whole one. Now those measures say why they are not computable; a
recording that starts and ends at rest (every bundled and benchmark session) is unchanged."""

from __future__ import annotations

import numpy as np

from armtrack_cli.measures.table import Inputs, measure_rows

FS = 30.0
D = 0.30  # m


def reach(t0: float, t1: float, rest: float = 1.0) -> Inputs:
    """A 1.5 s minimum-jerk reach of D along x between rests of ``rest`` s, seen from t0 to
    t1 (s, on the movement's clock: the reach runs from rest to rest + 1.5)."""
    t = np.arange(round(t0 * FS), round(t1 * FS)) / FS
    tau = np.clip((t - rest) / 1.5, 0, 1)
    x = D * (10 * tau**3 - 15 * tau**4 + 6 * tau**5)
    w = np.c_[x, np.full_like(x, 0.2), np.zeros_like(x)]
    return Inputs(t=t, wrist=w, task="reach")


def values(inp: Inputs) -> dict:
    return {r["measure"]: r["value"] for r in measure_rows(inp) if r["segment"] == "session"}


def test_a_whole_reach_is_measured_as_before():
    v = values(reach(0.0, 3.5))
    assert abs(v["wrist_path_length"] - D) < 0.01 * D  # the closed form: the distance
    assert abs(v["wrist_peak_speed"] - 1.875 * D / 1.5) < 0.02 * 1.875 * D / 1.5
    assert v["movement_units"] == 1.0


def test_a_reach_whose_start_is_before_the_data_is_not_measured_as_a_whole():
    v = values(reach(1.6, 3.5))  # data begin 0.1 s after the reach began (hand moving)
    for m in ("wrist_mean_speed", "time_to_peak_speed", "movement_time", "wrist_path_length",
              "movement_units", "sparc", "ldlj"):
        assert isinstance(v[m], str) and "the movement's start is not in the data" in v[m], m
    assert "begin at 1.60 s" in v["movement_time"]
    assert isinstance(v["wrist_peak_speed"], float)  # its peak, later, is in the data


def test_a_reach_whose_end_is_after_the_data_and_peak_at_the_cut():
    v = values(reach(0.0, 1.75))  # data end at the peak speed (mid-reach)
    assert "the movement's end is not in the data" in v["movement_time"]
    assert "the movement's end is not in the data" in v["wrist_peak_speed"]  # a lower bound


def test_noise_at_rest_at_the_edges_cuts_nothing():
    inp = reach(0.0, 3.5)
    rng = np.random.default_rng(1)
    noisy = Inputs(t=inp.t, wrist=inp.wrist + rng.normal(0, 2e-4, inp.wrist.shape), task="reach")
    v = values(noisy)
    assert all(not isinstance(v[m], str) for m in ("movement_time", "wrist_path_length")), v
