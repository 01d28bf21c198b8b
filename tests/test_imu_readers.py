"""IMU readers on real Xsens exports and on files written with known content."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from armtrack_cli.core import quaternion as Q
from armtrack_cli.core.errors import ImuFileError
from armtrack_cli.session.export.mcap import write_imu_mcap
from armtrack_cli.session.export.xsens import write_mt_manager
from armtrack_cli.session.imu import read_imu

from .conftest import DATA

XSENS = DATA / "xsens"
REAL = Path(__file__).resolve().parents[2] / "shared" / "realdata"
G = 9.81


# ------------------------------------------------------------------ real exports

@pytest.mark.parametrize("name", sorted(p.name for p in XSENS.glob("MT*.txt")))
def test_every_real_export_loads(name):
    s = read_imu(XSENS / name, rate_hz=100.0)
    assert s.n >= 4 and s.quat is not None and s.orientation_source == "file"
    np.testing.assert_allclose(np.linalg.norm(s.quat, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.diff(s.t), 0.01, atol=1e-9)  # 100 Hz, nothing dropped


@pytest.mark.parametrize("name", ["MT2022_ACC_GYRO_ROT_ALL_TAB_NAN_00B42D4B.txt",
                                  "MT2022_ACC_GYRO_ROT_MAT_COMMA_00B42D4B.txt",
                                  "MT_01200454_000-000_00B40DE4.txt"])
def test_exports_without_a_rate_need_rate_hz(name):
    with pytest.raises(ImuFileError, match=r"rate_hz"):
        read_imu(XSENS / name)


def test_legacy_export_with_matrix_and_empty_time_columns():
    s = read_imu(XSENS / "MT_012005D6_031-000_00B421AF.txt")
    assert (s.n, s.rate_hz, s.dropped) == (3369, 100.0, 0)
    assert s.duration_s == pytest.approx(33.68)
    assert s.mag is not None
    # first row of the file: Mat[1][1]=0.609684 Mat[2][1]=0.730843 Mat[3][1]=0.306845 (column 1)
    np.testing.assert_allclose(Q.to_matrix(s.quat[0])[:, 0], [0.609684, 0.730843, 0.306845],
                               atol=2e-6)


def test_tab_nan_and_comma_exports_agree():
    tab = read_imu(XSENS / "MT2022_ACC_GYRO_ROT_ALL_TAB_NAN_00B42D4B.txt", rate_hz=100)
    com = read_imu(XSENS / "MT2022_ACC_GYRO_ROT_MAT_COMMA_00B42D4B.txt", rate_hz=100)
    # the tab file's quaternion and the comma file's matrix describe the same orientation
    assert Q.angle_between(tab.quat, com.quat).max() < np.deg2rad(0.01)
    # the tab export has NaN for Acc_X in its first row: kept missing, never zero
    assert np.isnan(tab.acc[0, 0]) and np.isfinite(tab.acc[1:]).all()
    np.testing.assert_allclose(tab.acc[1:], com.acc[1:])
    np.testing.assert_allclose(tab.acc[0, 1:], com.acc[0, 1:])
    assert tab.quat.shape == (5, 4)


def test_resting_sensor_reads_gravity_up_in_w():
    # The MT2022 recording is of a sensor lying still: f_W = R_WB f_B = (0, 0, +9.81).
    s = read_imu(XSENS / "MT2022_ACC_GYRO_ROT_MAT_COMMA_00B42D4B.txt", rate_hz=100)
    f_w = Q.rotate(s.quat, s.acc).mean(axis=0)
    np.testing.assert_allclose(f_w, [0, 0, G], atol=0.15)
    assert np.abs(s.gyr).max() < 0.01  # and the gyro reads ~0 rad/s


@pytest.mark.skipif(not (REAL / "broad-02").is_dir(), reason="shared/realdata not beside repo")
def test_estimated_orientation_matches_optical_truth_on_broad():
    """No orientation in the file: VQF estimates it. Against OptiTrack (BROAD trial 02) the
    inclination error must be small (VQF paper reports ~1-2° on BROAD's undisturbed trials)."""
    s = read_imu(REAL / "broad-02" / "imu.csv")
    assert s.orientation_source.startswith("estimated")
    truth = pd.read_csv(REAL / "broad-02" / "optical_truth.csv")
    q_ref = truth[["qw", "qx", "qy", "qz"]].to_numpy()
    ok = np.isfinite(q_ref).all(axis=1) & (truth["movement"].to_numpy() == 1)
    # inclination: the direction of 'up' seen in the sensor frame
    up_est = Q.rotate(Q.conjugate(s.quat[ok]), [0.0, 0.0, 1.0])
    up_ref = Q.rotate(Q.conjugate(q_ref[ok]), [0.0, 0.0, 1.0])
    err = np.degrees(np.arccos(np.clip(np.sum(up_est * up_ref, axis=1), -1, 1)))
    assert np.sqrt(np.mean(err**2)) < 3.0, f"inclination RMSE {np.sqrt(np.mean(err**2)):.2f}°"


# ------------------------------------------------------------------ synthetic exports

def _motion(n=400, rate=100.0, drop=(50, 51, 52, 300), seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / rate
    keep = np.ones(n, bool)
    keep[list(drop)] = False
    q = Q.normalize(np.cumsum(rng.normal(0, 0.02, (n, 4)), 0) + [1, 0, 0, 0])
    acc = Q.rotate(Q.conjugate(q), [0, 0, G]) + rng.normal(0, 0.02, (n, 3))
    gyr = rng.normal(0, 0.05, (n, 3))
    return t[keep], acc[keep], gyr[keep], q[keep]


@pytest.mark.parametrize("delimiter", ["\t", ",", ";", " "])
@pytest.mark.parametrize("orientation", ["quat", "matrix", "euler"])
def test_mt_manager_round_trip(tmp_path, delimiter, orientation):
    t, acc, gyr, q = _motion()
    write_mt_manager(tmp_path / "imu.txt", t, acc, gyr, q, delimiter=delimiter,
                     orientation=orientation, stf_start=2**32 - 1234, counter_start=65480)
    s = read_imu(tmp_path / "imu.txt")
    assert s.dropped == 4  # packet counter gaps across the 16-bit wrap
    np.testing.assert_allclose(s.t, t, atol=1e-9)  # true times across the 2^32 wrap
    assert Q.angle_between(s.quat, q).max() < 1e-5
    np.testing.assert_allclose(s.acc, acc, atol=1e-6)


def test_counter_gaps_keep_true_times_without_sample_time_fine(tmp_path):
    t, acc, gyr, q = _motion()
    write_mt_manager(tmp_path / "imu.txt", t, acc, gyr, q, style="legacy",
                     sample_time_fine=False, counter_start=65530)
    s = read_imu(tmp_path / "imu.txt")
    np.testing.assert_allclose(s.t, t, atol=1e-12)  # nothing shifted after the gaps
    assert s.dropped == 4 and s.n == t.size


def test_ned_export_is_turned_z_up(tmp_path):
    t, acc, gyr, q = _motion(drop=())
    write_mt_manager(tmp_path / "imu.txt", t, acc, gyr, q, coordinate_system="NED")
    s = read_imu(tmp_path / "imu.txt")
    assert Q.angle_between(s.quat, q).max() < 1e-5
    np.testing.assert_allclose(Q.rotate(s.quat, s.acc).mean(0), [0, 0, G], atol=0.05)


def test_dot_export_with_units_in_the_header(tmp_path):
    t, acc, gyr, q = _motion(drop=(10,))
    stf = (2**32 - 5000 + np.round(t * 1e6)).astype(np.int64) % 2**32  # µs, wraps
    counter = np.round(t * 100).astype(int)
    rows = ["sep=,", "Movella DOT – exported data", "Device tag: Left wrist",
            "PacketCounter,SampleTimeFine,Quat_W,Quat_X,Quat_Y,Quat_Z,Acc_X (m/s²),Acc_Y (m/s²),"
            "Acc_Z (m/s²),Gyr_X (°/s),Gyr_Y (°/s),Gyr_Z (°/s)"]
    g = np.degrees(gyr)
    for i in range(t.size):
        rows.append(",".join([str(counter[i]), str(stf[i])] + [f"{v:.7f}" for v in q[i]]
                             + [f"{v:.6f}" for v in acc[i]] + [f"{v:.5f}" for v in g[i]]))
    (tmp_path / "dot.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
    s = read_imu(tmp_path / "dot.csv")
    assert s.fmt == "xsens-dot" and s.dropped == 1
    np.testing.assert_allclose(s.t, t, atol=1e-9)
    np.testing.assert_allclose(s.gyr, gyr, atol=1e-6)  # deg/s converted to rad/s


def test_dot_free_acceleration_becomes_specific_force(tmp_path):
    t, acc, gyr, q = _motion(drop=())
    free = Q.rotate(q, acc) - [0, 0, G]  # a_W = R f_B + g_W
    rows = ["sep=,", "PacketCounter,SampleTimeFine,Euler_X,Euler_Y,Euler_Z,FreeAcc_X,FreeAcc_Y,"
            "FreeAcc_Z"]
    R = Q.to_matrix(q)
    e = np.degrees(np.stack([np.arctan2(R[:, 2, 1], R[:, 2, 2]), -np.arcsin(R[:, 2, 0]),
                             np.arctan2(R[:, 1, 0], R[:, 0, 0])], 1))
    for i in range(t.size):
        rows.append(",".join([str(i), str(int(t[i] * 1e6))] + [f"{v:.8f}" for v in e[i]]
                             + [f"{v:.8f}" for v in free[i]]))
    (tmp_path / "dot.csv").write_text("\n".join(rows) + "\n")
    s = read_imu(tmp_path / "dot.csv")
    np.testing.assert_allclose(s.acc, acc, atol=1e-5)


def test_generic_csv_without_orientation_gets_one_from_vqf(tmp_path):
    # A sensor resting tilted 30° about x: VQF's inclination must match within 1°.
    n = 500
    q_true = Q.from_axis_angle(np.array([1.0, 0, 0]), np.deg2rad(30))
    f = Q.rotate(Q.conjugate(q_true), [0, 0, G])
    rows = ["t,ax,ay,az,gx,gy,gz"] + [f"{i / 100:.2f},{f[0]:.6f},{f[1]:.6f},{f[2]:.6f},0,0,0"
                                      for i in range(n)]
    (tmp_path / "imu.csv").write_text("\n".join(rows) + "\n")
    s = read_imu(tmp_path / "imu.csv")
    assert s.orientation_source.startswith("estimated")
    up = Q.rotate(Q.conjugate(s.quat[-1]), [0, 0, 1.0])
    assert np.degrees(np.arccos(up @ Q.rotate(Q.conjugate(q_true), [0, 0, 1.0]))) < 1.0


@pytest.mark.parametrize("encoding", ["cdr", "json"])
def test_mcap_imu_round_trip_with_ros_quaternion_order(tmp_path, encoding):
    t, acc, gyr, q = _motion()
    write_imu_mcap(tmp_path / "imu.mcap", t + 0.5, acc, gyr, q, encoding=encoding)
    s = read_imu(tmp_path / "imu.mcap")
    assert s.fmt == "mcap" and s.dropped == 4
    np.testing.assert_allclose(s.quat, q, atol=1e-12)
    np.testing.assert_allclose(s.t, t - t[0], atol=1e-6)
    np.testing.assert_allclose(s.gyr, gyr)


def test_mcap_without_orientation_is_estimated(tmp_path):
    t, acc, gyr, _ = _motion(drop=())
    write_imu_mcap(tmp_path / "imu.mcap", t, acc, gyr, None)
    s = read_imu(tmp_path / "imu.mcap")
    assert s.orientation_source.startswith("estimated")


def test_truncated_last_line_is_dropped_with_a_note(tmp_path):
    t, acc, gyr, q = _motion(drop=())
    write_mt_manager(tmp_path / "imu.txt", t, acc, gyr, q)
    text = (tmp_path / "imu.txt").read_text()
    (tmp_path / "imu.txt").write_text(text[: len(text) - 30])
    s = read_imu(tmp_path / "imu.txt")
    assert s.n == t.size - 1 and any("truncated" in n for n in s.notes)


def test_gyro_in_degrees_is_refused(tmp_path):
    rows = ["t,ax,ay,az,gx,gy,gz"] + [f"{i / 100},0,0,9.81,{90 * np.sin(i / 10):.3f},0,0"
                                      for i in range(100)]
    (tmp_path / "imu.csv").write_text("\n".join(rows))
    with pytest.raises(ImuFileError, match="degrees per second"):
        read_imu(tmp_path / "imu.csv")


@pytest.mark.parametrize("row,col,value", [(0, 0, 400.0), (1234, 2, -200.0), (2999, 1, np.inf)])
def test_the_checks_name_the_same_sample_a_block_at_a_time(monkeypatch, row, col, value):
    """session/imu.py's checks take their temporaries BLOCK_ROWS samples at a time: with
    blocks of 7 they find the same first damaged sample, gyro scale and median |acc| as with
    the whole recording in one block."""
    from armtrack_cli.core.streams import ImuSamples
    from armtrack_cli.session import imu, imu_checks

    rng = np.random.default_rng(3)
    n = 3000
    acc = rng.normal([0, 0, 9.81], 0.5, (n, 3))
    gyr = rng.normal(0, 0.5, (n, 3))
    acc[rng.random(n) < 0.01] = np.nan
    bad = acc.copy()
    bad[row, col] = value
    degrees = gyr * 180 / np.pi
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    q[77] *= 1.2

    def errors():
        out = []
        for a, g in ((bad, gyr), (acc, degrees), (acc / 9.81, gyr)):
            s = ImuSamples("x.txt", "csv", np.arange(n) / 100.0, a, g, None, None, 100.0)
            with pytest.raises(ImuFileError) as e:
                imu.check_units(s)
                imu.check_usable(s)
            out.append(str(e.value))
        with pytest.raises(ImuFileError) as e:
            imu_checks.unit_quaternions(Path("x.txt"), q.copy(), str, "q", "")
        return out + [str(e.value)]

    whole = errors()
    monkeypatch.setattr(imu, "BLOCK_ROWS", 7)
    monkeypatch.setattr(imu_checks, "BLOCK_ROWS", 7)
    assert errors() == whole
    assert f"sample {row} " in whole[0] and "reaches" in whole[1] and "median" in whole[2]
    assert "77: q has norm 1.200" in whole[3]


@pytest.mark.parametrize("encoding", ["cdr", "json"])
@pytest.mark.parametrize("shuffled", [False, True])
def test_mcap_read_in_blocks_is_the_recording(tmp_path, monkeypatch, encoding, shuffled):
    """imu_mcap makes its arrays BLOCK messages at a time: with blocks of 7 (and messages
    written out of time order, sorted by the reader) the recording written, to the bit."""
    from armtrack_cli.session import imu_mcap

    t, acc, gyr, q = _motion()
    order = np.random.default_rng(5).permutation(t.size) if shuffled else np.arange(t.size)
    write_imu_mcap(tmp_path / "imu.mcap", t[order] + 0.5, acc[order], gyr[order], q[order],
                   encoding=encoding)
    whole = read_imu(tmp_path / "imu.mcap")
    monkeypatch.setattr(imu_mcap, "BLOCK", 7)
    s = read_imu(tmp_path / "imu.mcap")
    for name in ("t", "acc", "gyr", "quat"):
        np.testing.assert_array_equal(getattr(s, name), getattr(whole, name))
    np.testing.assert_array_equal(s.acc, acc)
    np.testing.assert_array_equal(s.gyr, gyr)
    np.testing.assert_allclose(s.quat, q, atol=1e-12)
