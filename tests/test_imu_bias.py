"""fuse/imu_bias.py against closed forms: the IMU's double integral of a constant
acceleration is ½ a t²; an IMU that reads a + b on a trajectory with acceleration a gives back
b exactly once a full window of frames is at hand, from earlier frames only; the corrected
steps are those of the true acceleration; frames the filter did not use are left out. (What
it does to the forward filter is measured in docs/validation-forward-filter.md.)"""

from __future__ import annotations

import numpy as np

from armtrack_cli.fuse import imu_bias
from armtrack_cli.fuse.models import composite_steps

T_IMU = np.arange(0.0, 4.0, 0.01)
T_F = np.arange(0.0, 3.9, 1 / 30)


def _accel(t):
    """A smooth wrist acceleration (m/s²) whose trajectory is known in closed form."""
    return np.c_[0.3 * np.cos(2 * t), -0.2 * np.sin(3 * t), 0.1 * np.cos(t)]


def _position(t):
    """p(t) whose second derivative is _accel(t) (differentiate twice)."""
    return np.c_[0.2 - 0.3 / 4 * np.cos(2 * t) + 0.075 + 0.05 * t,
                 0.3 + 0.2 / 9 * np.sin(3 * t) - 0.2 / 3 * t + 0.02 * t,
                 0.1 - 0.1 * np.cos(t) + 0.1]


def test_imu_path_of_a_constant_acceleration_is_half_a_t_squared():
    a = np.array([0.3, -0.1, 0.2])
    steps = composite_steps(T_IMU, np.tile(a, (T_IMU.size, 1)), T_F, accel_noise=0.1,
                            imu_period=0.01)
    D = imu_bias.imu_path(steps)
    np.testing.assert_allclose(D, 0.5 * a * (T_F - T_F[0])[:, None] ** 2, atol=1e-12)


def test_a_constant_bias_is_recovered_from_earlier_frames_only():
    b = np.array([0.12, -0.08, 0.03])
    t_fine = np.arange(0.0, 4.0, 0.001)  # the held IMU samples integrate exactly only at
    steps = composite_steps(t_fine, _accel(t_fine) + b, T_F, accel_noise=0.1,  # a fine rate
                            imu_period=0.001)
    p = _position(T_F)
    used = np.ones(T_F.size, bool)
    est = imu_bias.causal_bias(T_F, p, used, steps, window_s=1.0)
    full = T_F > 1.0 + 1.5 / 30  # a full window of earlier frames
    np.testing.assert_allclose(est[full], np.tile(b, (full.sum(), 1)), atol=2e-3)
    assert (est[T_F < 0.85] == 0).all()  # no full window yet: nothing is invented
    # causal: changing the estimates from frame k on leaves b_0 … b_k as they were
    k = 70
    p2 = p.copy()
    p2[k:] += 0.3
    est2 = imu_bias.causal_bias(T_F, p2, used, steps, window_s=1.0)
    np.testing.assert_array_equal(est2[:k + 1], est[:k + 1])
    assert np.abs(est2[k + 1:] - est[k + 1:]).max() > 0.01
    # the corrected steps are the true acceleration's
    true = composite_steps(t_fine, _accel(t_fine), T_F, accel_noise=0.1, imu_period=0.001)
    fixed = imu_bias.corrected(steps, np.tile(b, (T_F.size, 1)))
    np.testing.assert_allclose(fixed.dp, true.dp, atol=1e-12)
    np.testing.assert_allclose(fixed.dv, true.dv, atol=1e-12)


def test_frames_not_used_are_left_out_and_the_cap_holds():
    b = np.array([0.5, 0.0, 0.0])  # beyond the cap (0.25 m/s²)
    t_fine = np.arange(0.0, 4.0, 0.001)
    steps = composite_steps(t_fine, _accel(t_fine) + b, T_F, accel_noise=0.1,
                            imu_period=0.001)
    p = _position(T_F)
    used = np.ones(T_F.size, bool)
    used[40:70] = False
    p_bad = p.copy()
    p_bad[40:70] += 0.5  # what a drifted filter would say under a card: not used
    est = imu_bias.causal_bias(T_F, p_bad, used, steps, window_s=1.0)
    np.testing.assert_allclose(np.linalg.norm(est[T_F > 1.1], axis=1), 0.25, atol=1e-9)
    np.testing.assert_allclose(est[T_F > 1.1, 1:], 0.0, atol=1e-3)
