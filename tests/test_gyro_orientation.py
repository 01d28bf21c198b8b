"""The gyro-anchored orientation (fuse/gyro_orientation.py) against the simulator's truth: the
reported orientation's wandering ~1° error (simulate/imu_model.py) becomes one nearly constant
error; without a gyroscope the reported orientation is returned unchanged."""

from __future__ import annotations

import numpy as np

from armtrack_cli.core import quaternion as quat
from armtrack_cli.fuse.gyro_orientation import gyro_anchored, integrate_gyro, prefix_products
from armtrack_cli.simulate import imu_model, kinematics
from armtrack_cli.simulate.arm_session import ArmSimSettings


def _imu(task: str, seed: int = 0, duration: float = 20.0):
    s = ArmSimSettings(task=task, duration_s=duration)
    arm = kinematics.ArmGeometry(np.array(s.shoulder), s.upper_arm_m, s.forearm_m)
    t = np.arange(int(duration * 100)) / 100.0
    st = kinematics.arm_state(arm, kinematics.Task(task, duration, np.array(s.centre), s.size_m), t)
    m = imu_model.measure(t, st.q_WB, st.wrist_acc, st.omega_B, imu_model.ImuErrors.preset("mtw"),
                          100.0, np.random.default_rng(seed))
    return t, st.q_WB, m


def _error_vectors(q: np.ndarray, q_true: np.ndarray) -> np.ndarray:
    """World-frame error rotation vectors (rad) of q against the truth, small-angle."""
    e = quat.multiply(q, quat.conjugate(q_true))
    return 2 * e[:, 1:] * np.sign(e[:, :1])


def test_exact_gyro_integrates_to_the_true_turn():
    """Noise-free rates from the simulator's kinematics turn q_0 as the truth turns (q̇ = ½ q ⊗ ω)."""
    t, q_true, _ = _imu("figure8", duration=10.0)
    s = ArmSimSettings(task="figure8", duration_s=10.0)
    arm = kinematics.ArmGeometry(np.array(s.shoulder), s.upper_arm_m, s.forearm_m)
    w = kinematics.arm_state(arm, kinematics.Task("figure8", 10.0, np.array(s.centre), s.size_m),
                             t).omega_B
    q = integrate_gyro(t, q_true, w)
    assert np.degrees(quat.angle_between(q, q_true)).max() < 0.05


def test_wandering_error_becomes_nearly_constant():
    for task, seed in (("circle", 0), ("reach", 1)):
        t, q_true, m = _imu(task, seed)
        rep = _error_vectors(m["quat"], q_true)
        fix = _error_vectors(gyro_anchored(t, m["quat"], m["gyr"]), q_true)
        wander_rep = np.degrees(np.sqrt(np.mean(np.sum((rep - rep.mean(0)) ** 2, 1))))
        wander_fix = np.degrees(np.sqrt(np.mean(np.sum((fix - fix.mean(0)) ** 2, 1))))
        assert wander_rep > 0.5  # the simulator's 1° RMS error does wander
        assert wander_fix < 0.35 * wander_rep  # the gyro noise's walk: ~0.2° over 20 s
        assert np.degrees(np.linalg.norm(fix.mean(0))) < 1.0  # its constant: below the 1° RMS


def test_without_a_gyro_the_reported_orientation():
    t, _, m = _imu("circle", duration=5.0)
    assert gyro_anchored(t, m["quat"], np.full_like(m["gyr"], np.nan)) is m["quat"]
    gyr = m["gyr"].copy()
    gyr[100:150] = np.nan  # a gap: those steps turn as the reported orientation does
    q = gyro_anchored(t, m["quat"], gyr)
    assert np.isfinite(q).all()


def test_prefix_products_equal_the_sequential_product():
    """The doubling scan gives q_0 ⊗ q_1 ⊗ … ⊗ q_k as the plain left-to-right loop does, for
    every k and lengths that are and are not powers of two (non-commuting random rotations)."""
    rng = np.random.default_rng(7)
    for m in (1, 2, 7, 64, 1000):
        q = quat.normalize(rng.standard_normal((m, 4)))
        seq = np.empty_like(q)
        seq[0] = q[0]
        for k in range(1, m):
            seq[k] = quat.multiply(seq[k - 1], q[k])
        assert np.abs(prefix_products(q) - seq).max() < 1e-12
