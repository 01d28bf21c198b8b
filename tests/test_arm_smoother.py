"""The orientation-aware arm smoother's parts against independent answers: one smoother pass
against batch least squares on a linear-Gaussian model, the IMU fold against the held-sample
steps and closed-form integrals, the linearised rows against finite differences. Its accuracy
on simulated sessions is tested in test_fuse_compare.py, studied in `make validate`."""

from __future__ import annotations

import numpy as np
import pytest

from armtrack_cli.core import quaternion as quat
from armtrack_cli.core.streams import CameraModel
from armtrack_cli.fuse import arm_smoother, arm_state, imu_fold, models
from armtrack_cli.fuse.settings import FuseSettings
from armtrack_cli.fuse.smoother_kernel import smooth


def _linear_problem(rng, n=20, d=7, f_scale=0.1, p_camera=0.7, outliers=0.0):
    """A random linear-Gaussian model in the smoother kernel's arguments (``outliers``: the
    share of camera pairs moved 50 σ, for the χ² gate)."""
    F = np.eye(d) + f_scale * rng.standard_normal((n, d, d))
    b = rng.standard_normal((n, d))
    A = rng.standard_normal((n, d, d))
    Q = A @ np.swapaxes(A, 1, 2) * 0.05 + 0.01 * np.eye(d)
    Hc, Hk = rng.standard_normal((n, 2, d)), rng.standard_normal((n, d))
    zc, zk = rng.standard_normal((n, 2)), rng.standard_normal(n)
    if outliers:
        zc[rng.random(n) < outliers] += 50.0
    use_c, use_k = rng.random(n) < p_camera, rng.random(n) < 0.5
    x0, P0 = rng.standard_normal(d), np.diag(rng.uniform(0.5, 2.0, d))
    return x0, P0, F, b, Q, Hc, zc, use_c, 0.3, Hk, zk, use_k, 0.2


def _batch(x0, P0, F, b, Q, Hc, zc, use_c, rc, Hk, zk, use_k, rk):
    """The MAP of the whole linear-Gaussian model by its normal equations, and the
    posterior covariance: the inverse of their matrix (independent of any filter)."""
    n, d = F.shape[0], x0.size
    rows, rhs, wts = [], [], []

    def add(blocks, target, info):
        row = np.zeros((target.size, n * d))
        for k, M in blocks:
            row[:, k * d:(k + 1) * d] = M
        rows.append(row)
        rhs.append(target)
        wts.append(info)

    add([(0, np.eye(d))], x0, np.linalg.inv(P0))
    for k in range(1, n):
        add([(k, np.eye(d)), (k - 1, -F[k])], b[k], np.linalg.inv(Q[k]))
    for k in range(n):
        if use_c[k]:
            add([(k, Hc[k])], zc[k], np.eye(2) / rc)
        if use_k[k]:
            add([(k, Hk[k][None])], zk[k:k + 1], np.eye(1) / rk)
    info = sum(r.T @ w @ r for r, w in zip(rows, wts))
    vec = sum(r.T @ w @ t for r, w, t in zip(rows, wts, rhs))
    cov = np.linalg.inv(info)
    return np.linalg.solve(info, vec).reshape(n, d), cov


@pytest.mark.parametrize("compiled", [True, False])
def test_one_pass_equals_batch_least_squares(compiled):
    prob = _linear_problem(np.random.default_rng(4))
    fn = smooth if compiled else smooth.py_func
    xs, Ps, gated = fn(*prob, np.inf)
    x_ref, cov = _batch(*prob)
    d = xs.shape[1]
    assert not gated.any()
    assert np.abs(xs - x_ref).max() < 1e-10
    for k in range(xs.shape[0]):
        assert np.abs(Ps[k] - cov[k * d:(k + 1) * d, k * d:(k + 1) * d]).max() < 1e-10


def test_gated_detection_is_as_if_absent():
    """A camera pair 100 σ off is not used: the result equals the smoother without it."""
    prob = list(_linear_problem(np.random.default_rng(5)))
    k = int(np.flatnonzero(prob[7])[3])
    prob[6] = prob[6].copy()
    prob[6][k] += 100 * np.sqrt(prob[8]) * 10
    xs, Ps, gated = smooth(*prob, 13.8)
    assert np.flatnonzero(gated).tolist() == [k]
    prob[7] = prob[7].copy()
    prob[7][k] = False
    xs2, Ps2, _ = smooth(*prob, np.inf)
    assert np.abs(xs - xs2).max() < 1e-12 and np.abs(Ps - Ps2).max() < 1e-12


