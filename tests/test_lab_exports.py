"""Exports from other labs that failed before issue 16, written here from their descriptions:
a space-delimited MT Manager 2022 export with empty fields, orientation-only and
acceleration-only Xsens exports (described by info, refused by fusion), and a VectorNav ROS 2
MCAP whose sensor_msgs/Imu is a field of a custom message."""

from __future__ import annotations

import json

import numpy as np
import pytest

from armtrack_cli.core.errors import ImuFileError
from armtrack_cli.session.export.mcap import IMU_MSGDEF, _imu_msg
from armtrack_cli.session.imu import read_imu
from armtrack_cli.session.info import describe_path

from .conftest import run_cli

RNG = np.random.default_rng(16)
N = 50
ACC = np.column_stack([RNG.normal(0, 0.5, N), RNG.normal(0, 0.5, N), 9.81 + RNG.normal(0, .1, N)])
GYR = RNG.normal(0, 0.3, (N, 3))
_q = RNG.normal(0, 0.1, (N, 4)) + [1, 0, 0, 0]
QUAT = _q / np.linalg.norm(_q, axis=1, keepdims=True)

SPACE_HEADER = ("PacketCounter SampleTimeFine UTC_Nano UTC_Year UTC_Month UTC_Day UTC_Hour "
                "UTC_Minute UTC_Second UTC_Valid StatusWord Acc_X Acc_Y Acc_Z Gyr_X Gyr_Y Gyr_Z "
                "Quat_q0 Quat_q1 Quat_q2 Quat_q3")


def _f(v) -> str:
    return f"{v:.9f}"


def test_space_delimited_2022_export_with_empty_fields(tmp_path):
    # MT Manager 2022, space delimiter: SampleTimeFine and the UTC columns left blank, so a row
    # holds consecutive single spaces; collapsing them gave "16 fields but the header has 21"
    rows = [f"{i} " + " " * 9 + "0 " + " ".join(_f(v) for v in (*ACC[i], *GYR[i], *QUAT[i]))
            for i in range(N)]
    p = tmp_path / "MT_space.txt"
    p.write_text("// General information:\n//  Update Rate: 100.0Hz\n//  Filter Profile: General\n"
                 + SPACE_HEADER + "\n" + "\n".join(rows) + "\n")
    assert len(SPACE_HEADER.split(" ")) == 21 and len(rows[0].split(" ")) == 21
    s = read_imu(p)
    assert (s.n, s.rate_hz, s.dropped) == (N, 100.0, 0)
    np.testing.assert_allclose(s.t, np.arange(N) / 100.0, atol=1e-12)
    np.testing.assert_allclose(s.acc, ACC, atol=1e-9)
    np.testing.assert_allclose(s.gyr, GYR, atol=1e-9)
    np.testing.assert_allclose(s.quat, QUAT, atol=1e-8)


def test_aligned_space_columns_still_read(tmp_path):
    p = tmp_path / "MT_aligned.txt"
    p.write_text("// Update Rate: 100.0Hz\nPacketCounter   Acc_X   Acc_Y   Acc_Z   Gyr_X   Gyr_Y   "
                 "Gyr_Z\n" + "\n".join(f"{i}    " + "   ".join(_f(v) for v in (*ACC[i], *GYR[i]))
                                       for i in range(N)) + "\n")
    s = read_imu(p)
    np.testing.assert_allclose(s.acc, ACC, atol=1e-9)


def _dot_quaternion_only(tmp_path):
    p = tmp_path / "dot_quat.csv"
    p.write_text("sep=,\nPacketCounter,SampleTimeFine,Quat_W,Quat_X,Quat_Y,Quat_Z\n" + "\n".join(
        f"{i},{1000 + 16667 * i}," + ",".join(_f(v) for v in QUAT[i]) for i in range(N)) + "\n")
    return p


def _legacy_matrix_only(tmp_path):
    from armtrack_cli.core import quaternion as Q

    R = Q.to_matrix(QUAT)
    head = "\t".join(["PacketCounter"] + [f"Mat[{i}][{j}]" for i in (1, 2, 3) for j in (1, 2, 3)])
    p = tmp_path / "MT_matrix.txt"
    p.write_text("// Start Time: Unknown\n// Update Rate: 100.0Hz\n" + head + "\n" + "\n".join(
        "\t".join([str(i)] + [_f(R[i, a, b]) for a in range(3) for b in range(3)])
        for i in range(N)) + "\n")
    return p


def _acc_only(tmp_path):
    p = tmp_path / "MT_acc.txt"
    p.write_text("// Update Rate: 60.0Hz\nPacketCounter\tSampleTimeFine\tAcc_X\tAcc_Y\tAcc_Z\n"
                 + "\n".join(f"{i}\t{500 + 166 * i}\t" + "\t".join(_f(v) for v in ACC[i])
                             for i in range(N)) + "\n")
    return p


