"""fuse/imu_error.py, the forward filter's causal estimate of the IMU's orientation error and
accelerometer bias, against independent answers: its Kalman pass equals batch least squares
over the frames up to k (the filtered, not the smoothed, estimate); on an arm whose motion is
known in closed form, seen by an IMU with a known tilt and bias, it recovers both and removes
most of the error of a_W; and it is causal: the estimate at frame k does not change when the
data after k change. (What it does to the forward filter: docs/validation-forward-filter.md.)
"""

from __future__ import annotations

import numpy as np
import pytest

from armtrack_cli.core import quaternion as quat
from armtrack_cli.core.streams import CameraModel
from armtrack_cli.fuse import arm_state, imu_error, models
from armtrack_cli.fuse.arm_smoother import ImuSamples
from armtrack_cli.fuse.methods import Inputs
from armtrack_cli.fuse.settings import LINEARISATIONS, FuseSettings

from .test_arm_smoother import _batch, _linear_problem

TILT = np.deg2rad([0.8, -0.6, 0.3])  # the IMU's output orientation error, rad (in W)
BIAS = np.array([0.03, -0.03, 0.02])  # its accelerometer bias, m/s² (in B)


def test_forward_pass_is_batch_least_squares_of_the_frames_so_far():
    """The filtered state at k is the MAP of the model cut at k (its last block)."""
    prob = list(_linear_problem(np.random.default_rng(7)))
    prob[11] = np.ones_like(prob[11])  # imu_error's pass applies the arm row on every frame
    x0, P0, F, b, Q, Hc, zc, use_c, rc, Hk, zk, use_k, rk = prob
    xf, codes = imu_error.forward(x0, P0, F, b, Q, Hc, zc, use_c, rc, Hk, zk, rk, np.inf, 10,
                                  np.zeros(x0.size))
    assert (codes[use_c] == 1).all() and (codes[~use_c] == 0).all()
    for k in (0, 5, 12, F.shape[0] - 1):
        cut = [a[:k + 1] if isinstance(a, np.ndarray) and a.ndim and a.shape[0] == F.shape[0]
               else a for a in prob]
        ref, _ = _batch(*cut)
        np.testing.assert_allclose(xf[k], ref[-1], atol=1e-9)


def _camera():
    K = np.array([[600.0, 0, 320], [0, 600, 240], [0, 0, 1]])
    R_WC = quat.to_matrix(quat.from_axis_angle(np.array([1.0, 0, 0]), np.deg2rad(-150)))
    return models.Projection(CameraModel(K=K, dist=np.zeros(5), R_WC=R_WC,
                                         T_WC=np.array([0.0, -0.45, 0.75]), width=640,
                                         height=480))


def _arm_motion(t):
    """The true forearm orientation q (n, 4), upper-arm direction e (n, 3), both smooth closed
    forms; shoulder at the origin, L1 0.3, L2 0.25, forearm along B's x."""
    q = quat.from_euler_zyx(0.4 * np.sin(0.9 * t), 0.25 * np.sin(1.3 * t + 0.5),
                            0.3 * np.cos(0.7 * t))
    a = 0.5 * np.sin(0.8 * t)
    e = np.stack([0.3 * np.cos(a), 0.85 + 0.1 * np.sin(a), -0.4 + 0.1 * np.cos(1.1 * t)], -1)
    return q, e / np.linalg.norm(e, axis=1, keepdims=True)


def _wrist(t, arm):
    q, e = _arm_motion(t)
    return arm.shoulder + arm.L1 * e + arm.L2 * quat.rotate(q, arm.forearm_B)