def _imu(rng, m=300):
    t = np.arange(m) * 0.01 + 0.004
    q = quat.normalize(np.array([1.0, 0, 0, 0]) + 0.3 * rng.standard_normal((m, 4)))
    return t, q, rng.standard_normal((m, 3)) + [0, 0, 9.81]


def test_fold_by_sample_equals_the_held_steps():
    t, q, f = _imu(np.random.default_rng(1))
    tf = np.arange(0.1, 2.9, 1 / 30)
    st = models.composite_steps(t, models.accel_world(q, f), tf, accel_noise=1.0,
                                imu_period=0.01)
    fd = imu_fold.fold(t, q, f, tf, hold="sample")
    assert np.abs(fd.dp - st.dp).max() < 1e-14 and np.abs(fd.dv - st.dv).max() < 1e-14


def test_linear_hold_is_exact_for_an_acceleration_linear_in_time():
    """a(t) = a0 + a1 t: ∫ a dt and ∫ a (t_k − t) dt in closed form."""
    a0, a1 = np.array([1.0, 2, 3]), np.array([0.5, -1, 2])
    t = np.arange(0, 3, 0.01)
    q = np.tile([1.0, 0, 0, 0], (t.size, 1))
    tf = np.arange(0.1, 2.9, 1 / 30)
    fd = imu_fold.fold(t, q, a0 + a1 * t[:, None] - models.GRAVITY_W, tf, hold="linear")
    T0, T1 = tf[:-1], tf[1:]
    dv = a0 * (T1 - T0)[:, None] + a1 * ((T1**2 - T0**2) / 2)[:, None]
    prim = lambda s: (a0 * (T1 * s - s**2 / 2)[:, None]  # noqa: E731
                      + a1 * (T1 * s**2 / 2 - s**3 / 3)[:, None])
    assert np.abs(fd.dv[1:] - dv).max() < 1e-12
    assert np.abs(fd.dp[1:] - (prim(T1) - prim(T0))).max() < 1e-12


@pytest.mark.parametrize("hold", ["linear", "sample"])
def test_fold_errors_enter_as_the_derivation_says(hold):
    """A bias b in f̂ moves (dp, dv) by exactly −(B_p, B_v) b; an orientation error δθ
    (true R = exp(−[δθ]×) R̂) by (A_p, A_v) δθ to first order."""
    t, q, f = _imu(np.random.default_rng(2))
    tf = np.arange(0.1, 2.9, 1 / 30)
    base = imu_fold.fold(t, q, f, tf, hold=hold)
    bias = np.array([0.03, -0.02, 0.05])
    fb = imu_fold.fold(t, q, f - bias, tf, hold=hold)
    assert np.abs(fb.dv - base.dv + base.B_v @ bias).max() < 1e-13
    assert np.abs(fb.dp - base.dp + base.B_p @ bias).max() < 1e-13
    th = np.array([2e-4, -1e-4, 3e-4])
    qt = arm_smoother.corrected(q, np.tile(th, (t.size, 1)))
    ft = imu_fold.fold(t, qt, f, tf, hold=hold)
    scale = np.abs(base.A_v @ th).max()
    assert np.abs(ft.dv - base.dv - base.A_v @ th).max() < 1e-3 * scale
    assert np.abs(ft.dp - base.dp - base.A_p @ th).max() < 1e-3 * np.abs(base.A_p @ th).max()


def _camera():
    K = np.array([[600.0, 0, 320], [0, 610, 240], [0, 0, 1]])
    R = quat.to_matrix(quat.from_axis_angle(np.array([1.0, 0.2, 0]) / np.hypot(1, 0.2), 2.0))
    return models.Projection(CameraModel(K=K, dist=np.array([-0.2, 0.05, 0.001, -0.002, 0.01]),
                                         R_WC=R, T_WC=np.array([0.1, 0.2, 1.2]), width=640,
                                         height=480))


