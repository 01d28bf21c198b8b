"""The calibration movement (simulate/calibration_move.py, `simulate --calibration-movement`):
its kinematics checked against independent computations, and `[arm] … = "auto"` recovering a
known arm from it where the task alone leaves the shoulder centimetres off."""

from __future__ import annotations

import json

import numpy as np
import pytest

from armtrack_cli import pipeline
from armtrack_cli.core import quaternion as Q
from armtrack_cli.fuse import arm_auto, models
from armtrack_cli.simulate import kinematics
from armtrack_cli.simulate.camera import default_camera, project
from tests.conftest import run_cli

ARM = kinematics.ArmGeometry(np.array([0.12, 0.58, 0.30]), 0.31, 0.27)
CENTRE = np.array([0.26, 0.25, 0.07])
C = 8.0  # the movement's length, s
START = kinematics.REST_S


def _task(name: str, seconds: float, calibration: float = C) -> kinematics.Task:
    return kinematics.Task(name, seconds, CENTRE, 0.10, calibration_s=calibration)


@pytest.mark.parametrize("name", kinematics.TASKS)
def test_movement_keeps_the_arm_rigid_in_view_and_smooth(name):
    t = np.linspace(START, START + C, 1601)
    st = kinematics.arm_state(ARM, _task(name, 14.0), t)
    np.testing.assert_allclose(np.linalg.norm(st.elbow - ARM.shoulder, axis=1), 0.31, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(st.wrist - st.elbow, axis=1), 0.27, atol=1e-9)
    np.testing.assert_allclose(Q.rotate(st.q_WB, [0, 1.0, 0]), (st.wrist - st.elbow) / 0.27,
                               atol=1e-9)
    cam = default_camera()
    px, depth = project(cam, st.wrist)
    assert (depth > 0).all() and (px > 20).all()
    assert (px[:, 0] < cam.width - 20).all() and (px[:, 1] < cam.height - 20).all()
    facing = np.einsum("ni,ni->n", Q.rotate(st.q_WB, [0, 0, 1.0]), cam.centre_W - st.wrist)
    assert (facing > 0).all()  # the patch on the back of the wrist faces the camera
    assert st.elbow[:, 2].min() > 0.01  # the elbow clear of the table
    assert st.wrist[:, 2].max() - st.wrist[0, 2] > 0.15  # the hand lifted
    # derivatives against an independent one: the positions' central difference on the grid
    dt = t[1] - t[0]
    vel = (st.wrist[2:] - st.wrist[:-2]) / (2 * dt)
    np.testing.assert_allclose(st.wrist_vel[1:-1], vel, atol=2e-4)
    acc = (st.wrist[2:] - 2 * st.wrist[1:-1] + st.wrist[:-2]) / dt**2
    # (the grid's 5 ms second difference is ~3 mm/s² off where the envelope's jerk steps, as
    # the tasks' minimum-jerk segments do; ~1e-5 elsewhere)
    np.testing.assert_allclose(st.wrist_acc[1:-1], acc, atol=5e-3)
    # still at both ends: it leaves the rest pose as smoothly as a task does, and hands over to
    # the task exactly as the task alone starts from rest
    ends = kinematics.arm_state(ARM, _task(name, 14.0), np.array([START, START + C]))
    alone = kinematics.arm_state(ARM, _task(name, 6.0, 0.0), np.array([START]))
    assert np.abs(ends.wrist_vel[0]).max() < 1e-9 and np.abs(ends.omega_B[0]).max() < 1e-6
    assert np.abs(ends.wrist_acc[0]).max() < 1e-3
    # (the 5-point stencil's ±2 ms reach the envelope's last, near-still instants: ~2e-4 m/s²)
    for key, tol in (("wrist", 1e-12), ("q_WB", 1e-12), ("wrist_vel", 1e-6), ("wrist_acc", 1e-3),
                     ("omega_B", 1e-5)):
        np.testing.assert_allclose(getattr(ends, key)[1:], getattr(alone, key), atol=tol)


@pytest.mark.parametrize("name", kinematics.TASKS)
def test_task_after_the_movement_is_the_task_shifted(name):
    t = np.linspace(START + C + 0.003, 28.0, 700)  # (past the stencil's reach into the movement)
    moved = kinematics.arm_state(ARM, _task(name, 28.0), t)
    alone = kinematics.arm_state(ARM, _task(name, 20.0, 0.0), t - C)
    # t − C rounds differently from the task's own clock: 1e-15 s, 1e-8 m/s² through the stencil
    for key, tol in (("wrist", 1e-12), ("elbow", 1e-12), ("q_WB", 1e-12), ("wrist_acc", 1e-7),
                     ("omega_B", 1e-8)):
        np.testing.assert_allclose(getattr(moved, key), getattr(alone, key), atol=tol)
    before = kinematics.arm_state(ARM, _task(name, 28.0), np.linspace(0, START, 50))
    np.testing.assert_allclose(before.wrist, alone.wrist[:1].repeat(50, 0), atol=1e-12)


