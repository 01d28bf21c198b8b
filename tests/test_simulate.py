"""The simulator's physics, checked against independent computations (issue 3)."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from armtrack_cli import pipeline
from armtrack_cli.calibrate.board_pose import board_pose
from armtrack_cli.core import quaternion as Q
from armtrack_cli.session.camera_yaml import read_camera_yaml
from armtrack_cli.session.config import load_session
from armtrack_cli.session.imu import read_imu
from armtrack_cli.session.qualisys import read_qualisys, to_world
from armtrack_cli.session.video import iter_frames, probe_video
from armtrack_cli.simulate import imu_model, kinematics
from armtrack_cli.simulate.arm_session import ArmSimSettings
from armtrack_cli.vision.charuco import make_board

from .conftest import run_cli

G = 9.81


@pytest.fixture(scope="module")
def sessions(tmp_path_factory):
    root = tmp_path_factory.mktemp("sim")
    made = {}
    for name, settings, fmt in [
        ("default", ArmSimSettings(task="circle", duration_s=8.0, seed=1, distractor=True,
                                   occlusions=((3.0, 1.0),), gt_gaps=2), "xsens"),
        ("ideal", ArmSimSettings(task="rectangle", duration_s=8.0, seed=2, imu_preset="ideal",
                                 marker_noise_m=0.0), "csv"),
        ("mcap", ArmSimSettings(task="reach", duration_s=6.0, seed=3, drop_rate=0.02), "mcap"),
    ]:
        pipeline.simulate(root / name, settings, imu_format=fmt)
        made[name] = (root / name, dict(np.load(root / f"{name}.truth.npz")), settings)
    return made


def test_static_sensor_reads_gravity_up_and_no_rotation():
    q = np.array([[1.0, 0, 0, 0]])
    np.testing.assert_allclose(imu_model.specific_force(q, np.zeros((1, 3))), [[0, 0, G]])
    # at rest in the simulated task (first REST_S seconds) the same holds in B
    arm = kinematics.ArmGeometry(np.array([0.12, 0.58, 0.30]), 0.31, 0.27)
    task = kinematics.Task("circle", 10.0, np.array([0.26, 0.25, 0.07]), 0.1)
    st = kinematics.arm_state(arm, task, np.array([0.2, 0.8]))
    np.testing.assert_allclose(st.wrist_acc, 0, atol=1e-6)
    np.testing.assert_allclose(st.omega_B, 0, atol=1e-6)
    f = imu_model.specific_force(st.q_WB, st.wrist_acc)
    np.testing.assert_allclose(Q.rotate(st.q_WB, f), [[0, 0, G]] * 2, atol=1e-9)
    meas = imu_model.measure(st.t, st.q_WB, st.wrist_acc, st.omega_B,
                             imu_model.ImuErrors.preset("ideal"), 100.0, np.random.default_rng(0))
    np.testing.assert_allclose(meas["gyr"], 0, atol=1e-6)


def test_bone_lengths_are_exact():
    arm = kinematics.ArmGeometry(np.array([0.12, 0.58, 0.30]), 0.31, 0.27)
    for name in kinematics.TASKS:
        st = kinematics.arm_state(arm, kinematics.Task(name, 12.0, np.array([0.26, 0.25, 0.07]),
                                                       0.1), np.linspace(0, 12, 500))
        np.testing.assert_allclose(np.linalg.norm(st.elbow - st.shoulder, axis=1), 0.31, atol=1e-12)
        np.testing.assert_allclose(np.linalg.norm(st.wrist - st.elbow, axis=1), 0.27, atol=1e-12)
        forearm = Q.rotate(st.q_WB, [0, 1.0, 0])  # +y of B runs elbow -> wrist
        np.testing.assert_allclose(forearm, (st.wrist - st.elbow) / 0.27, atol=1e-9)


def _integrate_windows(folder, truth, window=1.0):
    """Strapdown over 1 s windows from the true state: a_W = R_WB f_B + g_W, trapezoid twice.
    Returns per-window position errors (m) and the window start times."""
    s = load_session(folder)
    imu = read_imu(s.imu.file)
    t = imu.t + s.sync.imu_offset_s
    a_w = Q.rotate(imu.quat, imu.acc) + imu_model.GRAVITY_W
    interp = lambda key, tt: np.stack([np.interp(tt, truth["t"], truth[key][:, k])  # noqa: E731
                                       for k in range(3)], -1)
    errs, starts, angles = [], [], []
    for t0 in np.arange(0.0, truth["frame_t"][-1] - window, 0.5):
        m = (t >= t0) & (t <= t0 + window + 1e-9)
        tt, aa = t[m], a_w[m]
        p, v = interp("wrist", tt[:1])[0], interp("wrist_vel", tt[:1])[0]
        for k in range(1, tt.size):
            dt = tt[k] - tt[k - 1]
            p = p + v * dt + (2 * aa[k - 1] + aa[k]) / 6 * dt**2  # exact for linear a(t)
            v = v + (aa[k - 1] + aa[k]) / 2 * dt
        errs.append(np.linalg.norm(p - interp("wrist", tt[-1:])[0]))
        starts.append(t0)
        angles.append(Q.angle_between(imu.quat[m], truth["imu_q_true"][m]).max())
    return np.array(errs), np.array(starts), np.array(angles)


def test_strapdown_reproduces_the_wrist_without_sensor_errors(sessions):
    """Ideal IMU: only the file's 6-decimal rounding and 100 Hz trapezoids remain (< 1 mm)."""
    errs, _, _ = _integrate_windows(*sessions["ideal"][:2])
    assert errs.max() < 1e-3, f"max {errs.max() * 1000:.3f} mm"