def _session(seed=0):
    """IMU (100 Hz) with TILT, BIAS and noise, detections (30 fps, 1 px noise, a 1 s card),
    and the truth: (inputs, first (n, 6) a forward estimate near the truth, arm, camera,
    the true Δv per frame)."""
    rng = np.random.default_rng(seed)
    arm = models.Arm(shoulder=np.zeros(3), L1=0.3, L2=0.25, forearm_B=np.array([1.0, 0, 0]))
    t = np.arange(0.0, 6.0, 0.01)
    h = 1e-4
    acc = (_wrist(t + h, arm) - 2 * _wrist(t, arm) + _wrist(t - h, arm)) / h**2
    q, _ = _arm_motion(t)
    dq = quat.multiply(quat.conjugate(_arm_motion(t - h)[0]), _arm_motion(t + h)[0])
    w_B = dq[:, 1:] * np.sign(dq[:, :1]) / h
    f_B = quat.rotate(quat.conjugate(q), acc - models.GRAVITY_W) + BIAS
    f_B += 0.02 * rng.standard_normal(f_B.shape)
    ang = np.linalg.norm(TILT)
    q_hat = quat.multiply(np.tile(quat.from_axis_angle(TILT / ang, ang), (t.size, 1)), q)
    tf = np.arange(0.0, 5.9, 1 / 30)
    proj = _camera()
    p = _wrist(tf, arm)
    z = proj(p) + rng.standard_normal((tf.size, 2))
    z[(tf > 3.0) & (tf < 4.0)] = np.nan
    steps = models.composite_steps(t, models.accel_world(q_hat, f_B), tf, accel_noise=1.0,
                                   imu_period=0.01)
    inp = Inputs(steps, z, quat.interpolate(t, q_hat, tf), t=tf, imu=ImuSamples(t, q_hat, f_B,
                                                                                 w_B))
    v = (_wrist(tf + h, arm) - _wrist(tf - h, arm)) / (2 * h)
    first = np.hstack([p + 0.01 * rng.standard_normal(p.shape), v])
    return inp, first, arm, proj, np.vstack([np.zeros((1, 3)), np.diff(v, axis=0)])


def _estimate(inp, first, arm, proj, passes=2, velocity=False, linearise="passes"):
    x0 = first[0]
    P0 = np.diag([0.03**2] * 3 + [0.05**2] * 3)
    out = imu_error.causal_errors(inp, first, x0, P0, proj,
                                  FuseSettings(kalman_linearise=linearise), arm, passes)
    return out[:3] if velocity else out[:2]


@pytest.mark.parametrize("linearise", LINEARISATIONS)
def test_tilt_and_bias_are_recovered_and_a_w_corrected(linearise):
    inp, first, arm, proj, dv_true = _session()
    assert np.isfinite(proj(first[:, :3])).all()
    th, ba = _estimate(inp, first, arm, proj, linearise=linearise)
    late = inp.t > 2.0
    # the tilt (what leaks gravity, 1°) within 0.3° after 2 s of detections, 0.1° at the end
    err = np.degrees(np.abs(th[:, :2] - TILT[:2]))
    assert err[late].max() < 0.3 and err[inp.t > 5.0].max() < 0.1, err[late].max()
    assert np.abs(ba[-1] - BIAS).max() < 0.02
    fixed = imu_error.corrected(inp, inp.steps, th, ba)
    dt = inp.steps.dt[late, None]

    def rms(dv):
        return np.sqrt(np.mean(np.sum(((dv[late] - dv_true[late]) / dt) ** 2, axis=1)))

    before, after = rms(inp.steps.dv), rms(fixed.dv)
    assert before > 0.1  # g · sin 1°: what the tilt leaks
    assert after < 0.2 * before, (before, after)  # 0.19 -> 0.023 m/s², the noise 0.02


