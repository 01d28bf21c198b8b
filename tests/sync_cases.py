"""Synthetic clock-offset problems from the simulator's exact arm kinematics and its IMU
error model (simulate/imu_model.py), without rendering video: shared by tests/test_imu_sync.py
and validation/imu_sync.py. The detections are the true wrist pixels with 0.5 px of noise,
the spread measured of `armtrack detect` on rendered sessions (docs/validation-sync.md)."""

from __future__ import annotations

import numpy as np

from armtrack_cli.fuse import models
from armtrack_cli.fuse.gyro_orientation import gyro_anchored
from armtrack_cli.fuse.imu_sync import SyncProblem
from armtrack_cli.simulate import imu_model, kinematics
from armtrack_cli.simulate.arm_session import ArmSimSettings
from armtrack_cli.simulate.camera import default_camera

PIXEL_SD = 0.5  # px


def case(offset_s: float, *, task: str = "circle", seed: int = 0, duration: float = 20.0,
         orientation_deg: float | None = None) -> SyncProblem:
    """Frames at 30 fps on the session clock; an MTw-class IMU at 100 Hz on its own clock
    (session time = IMU time + offset_s), covering the video and 0.5 s more;
    ``orientation_deg`` overrides the preset's 1° orientation error."""
    rng = np.random.default_rng([seed, 7])
    s = ArmSimSettings(task=task, duration_s=duration)
    arm = kinematics.ArmGeometry(np.array(s.shoulder), s.upper_arm_m, s.forearm_m)
    tk = kinematics.Task(task, duration, np.array(s.centre), s.size_m)
    proj = models.Projection(default_camera())
    t_f = np.arange(int(round(duration * 30))) / 30.0
    uv = proj(kinematics.arm_state(arm, tk, t_f).wrist) + rng.normal(0, PIXEL_SD, (t_f.size, 2))
    t_imu = np.arange(int(np.floor((duration - offset_s + 0.5) * 100))) / 100.0
    st = kinematics.arm_state(arm, tk, t_imu + offset_s)
    err = imu_model.ImuErrors.preset("mtw")
    if orientation_deg is not None:
        err = err.override(orientation_rms_deg=orientation_deg)
    m = imu_model.measure(t_imu + offset_s, st.q_WB, st.wrist_acc, st.omega_B, err, 100.0, rng)
    q = gyro_anchored(t_imu, m["quat"], m["gyr"])  # as fuse prepares it (pipeline/fuse.py)
    return SyncProblem(t_imu, models.accel_world(q, m["acc"]), q, t_f, uv, proj,
                       models.Arm(shoulder=arm.shoulder, L1=arm.upper_arm_m, L2=arm.forearm_m,
                                  forearm_B=np.array([0.0, 1.0, 0.0])))
