"""ux13: a palm session whose wrist angles were never estimated wrote "nan" as the angular
speeds' values in kinematics-ukf-palm.csv (the contract: a number or "not computable: why"),
and `armtrack report` then refused the file ("value = 'nan' is not a number")."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from armtrack_cli.pipeline.palm import measured_only, palm_kinematics
from armtrack_cli.session.config import load_session
from armtrack_cli.session.tables import read_kinematics

from .conftest import REPO


def test_angular_speeds_without_angles_are_not_computable_and_the_file_reads(tmp_path):
    session = load_session(REPO / "sample_sessions" / "wrist-rom-01")
    t = np.arange(120) / 30.0
    nan = np.full_like(t, np.nan)
    traj = pd.DataFrame({"t": t, "wrist_x": 0.4 + 0.05 * np.sin(t), "wrist_y": 0.16 + 0 * t,
                         "wrist_z": 0.035 + 0 * t, "flexion_deg": nan, "deviation_deg": nan,
                         "pronation_deg": nan})
    traj.loc[60, "flexion_deg"] = 5.0  # one frame: no run of 3 to take a speed over
    kin = palm_kinematics(traj, session)
    speeds = kin[kin["measure"].str.endswith(("_peak_speed", "_mean_speed"))
                 & kin["measure"].str.startswith(("wrist_flexion", "wrist_deviation",
                                                  "wrist_pronation"))]
    assert len(speeds) == 6
    assert all(v.startswith("not computable: ") for v in speeds["value"]), speeds["value"].tolist()
    kin.to_csv(tmp_path / "kinematics-ukf-palm.csv", index=False)
    back = read_kinematics(tmp_path / "kinematics-ukf-palm.csv")  # raised before
    assert "nan" not in set(back["value"].str.lower())


def flexing(predicted: slice) -> pd.DataFrame:
    """A wrist flexing ±45° (sine, 4 s period) with its frames in ``predicted`` replaced by a
    constant-velocity prediction running past the true peak, as ukf-palm's rows flagged
    predicted_only were while every marker was hidden."""
    t = np.arange(360) / 30.0
    flex = 45 * np.sin(2 * np.pi * t / 4)
    i = np.arange(360)[predicted]
    rate = (flex[i[0]] - flex[i[0] - 1]) * 30
    flex = flex.copy()
    flex[i] = flex[i[0] - 1] + rate * (t[i] - t[i[0] - 1])  # overshoots 45°
    d = pd.DataFrame({"t": t, "wrist_x": 0.4 + 0 * t, "wrist_y": 0.16 + 0 * t,
                      "wrist_z": 0.035 + 0 * t, "flexion_deg": flex, "deviation_deg": 0 * t,
                      "pronation_deg": 0 * t, "markers_used": 6, "predicted_only": 0})
    d.loc[i, "predicted_only"] = 1
    d.loc[i, "markers_used"] = 0
    return d


def test_the_range_leaves_out_the_frames_the_filter_only_predicted():
    """flexhide (simulate --task wrist-flexion --seed 4 --duration 12, all six markers hidden
    2.2-3.1 s): flexion range 132.5° against the reference's 90.2°, its max 87.5° a
    prediction; now 88.7° against 90.0°."""
    session = load_session(REPO / "sample_sessions" / "wrist-rom-01")
    d = flexing(slice(15, 45))  # 0.5-1.5 s: through the peak at 1 s
    assert d["flexion_deg"].max() > 60  # the prediction's overshoot
    kin = palm_kinematics(d, session).set_index("measure")
    seen = d.loc[d["predicted_only"] == 0, "flexion_deg"]
    assert float(kin.loc["wrist_flexion_max", "value"]) == pytest.approx(seen.max(), abs=1e-5)
    assert float(kin.loc["wrist_flexion_rom", "value"]) == pytest.approx(
        seen.max() - seen.min(), abs=1e-5)
    assert float(kin.loc["wrist_flexion_rom", "value"]) <= 90.0 + 1e-6
    whole = flexing(slice(15, 45)).assign(predicted_only=0)  # unflagged: as before
    assert measured_only(whole) is whole


def test_compare_takes_the_range_over_the_same_measured_frames():
    from armtrack_cli.compare.palm import _angle_rows

    d = flexing(slice(15, 45))
    est = d[["flexion_deg", "deviation_deg", "pronation_deg"]].to_numpy()
    t = d["t"].to_numpy()
    truth = np.c_[45 * np.sin(2 * np.pi * t / 4), 0 * t, 0 * t]
    seen = d["predicted_only"].to_numpy() == 0
    flex = _angle_rows("ukf-palm", t, est, truth, seen)[0]
    every = _angle_rows("ukf-palm", t, est, truth, np.ones(t.size, bool))[0]
    assert every["rom_deg"] > 100 and flex["rom_deg"] < 91  # the overshoot, and without it
    assert abs(flex["rom_error_deg"]) < 1.5
    assert flex["n"] == every["n"] == 360  # the errors still score every frame