@pytest.mark.parametrize("drifting", [False, True])
def test_linearised_rows_match_finite_differences(drifting):
    rng = np.random.default_rng(3)
    proj = _camera()
    arm = models.Arm(shoulder=np.array([0.0, 0.3, 0.35]), L1=0.3, L2=0.28,
                     forearm_B=np.array([1.0, 0, 0]))
    n, d = 4, 16 if drifting else 12  # drifting: (ℓ, S) at 12:16
    X = np.zeros((n, d))
    X[:, :3] = [0.25, 0.2, 0.1] + 0.03 * rng.standard_normal((n, 3))
    X[:, 6:9] = 0.01 * rng.standard_normal((n, 3))
    if drifting:
        X[:, 13:16] = arm.shoulder + 0.01 * rng.standard_normal((n, 3))
    q = quat.normalize(rng.standard_normal((n, 4)))
    if drifting:
        X[:, 12] = 0.02 * rng.standard_normal(n)  # ℓ, the upper arm's length change
    z = proj(X[:, :3]) + 1.0
    Hc, zc, Hk, zk = arm_smoother.linearise(X, z, q, proj, arm, None if drifting else arm.shoulder)

    def residuals(Y):
        u = arm_smoother.forearm(q, Y[:, 6:9], arm)
        S, ell = (Y[:, 13:16], Y[:, 12]) if drifting else (arm.shoulder, 0.0)
        return proj(Y[:, :3]), np.linalg.norm(Y[:, :3] - arm.L2 * u - S, axis=1) - arm.L1 - ell

    h0, r0 = residuals(X)
    assert np.abs(zc - (z - h0 + np.einsum("kij,kj->ki", Hc, X))).max() < 1e-9
    for j in range(d):
        dX = np.zeros_like(X)
        dX[:, j] = 1e-6
        (hp, rp), (hm, rm) = residuals(X + dX), residuals(X - dX)
        assert np.allclose((hp - hm) / 2e-6, Hc[:, :, j], rtol=1e-5, atol=1e-3)
        # ∂u/∂δθ = [u]× is the derivative at δθ = 0; at |δθ| ~ 1° it is within a few %
        assert np.allclose((rp - rm) / 2e-6, Hk[:, j], rtol=0.05, atol=1e-6)


def test_process_is_gauss_markov_with_the_stated_spread():
    """δθ's stationary SD is orientation_sd_deg (tilt) and heading_sd_deg (about z) whatever
    the frame interval; the drifting arm's (ℓ, S) are random walks: unchanged in the mean,
    their variance grown by rate² × dt, starting at the declared arm with the stated SDs."""
    s = FuseSettings(orientation_sd_deg=0.8, heading_sd_deg=1.2, orientation_tau_s=1.5,
                     shoulder_sd_m=0.02, shoulder_walk_m_s=0.01, upper_arm_sd_m=0.03,
                     upper_arm_walk_m_s=0.02)
    t, q, f = _imu(np.random.default_rng(6))
    fd = imu_fold.fold(t, q, f, np.arange(0.1, 2.9, 1 / 30))
    S0 = np.array([0.1, 0.2, 0.3])
    F, b, Q = arm_state.process(fd, s, S0, 0.01)
    var = np.diag(np.deg2rad([0.8, 0.8, 1.2]) ** 2)
    k = 5
    assert np.allclose(F[k, 6:9, 6:9] @ var @ F[k, 6:9, 6:9].T + Q[k, 6:9, 6:9], var,
                       rtol=1e-12, atol=0)
    x = np.r_[np.zeros(12), 0.01, S0]
    assert F.shape[1:] == (16, 16)
    assert np.allclose((F[k] @ x + b[k])[12:], x[12:], rtol=1e-12)
    dt = fd.dt[k]
    assert np.allclose(Q[k, 12:, 12:], np.diag([0.02**2] + [0.01**2] * 3) * dt, rtol=1e-12)
    assert np.allclose(Q[k, 12:, :12], 0.0)
    m, P = arm_smoother.prior(np.zeros(6), np.eye(6) * 1e-4, s, S0)
    assert np.allclose(m[12:], x[12:] - [0.01, 0, 0, 0])
    assert np.allclose(np.diag(P)[12:], [0.03**2] + [0.02**2] * 3)