def test_strapdown_error_is_what_the_sensor_errors_allow(sessions):
    """Default MTw-class errors. Over T = 1 s the position error is bounded by
    ½T²(‖b‖ + g·sin θ_max) from the bias b and the largest output-orientation error θ in the
    window (gravity leaks through a tilt), plus 3σ·√(dt/3)·T^1.5 of white noise, plus 1 mm."""
    folder, truth, settings = sessions["default"]
    errs, _, angles = _integrate_windows(folder, truth)
    b = np.linalg.norm(truth["acc_bias"])
    noise = 3 * 0.02 * np.sqrt(0.01 / 3)
    bound = 0.5 * (b + G * np.sin(angles)) + noise + 1e-3
    assert (errs <= bound).all(), np.c_[errs, bound][errs > bound]
    assert np.median(errs) > 0.002  # the errors are really there, not switched off


def test_patch_centroid_is_the_projected_wrist(sessions):
    folder, truth, _ = sessions["default"]
    s = load_session(folder)
    lo, hi = s.camera.patch.low, s.camera.patch.high
    errs, seen_when_hidden = [], 0
    for i, _, img in iter_frames(probe_video(s.camera.video)):
        hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
        mask = cv2.inRange(hsv, (lo[0], lo[1], lo[2]), (180, hi[1], hi[2])) | cv2.inRange(
            hsv, (0, lo[1], lo[2]), (hi[0], hi[1], hi[2]))
        n, lab, _, cen = cv2.connectedComponentsWithStats(mask)
        near = [k for k in range(1, n) if np.linalg.norm(cen[k] - truth["frame_wrist_px"][i]) < 25]
        if not truth["frame_patch_visible"][i]:
            seen_when_hidden += bool(near)
            continue
        assert near, f"frame {i}: patch not found"
        M = cv2.moments(np.isin(lab, near).astype(np.uint8))  # anti-aliased rims may split off
        errs.append(np.hypot(M["m10"] / M["m00"] - truth["frame_wrist_px"][i][0],
                             M["m01"] / M["m00"] - truth["frame_wrist_px"][i][1]))
    errs = np.array(errs)
    assert errs.size > 200 and errs.max() < 1.0, f"median {np.median(errs):.2f}, max {errs.max():.2f}"
    assert truth["frame_occluded"].sum() == 30 and seen_when_hidden == 0


