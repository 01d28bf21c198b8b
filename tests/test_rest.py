"""The hand at rest (fuse/rest.py): the detector against a stream whose still and moving
spans are known by construction, and the zero-velocity rows, inserted as zero-length steps,
against the batch least-squares answer of the same model with those rows (independent of any
filter)."""

from __future__ import annotations

import numpy as np

from armtrack_cli.fuse import rest
from armtrack_cli.fuse.smoother_kernel import smooth
from tests.test_arm_smoother import _batch, _linear_problem


def _stream(rng):
    """IMU at 100 Hz and the patch at 30 fps over 3 s: still on [0, 1.02) s, turning at
    0.5 rad/s on [1.02, 2.02), then the IMU still again while the patch slides 10 px/s."""
    t = np.arange(0, 3.0, 0.01)
    w = 0.003 * rng.standard_normal((t.size, 3))
    w[(t >= 1.02) & (t < 2.02), 2] += 0.5
    f = np.array([0.0, 0.0, 9.81]) + 0.02 * rng.standard_normal((t.size, 3))
    tf = np.arange(0, 3.0, 1 / 30)
    z = np.c_[320 + 10 * np.clip(tf - 2.02, 0, None), 240 + 0 * tf] + 0.2 * rng.standard_normal(
        (tf.size, 2))
    return t, f, w, tf, z


def test_rest_is_found_where_everything_is_still_and_nowhere_else():
    t, f, w, tf, z = _stream(np.random.default_rng(0))
    test = rest.RestTest(window_s=0.3)
    found = rest.rest_frames(t, f, w, tf, z, test)
    # still: the whole ±0.15 s window inside [0, 1.02) (and inside the recording)
    expected = (tf - 0.15 >= 0) & (tf + 0.15 < 1.02)
    assert np.array_equal(found, expected)
    # a detection missing within the window: that frame's neighbours are not at rest
    z2 = z.copy()
    z2[15] = np.nan
    found2 = rest.rest_frames(t, f, w, tf, z2, test)
    near = np.abs(tf - tf[15]) <= 0.15
    assert not found2[near].any() and np.array_equal(found2[~near], expected[~near])


def test_zero_velocity_rows_equal_the_batch_answer_with_those_rows():
    """Inserted steps (F = I, Q = 0) carrying v = 0 ± σ are the same model as three more
    rows on the rest frame itself: the smoother's result at the real frames equals the
    normal equations' with those rows, to 1e-9."""
    prob = _linear_problem(np.random.default_rng(7), n=12, d=7)
    x0, P0, F, b, Q, Hc, zc, use_c, rc, Hk, zk, use_k, rk = prob
    still = np.zeros(12, bool)
    still[[0, 4, 5, 11]] = True
    sd = 0.05
    ins = rest.with_rows(still, sd, rk, F, b, Q, Hc, zc, use_c, Hk, zk, use_k)
    xs, Ps, gated = smooth(x0, P0, *ins.arrays[:6], rc, *ins.arrays[6:], rk, np.inf)
    assert ins.real.sum() == 12 and ins.real.size == 12 + 3 * 4
    # the reference: each rest frame's three rows, as frames of their own with no motion
    # between, is what with_rows builds; here the batch takes them as rows of the frame itself
    x_ref, cov = _batch_with_velocity(prob, still, sd)
    assert np.abs(xs[ins.real] - x_ref).max() < 1e-9
    d = 7
    for i, k in enumerate(np.flatnonzero(ins.real)):
        assert np.abs(Ps[k] - cov[i * d:(i + 1) * d, i * d:(i + 1) * d]).max() < 1e-9


def _batch_with_velocity(prob, still, sd):
    """The batch MAP with v_k = 0 ± sd on the rest frames: the rows added to the normal
    equations of test_arm_smoother._batch's model (information adds)."""
    x0, P0, F, b, Q, Hc, zc, use_c, rc, Hk, zk, use_k, rk = prob
    n, d = F.shape[0], x0.size
    _, cov = _batch(*prob)
    info = np.linalg.inv(cov)
    x, _ = _batch(*prob)
    vec = info @ x.ravel()
    for k in np.flatnonzero(still):
        for a in range(3, 6):
            info[k * d + a, k * d + a] += 1 / sd**2  # row e_a, target 0
    cov2 = np.linalg.inv(info)
    return (cov2 @ vec).reshape(n, d), cov2


