"""session.toml: the contract's full example loads; errors name the key and the fix."""

from __future__ import annotations

import numpy as np
import pytest

from armtrack_cli.core.errors import ConfigError
from armtrack_cli.session.config import load_session, require

from .conftest import write_session

FULL = """
[session]
id = "circle-01"
subject = "S01"
recorded = 2026-11-20T10:15:00
task = "circle"
side = "right"

[arm]
upper_arm_m = 0.31
forearm_m = 0.27
shoulder_m = [0.10, 0.45, 0.32]

[camera]
video = "video.mp4"
intrinsics = "intrinsics.yaml"
board = { type = "charuco", squares = [7, 5], square_m = 0.04, marker_m = 0.03, dictionary = "DICT_4X4_50" }
patch = { hsv_low = [170, 140, 90], hsv_high = [12, 255, 255] }

[imu]
file = "imu.txt"
forearm_axis = "-x"
rate_hz = 100.0
topic = "/imu/data"

[palm]
markers = ["WRIST", "MCP2", "MCP3", "MCP4", "MCP5", "CMC1"]
link_m = [0.0, 0.085, 0.080, 0.075, 0.070, 0.045]
colour = { hsv_low = [100, 150, 60], hsv_high = [130, 255, 255] }

[groundtruth]
file = "qualisys.tsv"
markers = { shoulder = "R_SHO", elbow = "R_ELB", wrist = "R_WRI", MCP3 = "M3" }
to_world = [[0,-1,0,0.5],[1,0,0,0],[0,0,1,-0.7],[0,0,0,1]]

[sync]
imu_offset_s = "auto"
groundtruth_offset_s = -1.25
"""


def test_every_key_of_the_contract_loads(tmp_path):
    s = load_session(write_session(tmp_path / "circle-01", FULL))
    assert s.meta.id == "circle-01" and s.meta.side == "right"
    assert (s.arm.upper_arm_m, s.arm.forearm_m) == (0.31, 0.27)
    np.testing.assert_array_equal(s.arm.shoulder_m, [0.10, 0.45, 0.32])
    assert s.camera.board.squares == (7, 5) and s.camera.board.dictionary == "DICT_4X4_50"
    assert s.camera.patch.wraps and s.camera.video == tmp_path / "circle-01" / "video.mp4"
    np.testing.assert_array_equal(s.imu.forearm_unit, [-1, 0, 0])
    assert s.imu.rate_hz == 100.0 and s.imu.topic == "/imu/data"
    assert s.palm.markers[0] == "WRIST" and s.palm.link_m[2] == 0.080
    assert s.groundtruth.markers["MCP3"] == "M3"
    assert s.groundtruth.to_world[0, 3] == 0.5
    assert s.sync.imu_offset_s == "auto" and s.sync.groundtruth_offset_s == -1.25
    assert s.kind == "palm"


def test_defaults(tmp_path):
    s = load_session(write_session(tmp_path / "x", '[imu]\nfile = "imu.txt"\n'))
    assert s.meta.id == "x" and s.meta.side == "right" and s.imu.forearm_axis == "+y"
    assert s.sync.imu_offset_s == 0.0 and s.kind == "object"


@pytest.mark.parametrize("edit, message", [
    (("upper_arm_m", "upperarm_m"), "[arm] upperarm_m is not a key armtrack knows; did you mean "
                                    "'upper_arm_m'?"),
    (('side = "right"', 'side = "Right"'), "[session] side = 'Right' is not one of"),
    (("squares = [7, 5]", "squares = [7.5, 5]"), "[camera.board] squares = [7.5, 5] is not a list "
                                                  "of 2 integers"),
    (("forearm_m = 0.27", "forearm_m = 0.0"), "[arm] forearm_m = 0 is impossible"),
    (("[sync]", "[synch]"), "[synch] is not a section armtrack knows; did you mean [sync]?"),
    (('rate_hz = 100.0', 'rate_hz = true'), "[imu] rate_hz = True is a boolean"),
])
def test_errors_name_the_key(tmp_path, edit, message):
    folder = write_session(tmp_path / "s", FULL.replace(*edit))
    with pytest.raises(ConfigError) as err:
        load_session(folder)
    assert message in str(err.value)
    assert str(err.value).startswith(str(folder / "session.toml"))


def test_a_command_names_the_section_it_lacks(tmp_path):
    s = load_session(write_session(tmp_path / "s", '[imu]\nfile = "imu.txt"\n'))
    with pytest.raises(ConfigError, match=r"has no \[arm\] section"):
        require(s, "arm")


def test_the_arm_may_be_auto(tmp_path):
    """Any of the three [arm] values may be "auto" (fuse estimates it): NaN until then."""
    s = load_session(write_session(tmp_path / "a", FULL.replace(
        "shoulder_m = [0.10, 0.45, 0.32]", 'shoulder_m = "auto"').replace(
        "forearm_m = 0.27", 'forearm_m = "auto"')))
    assert s.arm.auto == ("shoulder_m", "forearm_m") and s.arm.upper_arm_m == 0.31
    assert np.isnan(s.arm.shoulder_m).all() and np.isnan(s.arm.forearm_m)
    with pytest.raises(ConfigError, match=r"\[arm\] upper_arm_m = .automatic. is a string"):
        load_session(write_session(tmp_path / "b", FULL.replace(
            "upper_arm_m = 0.31", 'upper_arm_m = "automatic"')))