@pytest.mark.parametrize("make, has_q, lack", [
    (_dot_quaternion_only, True, ["accelerometer"]),
    (_legacy_matrix_only, True, ["accelerometer"]),
    (_acc_only, False, ["orientation (or a gyroscope to estimate it)"]),
])
def test_partial_exports_are_described_and_refused_by_fusion(tmp_path, make, has_q, lack):
    p = make(tmp_path)
    d = describe_path(p)["imu"]
    assert d["samples"] == N and d["missing_for_fusion"] == lack
    assert d["accelerometer"] is (lack != ["accelerometer"])
    assert (d["orientation"] == "file") is has_q
    if has_q:  # the orientation itself is read exactly
        q = read_imu(p, complete=False).quat
        dots = np.abs(np.sum(q * QUAT, axis=1))
        np.testing.assert_allclose(dots, 1.0, atol=1e-8)
    with pytest.raises(ImuFileError, match="has no Acc_X/Acc_Y/Acc_Z" if lack == ["accelerometer"]
                       else "no orientation and no gyroscope"):
        read_imu(p)  # what fuse calls


def test_info_on_a_session_with_an_orientation_only_export(tmp_path):
    folder = tmp_path / "s"
    folder.mkdir()
    _dot_quaternion_only(folder).rename(folder / "imu.csv")
    (folder / "session.toml").write_text('[imu]\nfile = "imu.csv"\n')
    r = run_cli("info", folder, "--json")
    assert r.exit_code == 0, r.stderr
    info = json.loads(r.stdout)
    assert info["methods"]["ekf"].startswith("needs an IMU with accelerometer")


# ------------------------------------------------------------------ VectorNav MCAP

SEP = "=" * 80
MAG_DEF = "\n".join(["std_msgs/Header header", "geometry_msgs/Vector3 magnetic_field",
                     "float64[9] magnetic_field_covariance"])
VN_DEF = "\n".join([
    "std_msgs/Header header", "sensor_msgs/Imu imu", "sensor_msgs/MagneticField mag_field",
    "VectornavRaw raw",
    SEP, "MSG: custom_interfaces/VectornavRaw", "float64 temperature", "float64 pressure",
    SEP, "MSG: sensor_msgs/Imu", IMU_MSGDEF.split(SEP)[0].strip(),
    SEP, "MSG: sensor_msgs/MagneticField", MAG_DEF]
    + [SEP + "\n" + block.strip() for block in IMU_MSGDEF.split(SEP)[1:]])


def _vectornav_mcap(path, *, second_imu=False):
    from mcap_ros2.writer import Writer

    definition = VN_DEF.replace("VectornavRaw raw", "VectornavRaw raw\nsensor_msgs/Imu imu_raw") \
        if second_imu else VN_DEF
    with open(path, "wb") as f:
        w = Writer(f)
        schema = w.register_msgdef("custom_interfaces/msg/Vectornav", definition)
        for i in range(N):
            t = 1_700_000_000.0 + i / 200.0
            imu = _imu_msg(t, ACC[i], GYR[i], QUAT[i])
            msg = {"header": imu["header"], "imu": imu,
                   "mag_field": {"header": imu["header"],
                                 "magnetic_field": {"x": 2e-5, "y": 0.0, "z": -4e-5 + i * 1e-8},
                                 "magnetic_field_covariance": [0.0] * 9},
                   "raw": {"temperature": 25.0, "pressure": 101.3}}
            if second_imu:
                msg["imu_raw"] = imu
            ns = int(round(t * 1e9))
            w.write_message("/vectornav/raw", schema, msg, log_time=ns, publish_time=ns)
        w.finish()
    return path


def test_vectornav_mcap_imu_inside_a_custom_message(tmp_path):
    s = read_imu(_vectornav_mcap(tmp_path / "vn.mcap"))
    assert s.n == N and s.rate_hz == pytest.approx(200.0, rel=1e-4)
    np.testing.assert_allclose(s.acc, ACC, atol=1e-12)
    np.testing.assert_allclose(s.gyr, GYR, atol=1e-12)
    np.testing.assert_allclose(s.quat, QUAT, atol=1e-12)
    np.testing.assert_allclose(s.mag[:, 0], 20.0)  # 2e-5 T = 20 µT
    assert "field imu" in s.notes[0]


def test_two_imu_fields_need_imu_field(tmp_path):
    p = _vectornav_mcap(tmp_path / "vn2.mcap", second_imu=True)
    with pytest.raises(ImuFileError, match=r"several sensor_msgs/Imu fields: imu, imu_raw.*"
                                           r"\[imu\] field"):
        read_imu(p)
    assert read_imu(p, field="imu_raw").n == N
    with pytest.raises(ImuFileError, match="has no sensor_msgs/Imu field 'nope'"):
        read_imu(p, topic="/vectornav/raw", field="nope")
