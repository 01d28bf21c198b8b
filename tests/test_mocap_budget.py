"""The error budget of sessions from real motion (validation/mocap_budget.py): the error split
against closed forms, the IMU file with the truth put back read by the contract's reader, and
the drifting arm's prior measured from spheres known by construction."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from armtrack_cli.core import quaternion as quat
from armtrack_cli.session.export.xsens import format_mt_manager
from armtrack_cli.session.imu import read_imu

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "validation"))
import mocap_budget  # noqa: E402
import mocap_rates  # noqa: E402


def _truth(path: Path, n: int = 60) -> dict:
    """A camera 1 m above the origin looking down, a wrist moving along x for the first half
    of the frames at 10 cm/s and still for the rest."""
    t = np.arange(n) / 30.0
    speed = np.where(t < t[n // 2], 0.1, 0.0)
    W = np.c_[np.r_[0.0, np.cumsum(speed[:-1] / 30.0)], 0.3 * np.ones(n), 0.05 * np.ones(n)]
    R_WC = np.diag([1.0, -1.0, -1.0])  # optical axis along −z_W
    T_WC = -R_WC @ np.array([0.0, 0.3, 1.05])  # the camera centre at (0, 0.3, 1.05)
    tr = {"R_WC": R_WC, "T_WC": T_WC, "frame_wrist": W, "frame_t": t, "t": t,
          "wrist_vel": np.c_[speed, 0 * t, 0 * t]}
    np.savez(path, **tr)
    return tr


def test_the_error_splits_along_and_across_the_ray(tmp_path):
    tr = _truth(tmp_path / "s.truth.npz")
    W = tr["frame_wrist"]
    C = -tr["R_WC"].T @ tr["T_WC"]
    ray = (W - C) / np.linalg.norm(W - C, axis=1)[:, None]
    seen = np.arange(len(W)) % 3 != 0
    w = mocap_budget.where(W - 0.02 * ray, tmp_path / "s.truth.npz", seen)  # 2 cm towards it
    assert np.isclose(w["along_mean"], -2.0) and np.isclose(w["rmse"], 2.0)
    assert w["across"] < 1e-9
    side = np.cross(ray, [1.0, 0.0, 0.0])
    side /= np.linalg.norm(side, axis=1)[:, None]
    err = np.where(np.arange(len(W))[:, None] < len(W) // 2, 0.01, 0.03) * side  # across only
    w = mocap_budget.where(W + err, tmp_path / "s.truth.npz", seen)
    assert abs(w["along_mean"]) < 1e-9 and np.isclose(w["across"], w["rmse"])
    assert np.isclose(w["moving"], 1.0) and np.isclose(w["still"], 3.0)
    assert w["n_still"] == len(W) - len(W) // 2 and w["n_hidden"] == int((~seen).sum())


def test_the_imu_file_with_the_truth_put_back(tmp_path):
    rng = np.random.default_rng(3)
    n = 200
    t = np.arange(n) / 100.0
    q_true = quat.normalize(np.c_[np.ones(n), 0.1 * np.sin(t)[:, None] * [1, 0.5, -0.3]])
    err = quat.from_axis_angle(np.array([[0.0, 1.0, 0.0]]), np.deg2rad([1.0]))
    q_out = quat.multiply(np.broadcast_to(err, q_true.shape), q_true)
    bias = np.array([0.03, -0.03, 0.03])
    acc = np.array([0.0, 0.0, 9.81]) + bias + 0.02 * rng.standard_normal((n, 3))
    gyr = 0.005 * rng.standard_normal((n, 3))
    (tmp_path / "imu.txt").write_text(format_mt_manager(t, acc, gyr, q_out))
    (tmp_path / "true.txt").write_text(mocap_budget.true_imu_text(
        (tmp_path / "imu.txt").read_text(), q_true, bias))
    before, after = read_imu(tmp_path / "imu.txt"), read_imu(tmp_path / "true.txt")
    dots = np.abs(np.sum(after.quat * q_true, axis=1))
    assert np.all(dots > 1 - 1e-10)  # the true orientation, to the file's 6 decimals
    assert np.all(np.abs(np.sum(before.quat * q_true, axis=1)) < np.cos(np.deg2rad(0.45)))
    assert np.allclose(after.acc, acc - bias, atol=1e-6)
    assert np.allclose(after.gyr, before.gyr) and np.allclose(after.t, before.t)


def test_the_prior_is_the_mean_offset_of_the_elbows_sphere(tmp_path):
    """Two trials whose elbows move on spheres placed by construction, one of them a left arm:
    the prior's centre is their mean offset from the declared arm (x mirrored for the left)
    and its SDs their spread about it."""
    rng = np.random.default_rng(0)
    offsets = [(np.array([0.05, 0.06, -0.07]), 0.03, "right"),
               (np.array([-0.07, 0.04, -0.05]), 0.01, "left")]
    paths = []
    for k, (off, dl, side) in enumerate(offsets):
        declared, L1 = np.array([0.1, 0.6, 0.3]), 0.30
        centre, radius = declared + off, L1 + dl
        d = rng.standard_normal((300, 3)) * [1.0, 1.0, 0.5]
        elbow = centre + radius * d / np.linalg.norm(d, axis=1)[:, None]
        path = tmp_path / f"T{k}.truth.npz"
        np.savez(path, frame_elbow=elbow, arm=np.r_[declared, L1, 0.25])
        (tmp_path / f"T{k}").mkdir()
        (tmp_path / f"T{k}" / "session.toml").write_text(f'[session]\nside = "{side}"\n')
        paths.append(path)
    sd_c, sd_r, dx, dy, dz, dl = mocap_rates.arm_priors(paths)
    assert np.allclose([dx, dy, dz, dl], [0.06, 0.05, -0.06, 0.02], atol=1e-9)
    assert np.isclose(sd_c, 0.01, atol=1e-9) and np.isclose(sd_r, 0.01, atol=1e-9)


def test_rest_speed_is_the_median_of_each_trials_still_velocity_times_root_tau(tmp_path):
    """Three trials at 30 frames/s whose 600 still frames (speed < 2 cm/s) move at ±a per
    axis, each value held for 3 frames (a square wave: of the 599 neighbouring pairs 199
    change sign, ρ_1 = (400 − 199)/599, and at lag 2 most do, ρ_2 < 0, so τ = 1 + 2 ρ_1), and
    whose moving frames go at 10 cm/s: the answer is the median a·√τ, the moving frames
    ignored; held for 1 frame (ρ_1 = −1: τ = 1) it is the median a."""
    for hold, tau in ((3, 1 + 2 * (400 - 199) / 599), (1, 1.0)):
        paths = []
        for k, a in enumerate((0.002, 0.004, 0.009)):
            sign = np.where((np.arange(600) // hold) % 2 == 0, 1.0, -1.0)
            still = a * sign[:, None] * np.ones((600, 3))
            moving = np.tile([0.1, 0.0, 0.0], (200, 1))
            t = np.arange(800) / 30.0
            path = tmp_path / f"T{k}-{hold}.truth.npz"
            np.savez(path, wrist_vel=np.vstack([still, moving]), t=t, frame_t=t)
            paths.append(path)
        assert np.isclose(mocap_rates.rest_speed(paths), 0.004 * np.sqrt(tau), rtol=1e-9)


def test_correlation_frames_of_a_first_order_autoregression():
    """A still hand's velocity as AR(1), x_k = φ x_{k−1} + e: ρ_k = φ^k, τ = (1 + φ)/(1 − φ)
    (= 3 for φ = 0.5); the estimate from 40 runs of 2,000 frames within 5 %."""
    rng = np.random.default_rng(11)
    phi, runs = 0.5, []
    for _ in range(40):
        e = rng.standard_normal((2000, 3))
        x = np.empty_like(e)
        x[0] = e[0] / np.sqrt(1 - phi**2)
        for k in range(1, 2000):
            x[k] = phi * x[k - 1] + e[k]
        runs.append(x)
    assert abs(mocap_rates.correlation_frames(runs) - 3.0) < 0.15


def test_the_board_pose_error_against_a_known_correction(tmp_path):
    """A pose moved off the truth by a known c = (φ, τ): its angle, distance and Mahalanobis²
    under a diagonal covariance, by hand."""
    tr = _truth(tmp_path / "s.truth.npz")
    phi, tau = np.array([0.01, -0.02, 0.005]), np.array([0.003, 0.0, -0.004])
    rot = quat.to_matrix(quat.from_axis_angle(phi[None] / np.linalg.norm(phi),
                                              np.array([np.linalg.norm(phi)])))[0]
    # the truth is exp([φ]×) applied to the estimate: R_true = rot R, T_true = rot T + τ
    R = rot.T @ tr["R_WC"]
    T = rot.T @ (tr["T_WC"] - tau)
    sd = np.array([0.01, 0.01, 0.01, 0.002, 0.002, 0.002])
    deg, cm, m2 = mocap_budget.pose_error(R, T, np.diag(sd**2), tmp_path / "s.truth.npz")
    assert np.isclose(deg, np.degrees(np.linalg.norm(phi)))
    assert np.isclose(cm, np.linalg.norm(tau) * 100)
    assert np.isclose(m2, np.sum((np.r_[phi, tau] / sd) ** 2))


def test_the_pixel_sd_pools_the_other_sessions_errors(tmp_path):
    """Two sessions whose detections lie a known offset from the true pixel (one frame not
    ok, its pixel far off): the RMS per axis over the ok frames."""
    offsets = {"a": (0.3, -0.1), "b": (0.0, 0.2)}
    for name, (du, dv) in offsets.items():
        px = np.c_[np.linspace(100, 200, 10), np.linspace(50, 80, 10)]
        np.savez(tmp_path / f"{name}.truth.npz", frame_t=np.arange(10) / 30.0, frame_wrist_px=px)
        (tmp_path / name / "armtrack").mkdir(parents=True)
        ok = np.ones(10, int)
        ok[3] = 0
        rows = [f"{k},{px[k, 0] + du + 50 * (1 - ok[k]):.6f},{px[k, 1] + dv:.6f},{ok[k]}"
                for k in range(10)]
        (tmp_path / name / "armtrack" / "detections.csv").write_text(
            "frame,u,v,ok\n" + "\n".join(rows) + "\n")
    got = mocap_rates.pixel_sd([tmp_path / "a.truth.npz", tmp_path / "b.truth.npz"])
    assert np.isclose(got, np.sqrt((0.3**2 + 0.1**2 + 0.0**2 + 0.2**2) / 4), atol=1e-6)
