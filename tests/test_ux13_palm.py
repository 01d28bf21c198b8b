"""ux13: a palm session whose wrist angles were never estimated wrote "nan" as the angular
speeds' values in kinematics-ukf-palm.csv (the contract: a number or "not computable: why"),
and `armtrack report` then refused the file ("value = 'nan' is not a number")."""

from __future__ import annotations

import numpy as np
import pandas as pd

from armtrack_cli.pipeline.palm import palm_kinematics
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