@pytest.mark.parametrize("linearise", LINEARISATIONS)
def test_the_estimate_at_frame_k_uses_no_later_data(linearise):
    """Detections, the forward estimate and the IMU from one IMU sample after frame k on
    changed (the fold interpolates to the next sample): frames ≤ k unchanged, later ones not."""
    inp, first, arm, proj, _ = _session()
    th, ba, v = _estimate(inp, first, arm, proj, passes=8, velocity=True, linearise=linearise)
    k = 100
    z = inp.z.copy()
    z[k + 1:] += 25.0
    f2 = first.copy()
    f2[k + 1:, :3] += 0.05
    imu = inp.imu
    late = imu.t > inp.t[k] + 0.0101
    f_B = imu.f_B.copy()
    f_B[late] += 0.5
    w_B = imu.w_B.copy()
    w_B[late] += 0.1
    imu2 = ImuSamples(imu.t, imu.q_WB, f_B, w_B)
    inp2 = Inputs(inp.steps, z, inp.q_WB, t=inp.t, imu=imu2)
    th2, ba2, v2 = _estimate(inp2, f2, arm, proj, passes=8, velocity=True, linearise=linearise)
    np.testing.assert_array_equal(th2[:k + 1], th[:k + 1])
    np.testing.assert_array_equal(ba2[:k + 1], ba[:k + 1])
    np.testing.assert_array_equal(v2[:k + 1], v[:k + 1])  # after 8 passes too
    assert np.abs(th2[k + 1:] - th[k + 1:]).max() > 1e-4


def test_passes_bring_a_first_run_off_the_arm_back():
    """The first run 12 cm toward the camera for 2 s (as a forward filter that lost the arm
    on the chord): the velocity of the pass linearised about it is off; each pass linearised
    about the one before comes back to the truth's and stays there."""
    inp, first, arm, proj, _ = _session()
    t = inp.t
    p_true = _wrist(t, arm)
    v_true = (_wrist(t + 1e-4, arm) - _wrist(t - 1e-4, arm)) / 2e-4
    off = first.copy()
    bad = (t > 2.0) & (t < 4.0)
    ray = p_true[bad] - proj.eye
    off[bad, :3] -= 0.12 * ray / np.linalg.norm(ray, axis=1, keepdims=True)
    rmse = {}
    for n in (1, 2, 8):
        v = _estimate(inp, off, arm, proj, passes=n, velocity=True)[2]
        rmse[n] = float(np.sqrt(np.mean(np.sum((v - v_true)[t > 1.0] ** 2, axis=1))))
    # measured: 1.5, 0.67, 0.72 cm/s; within 1 cm/s of the truth's after 8 passes
    assert rmse[8] < 0.6 * rmse[1] and rmse[8] < 0.01, rmse


def test_iterated_pass_is_the_fixed_point_of_the_passes():
    """The iterated pass (its own rows, linearised per frame in the kernel) equals one pass of
    ``forward`` linearised by arm_smoother.linearise about the iterated pass's own states: the
    fixed point the passes converge to, whatever the first run (here 12 cm off for 2 s).
    Converged within arm_smoother.STEP_TOL_M (10 µm) on every frame, in a few linearisations."""
    from armtrack_cli.fuse import arm_smoother, imu_fold
    from armtrack_cli.fuse.methods import camera_arrays

    inp, first, arm, proj, _ = _session()
    x0, P0 = first[0], np.diag([0.03**2] * 3 + [0.05**2] * 3)
    s = FuseSettings(kalman_linearise="iterated")
    off = first.copy()
    off[60:120, :3] -= 0.12
    out = imu_error.causal_errors(inp, off, x0, P0, proj, s, arm)
    out2 = imu_error.causal_errors(inp, None, x0, P0, proj, s, arm)
    for a, b in zip(out, out2):  # no first run used
        np.testing.assert_array_equal(a, b)
    imu, seen = inp.imu, np.isfinite(inp.z).all(axis=1)
    fd = imu_fold.fold(imu.t, imu.q_WB, imu.f_B, inp.t, hold=s.imu_hold)
    track = imu_fold.orientation_track(imu.t, imu.q_WB, imu.w_B, inp.t)
    F, b, Q = arm_state.process(fd, s, None, 0.01, track)
    m0, Pm0 = arm_smoother.prior(x0, P0, s, None, True)
    infl = np.r_[np.full(3, s.reacquire_sigma_m**2), np.full(3, s.init_vel_sigma_m_s**2),
                 np.zeros(m0.size - 6)]
    X, codes, lin = imu_error.iterated(
        m0, Pm0, F, b, Q, np.where(seen[:, None], inp.z, 0.0), seen, s.pixel_sigma**2,
        *camera_arrays(proj), quat.rotate(inp.q_WB, arm.forearm_B), arm.shoulder, arm.L1,
        arm.L2, s.constraint_sigma_m**2, s.gate_chi2, s.reacquire_frames, infl,
        arm_smoother.STEP_TOL_M, imu_error.MAX_ITERATIONS)
    np.testing.assert_allclose(X[:, 3:6], out[2], atol=1e-12)
    assert lin.max() < imu_error.MAX_ITERATIONS and lin.mean() < 4, (lin.mean(), lin.max())
    # the reference: the same model linearised about those states by the numpy rows
    Hc, zc, Hk, zk = arm_smoother.linearise(X, inp.z, inp.q_WB, proj, arm, arm.shoulder)
    ref, ref_codes = imu_error.forward(m0, Pm0, F, b, Q, Hc, zc, seen, s.pixel_sigma**2, Hk,
                                       zk, s.constraint_sigma_m**2, s.gate_chi2,
                                       s.reacquire_frames, infl)
    np.testing.assert_array_equal(ref_codes, codes)
    np.testing.assert_allclose(ref[:, :3], X[:, :3], atol=2e-5)  # m
    np.testing.assert_allclose(ref[:, 3:6], X[:, 3:6], atol=1e-3)  # m/s


