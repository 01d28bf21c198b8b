"""The checkpointed smoother (fuse/smoother_blocks.py) against the plain pass it replaces
(fuse/smoother_kernel.smooth, itself tested against batch least squares in
test_arm_smoother.py): the same means, covariances and gate decisions, for block sizes that do
and do not divide the session, on a random linear model with outliers and on a session's own
linearised arm-smoother model."""

from __future__ import annotations

import numpy as np
import pytest

from armtrack_cli.core import quaternion as quat
from armtrack_cli.core.streams import CameraModel
from armtrack_cli.fuse import arm_smoother, arm_state, imu_fold, models, rest, smoother_blocks
from armtrack_cli.fuse.settings import FuseSettings
from armtrack_cli.fuse.smoother_blocks import smooth_blocked
from armtrack_cli.fuse.smoother_kernel import smooth
from tests.test_arm_smoother import _linear_problem


def _random_problem(rng, n=700, d=6):
    x0, P0, F, b, Q, Hc, zc, use_c, _, Hk, zk, use_k, _ = _linear_problem(
        rng, n, d, f_scale=0.05, p_camera=0.8, outliers=0.05)
    return x0, P0, (F, b, Q, Hc, zc, use_c, Hk, zk, use_k)


def _blocked(x0, P0, arrays, rc, rk, gate, block, store_mb=smoother_blocks.STORE_MB):
    n, d = arrays[0].shape[0], x0.size
    xs, Ps = np.full((n, d), np.nan), np.full((n, d, d), np.nan)

    def keep(lo, hi, x, P):
        xs[lo:hi], Ps[lo:hi] = x, P

    def model(lo, hi, steps_only=False):
        return tuple(a[lo:hi] for a in (arrays[:3] if steps_only else arrays))

    gated = smooth_blocked(x0, P0, model, n, rc=rc,
                           rk=rk, gate=gate, keep=keep, block=block, store_mb=store_mb)
    return xs, Ps, gated


def _plain(x0, P0, arrays, rc, rk, gate):
    F, b, Q, Hc, zc, use_c, Hk, zk, use_k = arrays
    return smooth(x0, P0, F, b, Q, Hc, zc, use_c, rc, Hk, zk, use_k, rk, gate)


# the store: every block's filtered states (the default at this size), none (each block
# filtered again from its checkpoint), and about 250 of the 700 rows (the latest blocks kept)
STORES = [smoother_blocks.STORE_MB, 0.0, 250 * 8 * (6 + 21) / 2**20]


@pytest.mark.parametrize("store_mb", STORES)
@pytest.mark.parametrize("block", [1, 64, 100, 700, 5000])
def test_blocks_equal_the_plain_pass_on_a_random_model(block, store_mb):
    x0, P0, arrays = _random_problem(np.random.default_rng(3))
    xs, Ps, gated = _plain(x0, P0, arrays, 0.3, 0.2, 9.0)
    xb, Pb, gb = _blocked(x0, P0, arrays, 0.3, 0.2, 9.0, block, store_mb)
    assert gated.sum() > 10 and np.array_equal(gb, gated)
    assert np.abs(xb - xs).max() < 1e-9 and np.abs(Pb - Ps).max() < 1e-9


def test_blocks_equal_the_plain_pass_on_a_session_model():
    """The arm smoother's own model (IMU fold with the gyro's orientation track, the camera
    and arm rows linearised about a trajectory) over 40 s at 30 fps: positions within 1e-9 m."""
    rng = np.random.default_rng(8)
    t = np.arange(0, 40, 0.01)
    q = quat.normalize(np.array([1.0, 0.1, 0, 0]) + 0.02 * rng.standard_normal((t.size, 4)))
    f = rng.standard_normal((t.size, 3)) * 0.5 + [0, 0, 9.81]
    w = rng.standard_normal((t.size, 3)) * 0.1
    tf = np.arange(0.05, 39.9, 1 / 30)
    n = tf.size
    s = FuseSettings()
    fd = imu_fold.fold(t, q, f, tf, hold=s.imu_hold)
    track = imu_fold.orientation_track(t, q, w, tf)
    F, b, Q = arm_state.process(fd, s, None, 0.01, track)
    cam = models.Projection(_camera())
    arm = models.Arm(shoulder=np.array([0.1, 0.5, 0.3]), L1=0.3, L2=0.27,
                     forearm_B=np.array([0.0, 1.0, 0.0]))
    X = np.zeros((n, 15))
    X[:, :3] = [0.3, 0.2, 0.1] + 0.05 * np.sin(tf)[:, None]
    X[:, 3:6] = 0.05 * np.cos(tf)[:, None]
    z = cam(X[:, :3]) + rng.standard_normal((n, 2))
    z[rng.random(n) < 0.1] = np.nan
    Hc, zc, Hk, zk = arm_smoother.linearise(X, z, q[::3][:n], cam, arm, arm.shoulder)
    arrays = (F, b, Q, Hc, zc, np.isfinite(z).all(axis=1), Hk, zk, np.ones(n, bool))
    x0, P0 = arm_smoother.prior(np.r_[X[0, :6]], np.eye(6) * 0.01, s, None, True)
    xs, Ps, gated = _plain(x0, P0, arrays, 4.0, 1e-4, 13.8)
    xb, Pb, gb = _blocked(x0, P0, arrays, 4.0, 1e-4, 13.8, 256)
    assert np.array_equal(gb, gated)
    assert np.abs(xb[:, :3] - xs[:, :3]).max() < 1e-9
    assert np.abs(xb - xs).max() < 1e-9 and np.abs(Pb - Ps).max() < 1e-12


