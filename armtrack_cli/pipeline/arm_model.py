"""`[arm] … = "auto"`: the arm model estimated from the session before fusing
(fuse/arm_auto.py), and the session with it in place for every stage after fuse."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from armtrack_cli.core.errors import DataError
from armtrack_cli.fuse import arm_auto, models
from armtrack_cli.session.arm_file import read_arm_estimate
from armtrack_cli.session.config import Session

ANCHORED_WALK = 0.001  # rad/√s: the gyro-anchored orientation's error is nearly constant (its
#                        white-noise walk: ~0.1° over 20 s; docs/validation-from-mocap.md)


def estimate(session: Session, prepared) -> arm_auto.ArmEstimate:
    """The free parts of the arm from the most varied stretch of the filtered frames, with the
    IMU's orientation whose wandering error the gyro has replaced by a constant one
    (fuse/gyro_orientation.py; the batch estimates that constant)."""
    inp, st = prepared.inputs, arm_auto.AutoSettings(orientation_walk=ANCHORED_WALK)
    t_fr = prepared.t_frames[prepared.frames]
    q_WB = models.quat.interpolate(inp.imu.t, prepared.q_anchored, t_fr)
    steps = models.composite_steps(inp.imu.t, models.accel_world(prepared.q_anchored, inp.imu.f_B),
                                   t_fr, accel_noise=0.0, imu_period=1.0)
    f_W = models.quat.rotate(q_WB, session.imu.forearm_unit)
    w = arm_auto.varied_stretch(inp.z[::st.stride], f_W[::st.stride], st.max_frames)
    a, b = w.start * st.stride, min(inp.z.shape[0], w.stop * st.stride)
    idx = np.arange(a, b, st.stride)
    if np.isfinite(inp.z[idx]).all(axis=1).sum() < 20:
        raise DataError(session.toml_path, f'[arm] "auto" needs at least 20 detections; the '
                        f"stretch used has {int(np.isfinite(inp.z[idx]).all(axis=1).sum())}",
                        "declare the arm model, or check detect")
    arm = session.arm
    declared = {k: (None if k in arm.auto else v) for k, v in
                (("shoulder_m", arm.shoulder_m), ("upper_arm_m", arm.upper_arm_m),
                 ("forearm_m", arm.forearm_m))}
    return arm_auto.estimate_arm(arm_auto.coarsen(steps, st.stride, a, b), inp.z[idx],
                                 q_WB[idx], prepared.t_frames[prepared.frames[idx]],
                                 prepared.projection, session.imu.forearm_unit, declared, st)


def estimate_with_offset(session: Session, prepared, prepare_again):
    """The arm, and the IMU's offset with it: the offset was set before the arm was known (its
    depths then from the first detection's range, no sphere), so it is set again with the
    estimated arm's depths, "auto" estimated or a declared value checked (and warned about,
    pipeline/imu_offset.py), and an "auto" offset's arm is estimated again at the new offset.
    ``prepare_again(session)`` prepares a session whose arm is declared. Returns the estimate
    and the preparation it belongs to."""
    est = estimate(session, prepared)
    known = with_arm(session, est.shoulder, est.upper_arm_m, est.forearm_m)
    known = dataclasses.replace(known, arm=dataclasses.replace(known.arm, auto=()))
    again = prepare_again(known)
    if session.sync.imu_offset_s != "auto":
        return est, dataclasses.replace(prepared, imu_offset=again.imu_offset)
    return estimate(session, again), again


def with_arm(session: Session, shoulder, upper_arm_m: float, forearm_m: float) -> Session:
    arm = dataclasses.replace(session.arm, shoulder_m=np.asarray(shoulder, float),
                              upper_arm_m=float(upper_arm_m), forearm_m=float(forearm_m))
    return dataclasses.replace(session, arm=arm)


def resolved(session: Session, work: str | Path) -> Session:
    """The session with fuse's estimate of an "auto" arm in place (unchanged otherwise; an
    "auto" arm without an estimate stays NaN: missing, as it is)."""
    if session.arm is None or not session.arm.auto:
        return session
    est = read_arm_estimate(work)
    if est is None:
        return session
    return with_arm(session, est["shoulder_m"], est["upper_arm_m"], est["forearm_m"])
