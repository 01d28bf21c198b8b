"""ux12: error messages that sent the user to the wrong place."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from .conftest import REPO, run_cli


@pytest.mark.slow
def test_arm_error_names_an_estimated_orientation_as_a_suspect(tmp_path):
    """circle-01's IMU as a generic CSV without orientation columns: the orientation is
    estimated from gyro + accelerometer, with the sensor's start as W's heading (170° off
    here), and fuse's error blamed [arm] shoulder_m and the lengths alone."""
    s = tmp_path / "s"
    shutil.copytree(REPO / "sample_sessions" / "circle-01", s)
    x = np.genfromtxt(s / "imu.txt", delimiter="\t", skip_header=8, names=True)
    t = (x["SampleTimeFine"] - x["SampleTimeFine"][0]) / 1e4
    cols = [t] + [x[c] for c in ("Acc_X", "Acc_Y", "Acc_Z", "Gyr_X", "Gyr_Y", "Gyr_Z")]
    np.savetxt(s / "imu.csv", np.column_stack(cols), delimiter=",", fmt="%.6f",
               header="t,ax,ay,az,gx,gy,gz", comments="")
    (s / "imu.txt").unlink()
    toml = s / "session.toml"
    toml.write_text(toml.read_text().replace('file = "imu.txt"', 'file = "imu.csv"'))
    assert run_cli("run", s, "--through", "detect").exit_code == 0
    r = run_cli("fuse", s)
    assert r.exit_code == 1
    assert "[arm] cannot explain the first detection" in r.stderr
    assert "or the IMU's orientation: the file has none" in r.stderr