def test_board_on_frame_zero_gives_the_camera_pose(sessions):
    folder, truth, _ = sessions["default"]
    s = load_session(folder)
    b = s.camera.board
    _, _, frame0 = next(iter_frames(probe_video(s.camera.video)))
    board = make_board(b.squares, b.square_m, b.marker_m, b.dictionary)
    eye = -truth["R_WC"].T @ truth["T_WC"]
    for corners in ("opencv", "saddle"):  # calibrate.corners
        pose = board_pose(frame0, board, read_camera_yaml(s.camera.intrinsics), corners=corners)
        assert np.linalg.norm(pose.camera_position_W - eye) < 0.01
        dR = pose.R_WC @ truth["R_WC"].T
        assert np.degrees(np.arccos(np.clip((np.trace(dR) - 1) / 2, -1, 1))) < 0.5
    # W's axes as the contract says: the camera looks down (its z has negative z_W) from above
    assert pose.camera_position_W[2] > 0.3 and pose.R_WC[2] @ [0, 0, 1] < 0


def test_qualisys_markers_equal_the_truth(sessions):
    for name in ("default", "ideal"):
        folder, truth, settings = sessions[name]
        s = load_session(folder)
        m = read_qualisys(s.groundtruth.file)
        t = m.t + s.sync.groundtruth_offset_s
        keep = (t >= 0) & (t <= truth["t"][-1])
        for role, key in (("shoulder", "shoulder"), ("elbow", "elbow"), ("wrist", "wrist")):
            got = to_world(m.marker(s.groundtruth.markers[role])[keep], s.groundtruth.to_world)
            exp = np.stack([np.interp(t[keep], truth["t"], truth[key][:, k]) for k in range(3)], -1)
            ok = np.isfinite(got[:, 0])
            err = np.abs(got[ok] - exp[ok])
            assert err.max() < 1e-3 + 5 * settings.marker_noise_m, (name, role, err.max())
            if name == "ideal":
                assert err.max() < 6e-4  # 3-decimal mm rounding and interpolation only
        gaps = np.isnan(m.marker("R_WRI")[:, 0]).sum()
        assert gaps > 0 if name == "default" else gaps == 0


def test_dropped_packets_are_absent_in_the_imu_file(sessions):
    folder, truth, _ = sessions["mcap"]
    session = load_session(folder)
    imu = read_imu(session.imu.file)
    assert imu.dropped > 0 and imu.fmt == "mcap"
    # each kept sample at its true session time (stream time + declared offset), so the
    # drops are gaps of more than one period, never later samples shifted to close them
    np.testing.assert_allclose(imu.t + session.offset_s("imu_offset_s"), truth["imu_t_session"],
                               atol=1e-6)
    assert np.diff(imu.t).max() > 1.5 / imu.rate_hz


def test_same_seed_same_bytes(tmp_path):
    settings = ArmSimSettings(duration_s=4.0, seed=11)
    for name in ("a", "b"):
        pipeline.simulate(tmp_path / name / "s1", settings)
    pipeline.simulate(tmp_path / "c" / "s1", ArmSimSettings(duration_s=4.0, seed=12))
    files = sorted(p.relative_to(tmp_path / "a") for p in (tmp_path / "a").rglob("*") if p.is_file())
    assert len(files) == 6  # five session files and the truth
    for f in files:
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes(), f
    assert (tmp_path / "a/s1/imu.txt").read_bytes() != (tmp_path / "c/s1/imu.txt").read_bytes()


def test_simulate_cli(tmp_path):
    r = run_cli("simulate", tmp_path / "r1", "--task", "figure8", "--duration", "4",
                "--imu-format", "csv", "--json")
    assert r.exit_code == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["frames"] == 120 and out["task"] == "figure8"
    assert run_cli("info", tmp_path / "r1").exit_code == 0
    again = run_cli("simulate", tmp_path / "r1")
    assert again.exit_code == 1 and "already exists" in again.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r1", "r1.truth.npz"]