def test_correction_is_the_fold_of_the_error_terms():
    """A constant δθ, b_a: the corrected step equals the fold of R̂ f̂ + g + [s]× δθ − R̂ b_a
    held over the samples (imu_fold's derivation), to round-off."""
    inp, *_ = _session()
    imu = inp.imu
    n = inp.t.size
    th, ba = np.tile(TILT, (n, 1)), np.tile(BIAS, (n, 1))
    fixed = imu_error.corrected(inp, inp.steps, th, ba)
    R = quat.to_matrix(imu.q_WB)
    s = np.einsum("mij,mj->mi", R, imu.f_B)
    a = s + models.GRAVITY_W + np.cross(s, TILT) - np.einsum("mij,j->mi", R, BIAS)
    ref = models.composite_steps(imu.t, a, inp.t, accel_noise=1.0, imu_period=0.01)
    np.testing.assert_allclose(fixed.dv[2:], ref.dv[2:], atol=1e-12)
    np.testing.assert_allclose(fixed.dp[2:], ref.dp[2:], atol=1e-12)


@pytest.mark.parametrize("linearise", LINEARISATIONS)
def test_the_recipe_stays_a_forward_filter(linearise):
    """tao2008-pf-constraint's whole chain (the iterated Kalman pass and the particles with its
    velocity; before: particles, 8 Kalman passes, particles again): detections and IMU changed
    after frame k leave frames ≤ k bit-identical, and the later ones not."""
    from armtrack_cli.fuse import methods

    inp, first, arm, proj, _ = _session()
    s = FuseSettings(method="pf-constraint", smoother="none", imu_error="causal",
                     kalman_linearise=linearise, kalman_passes=8, kalman_velocity=1.0,
                     particles=200)
    x0, P0 = first[0], np.diag([0.03**2] * 3 + [0.05**2] * 3)
    k = 100
    z = inp.z.copy()
    z[k + 1:] += 25.0
    imu = inp.imu
    f_B = imu.f_B.copy()
    f_B[imu.t > inp.t[k] + 0.0101] += 0.5
    st = inp.steps
    dv = st.dv.copy()
    dv[k + 1:] += 0.01  # the steps the particles integrate, from the changed IMU on
    inp2 = Inputs(models.Steps(st.dt, st.dp, dv, st.q), z, inp.q_WB, t=inp.t,
                  imu=ImuSamples(imu.t, imu.q_WB, f_B, imu.w_B))
    a = methods.run("pf-constraint", inp, x0, P0, proj, s, arm)
    b = methods.run("pf-constraint", inp2, x0, P0, proj, s, arm)
    np.testing.assert_array_equal(a.mean[:k + 1], b.mean[:k + 1])
    assert np.abs(a.mean[k + 1:] - b.mean[k + 1:]).max() > 1e-3
