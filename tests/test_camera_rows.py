"""fuse/camera_rows.py: still frames read from the detections, and rows scaled by 1/√τ are the
model whose camera variance is τ σ² on those frames (against the normal equations)."""

from __future__ import annotations

import numpy as np

from armtrack_cli.fuse import camera_rows
from armtrack_cli.fuse.smoother_kernel import smooth
from tests.test_arm_smoother import _batch, _linear_problem


def test_still_frames_are_those_whose_neighbours_lie_close():
    # u moves 0.2 px a frame for frames 0-5, then 3 px a frame; frame 8 missing
    u = np.r_[0.2 * np.arange(6), 1.0 + 3.0 * np.arange(1, 6)]
    z = np.c_[u, np.full(u.size, 50.0)]
    z[8] = np.nan
    still = camera_rows.still_patch(z, 0.5)
    # central difference: frames 1-4 move 0.2 px/frame; frame 5's neighbours (4: 0.8, 6: 4.0)
    # are 1.6 px/frame apart; 7 and 9 have a missing neighbour; ends have one neighbour
    assert np.array_equal(np.flatnonzero(still), [1, 2, 3, 4])
    assert not camera_rows.still_patch(z[:2], 10.0).any()


def test_tau_one_leaves_the_rows_as_they_are():
    z = np.zeros((5, 2))
    assert camera_rows.row_scale(z, 1.0, 0.5) is None
    Hc, zc = np.ones((5, 2, 3)), np.ones((5, 2))
    assert camera_rows.scaled(Hc, zc, None)[0] is Hc


def test_scaled_rows_equal_the_batch_answer_with_the_still_frames_variance():
    """Rows scaled by 1/√τ on the still frames: the smoother's result equals the normal
    equations' with camera variance τ·rc on those frames and rc elsewhere, to 1e-9."""
    prob = _linear_problem(np.random.default_rng(11), n=14, d=6, p_camera=1.0)
    x0, P0, F, b, Q, Hc, zc, use_c, rc, Hk, zk, use_k, rk = prob
    tau = 9.0
    z = np.c_[np.r_[np.zeros(7), 5.0 * np.arange(1, 8)], np.zeros(14)]  # frames 1-5 still
    scale = camera_rows.row_scale(z, tau, 0.5)
    still = scale < 1
    assert np.array_equal(np.flatnonzero(still), [1, 2, 3, 4, 5])
    Hs, zs = camera_rows.scaled(Hc, zc, scale)
    xs, Ps, _ = smooth(x0, P0, F, b, Q, Hs, zs, use_c, rc, Hk, zk, use_k, rk, np.inf)
    # the reference: the batch's information less (1 − 1/τ) of each still frame's camera rows
    x, cov = _batch(*prob)
    info = np.linalg.inv(cov)
    vec = info @ x.ravel()
    d = x0.size
    for k in np.flatnonzero(still & use_c):
        sl = slice(k * d, (k + 1) * d)
        info[sl, sl] -= (1 - 1 / tau) * Hc[k].T @ Hc[k] / rc
        vec[sl] -= (1 - 1 / tau) * Hc[k].T @ zc[k] / rc
    cov2 = np.linalg.inv(info)
    assert np.abs(xs - (cov2 @ vec).reshape(-1, d)).max() < 1e-9
    for k in range(14):
        sl = slice(k * d, (k + 1) * d)
        assert np.abs(Ps[k] - cov2[sl, sl]).max() < 1e-9