def _camera():
    K = np.array([[600.0, 0, 320], [0, 600, 240], [0, 0, 1]])
    R = np.array([[1.0, 0, 0], [0, -1, 0], [0, 0, -1]])  # looking down at the table
    return CameraModel(K=K, dist=np.array([-0.2, 0.05, 0.001, -0.002, 0.01]), width=640,
                       height=480, R_WC=R, T_WC=-R @ np.array([0.3, 0.2, 1.0]))


@pytest.mark.parametrize("hold", ["sample", "linear"])
def test_fold_in_chunks_equals_one_chunk(hold, monkeypatch):
    """imu_fold.fold a few frames at a time (each chunk's pieces cut from the IMU's and the
    frames' times afresh) equals the fold of all pieces at once."""
    rng = np.random.default_rng(2)
    t = np.arange(0, 5, 0.01) + 0.003
    q = quat.normalize(np.array([1.0, 0.2, 0, 0]) + 0.1 * rng.standard_normal((t.size, 4)))
    f = rng.standard_normal((t.size, 3)) + [0, 0, 9.81]
    tf = np.arange(0.1, 4.9, 1 / 30)
    whole = imu_fold.fold(t, q, f, tf, hold=hold)
    monkeypatch.setattr(imu_fold, "FOLD_FRAMES", 7)
    parts = imu_fold.fold(t, q, f, tf, hold=hold)
    for name in ("dp", "dv", "A_p", "A_v", "B_p", "B_v"):
        assert np.abs(getattr(parts, name) - getattr(whole, name)).max() < 1e-14, name


def _plain_run(imu, tf, z, q_hat, first, x0, P0, cam, s, arm):
    """arm_smoother.run as one plain pass over the whole session (smoother_kernel.smooth on
    every frame's arrays at once, the zero-velocity rows inserted by rest.with_rows over the
    whole session): the form the checkpointed pass replaced, its reference."""
    m_pre, tf, z, q_hat, first = arm_smoother.pre_roll(imu, tf, z, q_hat, first, s)
    fd = imu_fold.fold(imu.t, imu.q_WB, imu.f_B, tf, hold=s.imu_hold)
    track = imu_fold.orientation_track(imu.t, imu.q_WB, imu.w_B, tf)
    F, b, Q = arm_state.process(fd, s, None, float(np.median(np.diff(imu.t))), track)
    m0, Pm0 = arm_smoother.prior(x0, P0, s, None, True)
    X = np.zeros((tf.size, m0.size))
    X[:, :6] = first
    still = arm_smoother.resting(imu, tf, z, s, m_pre)
    rk = s.constraint_sigma_m**2
    step = np.inf
    for _ in range(s.smoother_iterations):
        Hc, zc, Hk, zk = arm_smoother.linearise(X, z, q_hat, cam, arm, arm.shoulder)
        ins = rest.with_rows(still, s.rest_velocity_sd_m_s, rk, F, b, Q, Hc, zc,
                             np.isfinite(z).all(axis=1), Hk, zk, np.ones(tf.size, bool))
        Xn, _, _ = smooth(m0, Pm0, *ins.arrays[:6], s.pixel_sigma**2, *ins.arrays[6:], rk,
                          s.gate_chi2)
        previous, step = step, np.abs(Xn[ins.real, :3] - X[:, :3]).max()
        X = Xn[ins.real]
        if arm_smoother.converged(step, previous):
            break
    return X[m_pre:], still[m_pre:].sum()