def test_before_the_video_the_imu_alone_decides():
    """Steps before the first frame (the IMU recorded before the video) have no patch: rest
    there is the IMU's test alone, over a window twice as long, cut at the IMU's first
    sample (t = 0: the window [max(t - 0.3, 0), t + 0.3] holds at least 0.3 s); from the
    video on, the patch's window is the video's."""
    t, f, w, tf, z = _stream(np.random.default_rng(1))
    z2 = z.copy()
    z2[:12] = np.nan  # the video starts at frame 12, t = 0.4 s
    found = rest.rest_frames(t, f, w, tf, z2, rest.RestTest(window_s=0.3), video_from=12)
    imu_only = tf + 0.3 < 1.02
    on_video = (tf - 0.15 >= tf[12] - 1e-9) & (tf + 0.15 < 1.02)
    assert found[:12].any() and np.array_equal(found[:12], imu_only[:12])
    assert np.array_equal(found[12:], on_video[12:])


def test_a_hand_resting_only_in_the_imus_first_samples_is_found_there():
    """A trial whose hand rests in the IMU's first 0.4 s and moves (gyro at 0.5 rad/s) from
    then on, the video starting at 0.5 s: before the video, the frames whose window cut at
    the IMU's first sample lies in the still span (t + 0.3 < 0.4) are at rest — the whole
    0.6 s window (the rule before the cut) fits nowhere there; none after."""
    rng = np.random.default_rng(5)
    t = np.arange(0, 2.0, 0.01)
    w = 0.003 * rng.standard_normal((t.size, 3))
    w[t >= 0.4, 2] += 0.5
    f = np.array([0.0, 0.0, 9.81]) + 0.02 * rng.standard_normal((t.size, 3))
    tf = np.arange(0, 2.0, 1 / 30)
    z = np.c_[320 + 0 * tf, 240 + 0 * tf]
    z[:15] = np.nan  # the video starts at frame 15, t = 0.5 s
    found = rest.rest_frames(t, f, w, tf, z, rest.RestTest(window_s=0.3), video_from=15)
    assert np.array_equal(found, tf + 0.3 < 0.4) and found.sum() == 3


def test_the_accelerometer_is_judged_by_its_rms_over_the_window():
    """A resting hand whose accelerometer shows brief peaks above the threshold (every 10th
    sample 0.25 m/s² off g: RMS 0.08) is at rest; the same stream with a steady 0.3 m/s²
    push on [1.5, 2.5) s (the hand starting to move, the gyro quiet) is not where the push
    fills half the window or more (RMS ≥ 0.3/√2 > 0.15)."""
    rng = np.random.default_rng(3)
    t = np.arange(0, 3.0, 0.01)
    w = 0.003 * rng.standard_normal((t.size, 3))
    f0 = np.tile([0.0, 0.0, 9.81], (t.size, 1))
    f = f0.copy()
    f[::10, 2] += 0.25
    tf = np.arange(0, 3.0, 1 / 30)
    z = np.c_[320 + 0 * tf, 240 + 0 * tf]
    test = rest.RestTest(window_s=0.3)
    covered = rest.rest_frames(t, f0, w, tf, z, test)  # the same hand without the peaks
    assert covered[(tf > 0.2) & (tf < 2.8)].all()
    assert np.array_equal(rest.rest_frames(t, f, w, tf, z, test), covered)
    f2 = f.copy()
    f2[(t >= 1.5) & (t < 2.5), 2] += 0.3
    found = rest.rest_frames(t, f2, w, tf, z, test)
    assert not found[(tf >= 1.5) & (tf < 2.5)].any()
    assert np.array_equal(found[(tf + 0.15 < 1.5) | (tf - 0.15 >= 2.5)],
                          covered[(tf + 0.15 < 1.5) | (tf - 0.15 >= 2.5)])