def _process_by_blocks(fd, s, shoulder, period, track, camera):
    """F, b, Q as the docstring's blocks say, each written whole: dt·I, [s]× (imu_fold.skew),
    the walks' q·dt³/3·I …: the reference process() is held to bit for bit."""
    n = fd.dt.size
    d = arm_state.state_size(track is not None, camera, shoulder is not None)
    dt, eye = fd.dt[:, None, None], np.eye(3)
    P, V, T, A, G = (slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12), slice(12, 15))
    F, b, Q = np.tile(np.eye(d), (n, 1, 1)), np.zeros((n, d)), np.zeros((n, d, d))
    F[:, P, V], F[:, P, T], F[:, V, T] = dt * eye, imu_fold.skew(fd.s_p), imu_fold.skew(fd.s_v)
    F[:, P, A], F[:, V, A] = -fd.B_p, -fd.B_v
    b[:, P], b[:, V] = fd.dp, fd.dv
    q = s.smoother_accel_noise**2 * period
    Q[:, P, P], Q[:, V, V] = q * dt**3 / 3 * eye, q * dt * eye
    Q[:, P, V] = Q[:, V, P] = q * dt**2 / 2 * eye
    if track is not None:
        b[:, T], F[:, T, G] = track.dtheta, track.G
        Q[:, T, T] = np.deg2rad(s.orientation_walk_deg) ** 2 * dt * eye
        Q[:, G, G] = np.deg2rad(s.gyro_bias_walk_deg_s) ** 2 * dt * eye
    else:
        phi = np.exp(-dt / s.orientation_tau_s)
        F[:, T, T] = phi * eye
        Q[:, T, T] = arm_state.orientation_var(s) * (1 - phi**2)
    Q[:, A, A] = s.accel_bias_walk**2 * dt * eye
    if shoulder is not None:
        Q[:, d - 4:, d - 4:] = arm_state.drift_noise(fd.dt, s)
    return F, b, Q


@pytest.mark.parametrize("gyro", [True, False])
@pytest.mark.parametrize("drifting", [True, False])
@pytest.mark.parametrize("camera", [True, False])
def test_process_writes_the_blocks_to_the_bit(gyro, drifting, camera):
    """process() writes only the non-zero entries of its diagonal and cross-product blocks:
    F, b, Q byte for byte those of the blocks written whole; noise=False: F, b alone."""
    t = np.arange(0, 6, 0.01)
    q_hat, w_B, _ = _turning(t, np.deg2rad([0.4, -0.3, 0.5]))
    tf = np.arange(0.05, 5.9, 1 / 30) + np.random.default_rng(2).uniform(0, 1e-3, 176)
    fd = imu_fold.fold(t, q_hat, np.tile([0.3, -0.2, 9.81], (t.size, 1)), tf)
    track = imu_fold.orientation_track(t, q_hat, w_B, tf) if gyro else None
    S0 = np.array([0.1, 0.2, 0.3]) if drifting else None
    s = FuseSettings()
    got = arm_state.process(fd, s, S0, 0.01, track, camera)
    ref = _process_by_blocks(fd, s, S0, 0.01, track, camera)
    assert all(g.tobytes() == r.tobytes() for g, r in zip(got, ref))
    bare = arm_state.process(fd, s, S0, 0.01, track, camera, noise=False)
    assert len(bare) == 2 and all(g.tobytes() == r.tobytes() for g, r in zip(bare, ref))


def _turning(t, bias):
    """A body turning about a changing axis (closed form), its output orientation turned by a
    smooth known error δθ(t), and the gyro of the true rotation plus ``bias``: (q̂, ω̂, δθ)."""
    def q_at(s):
        return quat.from_euler_zyx(0.3 * np.cos(0.7 * s), 0.5 * s, 0.8 * np.sin(1.3 * s))

    h = 1e-5
    dq = quat.multiply(quat.conjugate(q_at(t - h)), q_at(t + h))  # body rotation over 2h
    w_B = dq[:, 1:] * np.sign(dq[:, :1]) / h
    th = np.deg2rad(np.stack([np.sin(0.5 * t), 0.7 * np.cos(0.3 * t), 0.5 * np.sin(0.9 * t + 1)],
                             -1))
    ang = np.linalg.norm(th, axis=1)
    q_hat = quat.multiply(quat.from_axis_angle(th / ang[:, None], ang), q_at(t))
    return q_hat, w_B + bias, th