def _sphere_conditioning(elbow: np.ndarray) -> float:
    """√ smallest eigenvalue of the sphere fit's normal matrix over elbow directions n."""
    n = (elbow - ARM.shoulder) / np.linalg.norm(elbow - ARM.shoulder, axis=1, keepdims=True)
    J = np.c_[-n, -np.ones(len(n))]
    return float(np.sqrt(np.linalg.eigvalsh(J.T @ J / len(n))[0]))


@pytest.mark.parametrize("name", kinematics.TASKS)
def test_the_elbow_covers_a_patch_not_a_circle(name):
    t = np.linspace(0, 28.0, 2000)
    moved = _sphere_conditioning(kinematics.arm_state(ARM, _task(name, 28.0), t[t < START + C]).elbow)
    alone = _sphere_conditioning(kinematics.arm_state(ARM, _task(name, 20.0, 0.0),
                                                      t[t <= 20]).elbow)
    assert alone < 0.015 and moved > 0.035


def _batch(seconds: float, calibration: float, stride: int = 3, seed: int = 0):
    """Steps, detections, orientations of a reach (after the movement, if any) at 30 fps from
    exact kinematics: pixels with 1 px noise, accelerations with 0.02 m/s², orientation 1° off."""
    rng = np.random.default_rng(seed)
    task = _task("reach", seconds, calibration)
    t_imu = np.arange(int(seconds * 100)) / 100.0
    a_W = kinematics.arm_state(ARM, task, t_imu).wrist_acc + rng.normal(0, 0.02, (t_imu.size, 3))
    t_f = np.arange(0, seconds - 0.1, stride / 30.0)
    fs = kinematics.arm_state(ARM, task, t_f)
    proj = models.Projection(default_camera())
    uv = proj(fs.wrist) + rng.normal(0, 1.0, (t_f.size, 2))
    steps = models.composite_steps(t_imu, a_W, t_f, accel_noise=0.1, imu_period=0.01)
    tilt = Q.from_axis_angle(np.array([1.0, 0.3, 0.0]) / np.hypot(1.0, 0.3), np.deg2rad(1.0))
    return steps, uv, Q.multiply(tilt, fs.q_WB), t_f, proj


def test_the_sphere_fit_finds_the_arm_from_the_movement():
    """The reach alone leaves the sphere fit's shoulder centimetres off; with the movement
    before it, within 1.5 cm and the lengths within 1 cm (measured: 0.5-0.7 cm, 0.5 cm)."""
    free = {"shoulder_m": None, "upper_arm_m": None, "forearm_m": None}
    est = arm_auto.estimate_arm(*_batch(12.0, C), np.array([0.0, 1.0, 0.0]), free)
    assert np.linalg.norm(est.shoulder - ARM.shoulder) < 0.015
    assert abs(est.upper_arm_m - 0.31) < 0.01 and abs(est.forearm_m - 0.27) < 0.01
    alone = arm_auto.estimate_arm(*_batch(12.0, 0.0), np.array([0.0, 1.0, 0.0]), free)
    assert np.linalg.norm(alone.shoulder - ARM.shoulder) > 0.03


def test_simulate_option_and_auto_arm_end_to_end(tmp_path):
    """`simulate --calibration-movement` on a short session; fuse with the arm "auto" recovers
    the simulator's arm (shoulder within 1 cm, lengths within 0.6 cm) through the sphere fit
    and the refinement."""
    out = tmp_path / "moved"
    r = run_cli("simulate", out, "--task", "circle", "--duration", "14",
                "--calibration-movement", str(C), "--seed", "1")
    assert r.exit_code == 0, r.output
    toml = (out / "session.toml").read_text()
    assert "--calibration-movement 8" in toml
    truth = np.load(tmp_path / "moved.truth.npz")
    assert truth["frame_patch_visible"][: int((START + C) * 30)].all()
    for key in ("upper_arm_m", "forearm_m", "shoulder_m"):
        toml = "\n".join(f'{key} = "auto"' if ln.startswith(f"{key} =") else ln
                         for ln in toml.splitlines())
    (out / "session.toml").write_text(toml + "\n")
    pipeline.calibrate(out)
    pipeline.detect(out)
    pipeline.fuse(out, method="arm-smoother")
    est = json.loads((out / "armtrack" / "arm-auto.json").read_text())
    assert np.linalg.norm(np.array(est["shoulder_m"]) - ARM.shoulder) < 0.01, est
    assert abs(est["upper_arm_m"] - 0.31) < 0.006 and abs(est["forearm_m"] - 0.27) < 0.006, est


def test_simulate_option_is_refused_where_it_cannot_be(tmp_path):
    r = run_cli("simulate", tmp_path / "a", "--duration", "10", "--calibration-movement", "8")
    assert r.exit_code == 2 and "--calibration-movement" in r.output
    r = run_cli("simulate", tmp_path / "b", "--task", "wrist-rom", "--calibration-movement", "8")
    assert r.exit_code == 2 and "arm tasks" in r.output
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()