@pytest.mark.parametrize("store_mb", STORES)
def test_rest_rows_inserted_per_block_equal_the_plain_pass(store_mb, monkeypatch):
    """The arm smoother with the rest update (zero-velocity rows after each resting frame,
    fuse/rest.py), run block by block with blocks that end inside and at the edges of rest
    runs, equals the plain pass over the whole session to 1e-9 m, whether the backward pass
    takes a block's filtered states from the store (its model's steps alone) or filters it
    again."""
    rng = np.random.default_rng(5)
    t = np.arange(0, 20, 0.01)
    moving = ((t > 4) & (t < 9)) | (t > 14)
    q = quat.normalize(np.array([1.0, 0.1, 0, 0]) + np.where(
        moving[:, None], 0.02 * np.sin(t)[:, None], 0.0) + 1e-4 * rng.standard_normal((t.size, 4)))
    f = np.where(moving[:, None], 0.5 * rng.standard_normal((t.size, 3)), 0.01 * rng.standard_normal(
        (t.size, 3))) + [0, 0, 9.81]
    w = np.where(moving[:, None], 0.3, 0.005) * rng.standard_normal((t.size, 3))
    tf = np.arange(1.2, 19.9, 1 / 30)
    cam = models.Projection(_camera())
    arm = models.Arm(shoulder=np.array([0.1, 0.5, 0.3]), L1=0.3, L2=0.27,
                     forearm_B=np.array([0.0, 1.0, 0.0]))
    first = np.zeros((tf.size, 6))
    go = np.interp(tf, t, moving.astype(float)) > 0
    first[:, :3] = [0.3, 0.2, 0.1] + 0.05 * np.where(go, np.sin(tf), np.sin(4.0))[:, None]
    z = cam(first[:, :3]) + 0.1 * rng.standard_normal((tf.size, 2))
    z[rng.random(tf.size) < 0.05] = np.nan
    imu = arm_smoother.ImuSamples(t, q, f, w)
    q_hat = quat.interpolate(t, q, tf)
    s = FuseSettings(rest_velocity_sd_m_s=0.05, smoother_iterations=3)
    x0, P0 = first[0], np.eye(6) * 0.01
    ref, n_rest = _plain_run(imu, tf, z, q_hat, first, x0, P0, cam, s, arm)
    assert n_rest > 100  # resting frames, in runs that the blocks below cut
    monkeypatch.setattr(arm_smoother, "smooth_blocked",
                        lambda *a, **k: smooth_blocked(*a, **k, block=37, store_mb=store_mb))
    got = arm_smoother.run(imu, tf, z, q_hat, first, x0, P0, cam, s, arm)
    assert got.x.shape[0] == tf.size
    assert np.abs(got.x[:, :3] - ref[:, :3]).max() < 1e-9


def test_orientation_track_in_chunks_equals_one_chunk(monkeypatch):
    """∫R dt and the gyro's orientation track summed a few IMU intervals at a time (the sum
    carried across chunks) equal one sum over the whole recording, bit for bit."""
    rng = np.random.default_rng(4)
    t = np.arange(0, 5, 0.01) + 0.003
    q = quat.normalize(np.array([1.0, 0.2, 0, 0]) + 0.1 * rng.standard_normal((t.size, 4)))
    w = rng.standard_normal((t.size, 3))
    tf = np.arange(0.1, 4.9, 1 / 30)
    whole = imu_fold.orientation_track(t, q, w, tf), imu_fold.rotation_integral(t, q)
    monkeypatch.setattr(imu_fold, "FOLD_CHUNK", 7)
    parts = imu_fold.orientation_track(t, q, w, tf), imu_fold.rotation_integral(t, q)
    assert np.array_equal(parts[0].dtheta, whole[0].dtheta)
    assert np.array_equal(parts[0].G, whole[0].G) and np.array_equal(parts[1], whole[1])


@pytest.mark.parametrize("chunk", [1, 3, 4096])
def test_steps_in_place_are_np_diffs(monkeypatch, chunk):
    """orientation_track's steps taken in place, FOLD_FRAMES rows at a time from the last:
    np.diff's rows after a row of zeros, bit for bit, whatever the chunk."""
    rng = np.random.default_rng(8)
    monkeypatch.setattr(imu_fold, "FOLD_FRAMES", chunk)
    for shape in ((11, 3), (11, 3, 3), (1, 3)):
        y = rng.normal(size=shape) * 1e3
        ref = np.concatenate([np.zeros((1,) + shape[1:]), np.diff(y, axis=0)])
        assert np.array_equal(imu_fold._steps_in_place(y.copy()), ref)