def test_orientation_track_follows_a_known_error_and_bias():
    """The gyro against the output orientation measures how the orientation error changes:
    with the error's start and the gyro's bias known, the process's δθ rows carry the error
    along a turning body to within 3 % of its change (the term dropped is second order:
    about |δθ|/2 ≈ 1 % of the change at δθ ~ 1.5°)."""
    t = np.arange(0, 6, 0.01)
    bias = np.deg2rad([0.4, -0.3, 0.5])
    q_hat, w_B, th = _turning(t, bias)
    tf = np.arange(0.05, 5.9, 1 / 30)
    track = imu_fold.orientation_track(t, q_hat, w_B, tf)
    fd = imu_fold.fold(t, q_hat, np.tile([0, 0, 9.81], (t.size, 1)), tf)
    F, b, Q = arm_state.process(fd, FuseSettings(), None, 0.01, track)
    assert F.shape[1:] == (15, 15)
    th_f = np.stack([np.interp(tf, t, th[:, i]) for i in range(3)], -1)
    x = np.zeros(15)
    x[6:9], x[12:15] = th_f[0], bias
    err = []
    for k in range(1, tf.size):
        x = F[k] @ x + b[k]
        err.append(x[6:9] - th_f[k])
    change = np.abs(th_f - th_f[0]).max()
    assert np.abs(err).max() < 0.03 * change, (np.abs(err).max(), change)
    # without the bias term the error grows with the bias × time: the state is needed
    drift = np.cumsum(b[1:, 6:9], axis=0) + th_f[0] - th_f[1:]
    assert np.abs(drift).max() > 20 * np.abs(err).max()


def test_without_a_gyro_the_orientation_error_is_gauss_markov():
    """A file without a gyroscope (NaN) gives the 12-state smoother with δθ Gauss–Markov."""
    t = np.arange(0, 3, 0.01)
    imu = arm_smoother.ImuSamples(t, np.tile([1.0, 0, 0, 0], (t.size, 1)),
                                  np.tile([0, 0, 9.81], (t.size, 1)), np.full((t.size, 3), np.nan))
    assert not imu.gyro()
    assert arm_smoother.ImuSamples(t, imu.q_WB, imu.f_B, np.zeros((t.size, 3))).gyro()


def test_pre_roll_reaches_back_over_the_imu_recorded_before_the_video():
    """With the rest update on, the smoother starts where the IMU starts (at most pre_roll_s
    before the first frame), at the video's rate, with no detections and the first pass's
    start at rest; with it off, nothing is added."""
    t = np.arange(-0.5, 3.0, 0.01)
    q = np.tile([1.0, 0, 0, 0], (t.size, 1))
    imu = arm_smoother.ImuSamples(t, q, np.tile([0, 0, 9.81], (t.size, 1)), np.zeros((t.size, 3)))
    tf = np.arange(0, 2, 1 / 30)
    z = np.full((tf.size, 2), 100.0)
    first = np.tile([0.1, 0.2, 0.3, 0.01, 0.02, 0.03], (tf.size, 1))
    on = FuseSettings(rest_velocity_sd_m_s=0.01, pre_roll_s=1.0)
    m, t2, z2, q2, first2 = arm_smoother.pre_roll(imu, tf, z, q[:tf.size], first, on)
    assert m == 15  # 0.5 s of IMU before the video, at 30 frames/s
    np.testing.assert_allclose(t2[:m], -0.5 + np.arange(15) / 30, atol=1e-12)
    assert np.isnan(z2[:m]).all() and np.array_equal(z2[m:], z) and np.isfinite(q2).all()
    np.testing.assert_allclose(first2[:m], [[0.1, 0.2, 0.3, 0, 0, 0]] * m)
    short = FuseSettings(rest_velocity_sd_m_s=0.01, pre_roll_s=0.2)
    assert arm_smoother.pre_roll(imu, tf, z, q[:tf.size], first, short)[0] == 6
    assert arm_smoother.pre_roll(imu, tf, z, q[:tf.size], first, FuseSettings())[0] == 0


def _matrix_form(x0, P0, F, b, Q, Hc, zc, use_c, rc, Hk, zk, use_k, rk, gate):
    """The pass in smoother_kernel's matrix-form steps (_filter_step, _rts_step), run by
    Python: the arithmetic the in-place passes replaced."""
    from armtrack_cli.fuse.smoother_kernel import _filter_step, _rts_step

    n = F.shape[0]
    xs, Ps, gated = np.empty((n, x0.size)), np.empty((n, x0.size, x0.size)), np.zeros(n, bool)
    x, P = x0.copy(), P0.copy()
    for k in range(n):
        x, P, gated[k] = _filter_step.py_func(x, P, F[k], b[k], Q[k], Hc[k], zc[k], use_c[k], rc,
                                              Hk[k], zk[k], use_k[k], rk, gate, k > 0)
        xs[k], Ps[k] = x, P
    for k in range(n - 2, -1, -1):
        xs[k], Ps[k] = _rts_step.py_func(xs[k], Ps[k], F[k + 1], b[k + 1], Q[k + 1], xs[k + 1],
                                         Ps[k + 1])
    return xs, Ps, gated


