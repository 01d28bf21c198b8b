"""A causal estimate of the error of the IMU's acceleration in W, for the forward filter.

Tao & Hu integrate a_W = R_WB f_B + g (eq. 4) with the IMU's own orientation. An MTw-class
orientation error of ~1° leaks up to 0.17 m/s² of gravity into a_W and the accelerometer's
bias adds ~0.05 m/s²: an error b_W that changes over seconds. With the patch in view the
camera hides it; under a 1 s card it is ½ b t² ≈ 6-9 cm of drift, the largest error of the
forward filter (docs/validation-forward-filter.md).

Over the last ``window_s`` of frames whose detection the filter used, its estimates p̂_j and
the IMU's own double integral D_j (zero initial velocity) differ by p0 + v0 τ − ½ b τ² (τ the
time in the window): a quadratic fit per axis gives b. The estimate for the step into frame k
uses only the estimates of frames before k, which used only data up to them: a filter run on
a_W − b is still a forward (online) filter — online, the two run side by side.
"""

from __future__ import annotations

import numpy as np

from armtrack_cli.fuse.models import Steps


def imu_path(steps: Steps) -> np.ndarray:
    """(n_frames, 3) m: the IMU's double integral D_k from frame 0 with zero initial velocity
    (the deterministic part of Tao & Hu eqs. 5, 6 applied to the origin)."""
    n = steps.dt.size
    D, V = np.zeros((n, 3)), np.zeros((n, 3))
    for k in range(1, n):
        D[k] = D[k - 1] + V[k - 1] * steps.dt[k] + steps.dp[k]
        V[k] = V[k - 1] + steps.dv[k]
    return D


def causal_bias(t: np.ndarray, p_hat: np.ndarray, used: np.ndarray, steps: Steps, *,
                window_s: float, min_span: float = 0.9, min_frames: int = 15,
                max_bias: float = 0.25) -> np.ndarray:
    """(n_frames, 3) m/s²: b_k, the acceleration error in W held over the step into frame k.

    Fitted to the used frames j < k within ``window_s`` of the latest of them (t_e): per axis
    p̂_j − D_j = p0 + v0 τ − ½ b τ², τ = t_j − t_e, least squares. A fit needs ``min_frames``
    frames spanning min_span · window_s (a window cut by a card or the session's start is not
    trusted); otherwise the last b is held (0 before the first). |b| is capped at max_bias
    (0.25 m/s²: the gravity leak of a 1.5° orientation error).

    t (n,) s; p_hat (n, 3) m, the filter's estimates; used (n,) bool, frames whose detection
    the filter used."""
    n = t.size
    y = p_hat - imu_path(steps)
    b = np.zeros((n, 3))
    idx = np.flatnonzero(used & np.isfinite(p_hat).all(axis=1))
    last, lo = np.zeros(3), 0
    for k in range(1, n):
        hi = np.searchsorted(idx, k)  # used frames j < k: idx[:hi]
        if hi > 0:
            t_end = t[idx[hi - 1]]
            while lo < hi and t[idx[lo]] < t_end - window_s:
                lo += 1
            if hi - lo >= min_frames and t_end - t[idx[lo]] >= min_span * window_s:
                tau = t[idx[lo:hi]] - t_end
                A = np.stack([np.ones_like(tau), tau, tau * tau], 1)
                last = -2.0 * np.linalg.lstsq(A, y[idx[lo:hi]], rcond=None)[0][2]  # y'' = −b
        b[k] = last
    norm = np.linalg.norm(b, axis=1, keepdims=True)
    return b * np.minimum(1.0, max_bias / np.maximum(norm, 1e-12))


def corrected(steps: Steps, b: np.ndarray) -> Steps:
    """The steps with a_W − b_k held over each frame interval (eqs. 5, 6): dp − ½ b Δ²,
    dv − b Δ."""
    d = steps.dt[:, None]
    return Steps(steps.dt, steps.dp - 0.5 * b * d * d, steps.dv - b * d, steps.q)