@pytest.mark.parametrize("d", [6, 12, 15])
def test_in_place_pass_equals_the_matrix_form(d):
    """The allocation-free kernel (work arrays, loops) against the matrix-form steps, with
    gated outliers and the arm row: means within 1e-9 m, covariances within 1e-12."""
    x0, P0, F, b, Q, Hc, zc, use_c, _, Hk, zk, use_k, _ = _linear_problem(
        np.random.default_rng(d), 400, d, f_scale=0.05, p_camera=0.8, outliers=0.05)
    args = (x0, P0, F, b, Q, Hc, zc, use_c, 0.3, Hk, zk, use_k, 0.2, 9.0)
    xs, Ps, gated = smooth(*args)
    xr, Pr, gr = _matrix_form(*args)
    assert gr.sum() > 3 and np.array_equal(gated, gr)
    assert np.abs(xs - xr).max() < 1e-9 and np.abs(Ps - Pr).max() < 1e-12


def test_elbow_variance_is_the_diagonal_of_j_p_jt():
    """_elbow_var from P's (p, δθ) blocks equals the diagonal of J P Jᵀ with the elbow's full
    Jacobian J = [I, 0, −L2 [u]×, 0 …] (eq. 2) to 1e-12, on random covariances and
    orientations, and on a covariance with no δθ part is P_pp's diagonal exactly."""
    rng = np.random.default_rng(8)
    n, d = 50, 15
    A = rng.normal(size=(n, d, d))
    P = A @ np.swapaxes(A, 1, 2) * 1e-4
    x = rng.normal(size=(n, d)) * 0.02
    q = quat.normalize(rng.normal(size=(n, 4)))
    arm = models.Arm(shoulder=np.array([0.1, 0.5, 0.3]), L1=0.31, L2=0.27,
                     forearm_B=np.array([0.0, 1.0, 0.0]))
    u = quat.rotate(arm_smoother.corrected(q, x[:, 6:9]), arm.forearm_B)
    J = np.zeros((n, 3, d))
    J[:, :, :3] = np.eye(3)
    ux = np.swapaxes(np.cross(u[:, None, :], np.eye(3)[None]), 1, 2)  # column j: u × e_j
    J[:, :, 6:9] = -arm.L2 * ux
    ref = np.diagonal(J @ P @ np.swapaxes(J, 1, 2), axis1=1, axis2=2)
    got = arm_smoother._elbow_var(q, x, P, arm)
    assert np.abs(got - ref).max() <= 1e-12 * np.abs(ref).max()
    P[:, 6:9, :] = P[:, :, 6:9] = 0.0
    assert np.array_equal(arm_smoother._elbow_var(q, x, P, arm),
                          np.diagonal(P[:, :3, :3], axis1=1, axis2=2))


def test_corrected_is_the_error_rotation_removed_in_any_chunks(monkeypatch):
    """corrected(q̂, δθ) = exp(−[δθ]×) R̂ (Rodrigues' closed form, independent of the
    quaternion code) to 1e-12; taken quat.ROWS_AT_ONCE rows at a time (memory), the same
    numbers as all at once, bit for bit; δθ = 0 leaves q̂'s rotation as it is."""
    rng = np.random.default_rng(9)
    q = quat.normalize(rng.normal(size=(17, 4)))
    th = 0.05 * rng.normal(size=(17, 3))
    th[3] = 0.0
    whole = arm_smoother.corrected(q, th)
    monkeypatch.setattr(quat, "ROWS_AT_ONCE", 4)
    assert np.array_equal(arm_smoother.corrected(q, th), whole)
    for k in range(17):
        a = np.linalg.norm(th[k])
        K = imu_fold.skew(th[k] / a) if a > 0 else np.zeros((3, 3))
        E = np.eye(3) - np.sin(a) * K + (1 - np.cos(a)) * K @ K  # exp(−a [u]×)
        np.testing.assert_allclose(quat.to_matrix(whole[k]), E @ quat.to_matrix(q[k]),
                                   rtol=0, atol=1e-12)
