"""The IMU samples between two camera frames folded into one linear step of the augmented
state (p, v, δθ, b_a) of the orientation-aware arm smoother (docs/fusion.md).

With the IMU's orientation R̂ = R_e R (the output orientation is the true one turned by a small
world-frame error R_e = exp([δθ]×)) and the accelerometer f̂ = f + b_a (+ noise), the true
acceleration in W is, to first order in δθ and b_a (Tao & Hu eq. 4 with both errors):

    a_W = R (f̂ − b_a) + g ≈ s + g + [s]× δθ − R̂ b_a,      s = R̂ f̂ (specific force in W).

δθ and b_a vary slowly, so over one frame interval they are constants and the step is linear:

    v_k = v + dv + A_v δθ − B_v b_a,     p_k = p + v Δ + dp + A_p δθ − B_p b_a,

where dv, A_v, B_v are ∫ a(t) dt with a(t) = s + g, [s]×, R̂ in turn, and dp, A_p, B_p are
∫ a(t) (t_k − t) dt. ``hold = "sample"`` holds each sample until the next (models.composite_steps,
which this equals for δθ = b_a = 0); ``hold = "linear"`` interpolates linearly between samples
(a first-order hold), which removes the half-sample lag (T_s / 2) of holding.

``orientation_track`` measures how the orientation error changes between frames: the gyro
sees the true rotation, the output orientation R̂ = exp([δθ]×) R the rotation plus the error's
change, so over each IMU interval exp([δθ_{j+1}]×) = D_j exp([δθ_j]×) with
D_j = R̂_{j+1} ΔR_Bᵀ R̂_jᵀ, ΔR_B = exp([ω̄ T_s]×) the gyro's body rotation (trapezoid ω̄).
To first order δθ_k = δθ_{k−1} + Σ rotvec(D_j) + G_k b_g, where a gyro bias b_g (in B, in
ω̂ = ω + b_g) adds G_k = ∫ R̂ dt over the interval.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armtrack_cli.core import quaternion as quat
from armtrack_cli.fuse.gyro_orientation import gap_steps, gyro_steps
from armtrack_cli.fuse.models import GRAVITY_W
from armtrack_cli.fuse.settings import HOLDS

FOLD_CHUNK = 8192  # IMU intervals summed at once: memory bounded however long the session
FOLD_FRAMES = 2048  # frames folded at once (their pieces: ~4 per frame at 100 Hz and 30 fps)


@dataclass(frozen=True)
class Folded:
    """Per camera frame k, the step k-1 -> k (index 0 unused: zeros). A_p and A_v are made
    when asked from the integrals of s they are the cross-product matrices of (skew is
    linear), which is 6 numbers a frame held instead of 18."""

    dt: np.ndarray  # (n,) Δ, s
    dp: np.ndarray  # (n, 3) m, ∫ (s + g)(t_k − t) dt
    dv: np.ndarray  # (n, 3) m/s, ∫ (s + g) dt
    s_p: np.ndarray  # (n, 3) m, ∫ s (t_k − t) dt
    s_v: np.ndarray  # (n, 3) m/s, ∫ s dt
    B_p: np.ndarray  # (n, 3, 3) −∂p_k/∂b_a
    B_v: np.ndarray  # (n, 3, 3) −∂v_k/∂b_a

    @property
    def A_p(self) -> np.ndarray:
        """(n, 3, 3) ∂p_k/∂δθ = ∫ [s]× (t_k − t) dt = [s_p]×."""
        return skew(self.s_p)

    @property
    def A_v(self) -> np.ndarray:
        """(n, 3, 3) ∂v_k/∂δθ = ∫ [s]× dt = [s_v]×."""
        return skew(self.s_v)


@dataclass(frozen=True)
class OrientationTrack:
    """Per camera frame k, the orientation error's change over the step k-1 -> k (index 0
    unused: zeros) as the gyro measures it, and its sensitivity to the gyro's bias."""

    dtheta: np.ndarray  # (n, 3) rad, in W
    G: np.ndarray  # (n, 3, 3) s, ∂δθ_k/∂b_g = ∫ R̂ dt over the interval


def skew(v: np.ndarray) -> np.ndarray:
    """[v]× (..., 3, 3): [v]× w = v × w."""
    z = np.zeros(v.shape[:-1])
    return np.stack([np.stack([z, -v[..., 2], v[..., 1]], -1),
                     np.stack([v[..., 2], z, -v[..., 0]], -1),
                     np.stack([-v[..., 1], v[..., 0], z], -1)], -2)


def _segments(t_imu: np.ndarray, t_frames: np.ndarray, hold: str, a: int = 0,
              b: int | None = None):
    """Every piece [s0, s1) between consecutive IMU-sample and frame times from frame a to
    frame b (default: the last), in time order: its frame k, and for the two samples (j, j1)
    its acceleration depends on, the weights on ∫ a dt (wv, wv1) and on ∫ a (t_k − t) dt
    (wp, wp1). Each piece's numbers are its own: the pieces of frames a … b are those of the
    whole span that fall there, whatever span is asked."""
    b = t_frames.size - 1 if b is None else b
    lo, hi = np.searchsorted(t_imu, [t_frames[a], t_frames[b]], side="left")
    brk = np.union1d(t_imu[lo:hi], t_frames[a:b + 1])
    brk = brk[(brk >= t_frames[a]) & (brk <= t_frames[b])]
    s0, s1 = brk[:-1], brk[1:]
    last = t_imu.size - 1
    j = np.clip(np.searchsorted(t_imu, s0, side="right") - 1, 0, last)  # sample at or before s0
    k = np.searchsorted(t_frames, s0, side="right")  # the interval ending at t_frames[k]
    tau, D = s1 - s0, t_frames[k] - s0
    wv, wp = tau, (D**2 - (D - tau) ** 2) / 2  # ∫ dt and ∫ (t_k − t) dt over the piece
    if hold == "sample":
        return k, (j, j), (wv, 0 * wv), (wp, 0 * wp)
    # first-order hold: a(t) = a(s0) + (a(s1) − a(s0)) (t − s0)/τ on the piece, so
    # ∫ a dt = τ (a(s0) + a(s1))/2 and ∫ a (t_k − t) dt = a(s0) (wp − c) + a(s1) c with
    # c = ∫₀^τ u (D − u) du / τ = D τ/2 − τ²/3; a(s) interpolates samples j and j + 1
    c = D * tau / 2 - tau**2 / 3
    j1 = np.minimum(j + 1, last)
    span = np.where(j1 > j, t_imu[j1] - t_imu[j], 1.0)
    lam0 = np.clip((s0 - t_imu[j]) / span, 0.0, 1.0) * (j1 > j)
    lam1 = np.clip((s1 - t_imu[j]) / span, 0.0, 1.0) * (j1 > j)
    cv0 = cv1 = tau / 2
    cp0, cp1 = wp - c, c
    on_j = ((1 - lam0) * cv0 + (1 - lam1) * cv1, (1 - lam0) * cp0 + (1 - lam1) * cp1)
    on_j1 = (lam0 * cv0 + lam1 * cv1, lam0 * cp0 + lam1 * cp1)
    return k, (j, j1), (on_j[0], on_j1[0]), (on_j[1], on_j1[1])


def fold(t_imu: np.ndarray, q_WB: np.ndarray, f_B: np.ndarray, t_frames: np.ndarray, *,
         hold: str = "linear") -> Folded:
    """Fold IMU samples (t_imu (M,) s, q_WB (M, 4), f_B (M, 3) m/s²) over the frame intervals of
    t_frames (n,) s, all on the session clock."""
    if hold not in HOLDS:
        raise ValueError(f"unknown hold {hold!r}; holds are {', '.join(HOLDS)}")
    n = t_frames.size
    acc_v, acc_p = np.zeros((n, 3, 5)), np.zeros((n, 3, 5))  # per frame: s + g, s, R
    for a in range(0, n - 1, FOLD_FRAMES):  # the pieces of a chunk of frames at a time: the
        # temporaries (a dozen arrays per piece) bounded however long the session
        k, (j, j1), (wv, wv1), (wp, wp1) = _segments(t_imu, t_frames, hold, a,
                                                     min(a + FOLD_FRAMES, n - 1))
        lo, hi = j[0], j1[-1] + 1  # the samples this chunk's pieces use
        R = quat.to_matrix(q_WB[lo:hi])  # R̂_WB
        s = np.einsum("mij,mj->mi", R, f_B[lo:hi])  # specific force in W
        per_sample = np.concatenate([(s + GRAVITY_W)[:, :, None], s[:, :, None], R], axis=2)
        first = np.flatnonzero(np.r_[True, np.diff(k) > 0])  # k sorted: each frame's pieces
        for acc, w0, w1 in ((acc_v, wv, wv1), (acc_p, wp, wp1)):
            piece = (w0[:, None, None] * per_sample[j - lo]
                     + w1[:, None, None] * per_sample[j1 - lo])
            acc[k[first]] += np.add.reduceat(piece, first, axis=0)  # a frame's pieces at once
    dt = np.r_[0.0, np.diff(t_frames)]
    return Folded(dt, acc_p[:, :, 0], acc_v[:, :, 0], acc_p[:, :, 1], acc_v[:, :, 1],
                  acc_p[:, :, 2:5], acc_v[:, :, 2:5])


def _at(t_src: np.ndarray, y: np.ndarray, t: np.ndarray) -> np.ndarray:
    """y (M, ...) linearly interpolated at times t (inside t_src)."""
    return _streamed_at(t_src, t, [(0, t_src.size - 1, y)], y.shape[1:])


def _streamed_at(t_src: np.ndarray, t: np.ndarray, chunks, shape: tuple) -> np.ndarray:
    """_at of a y (M, *shape) given as ``chunks``: (a, b, rows a … b of y), consecutive
    chunks sharing their end row; y is never held whole. t (n,) sorted, inside t_src."""
    i = np.clip(np.searchsorted(t_src, t, side="right"), 1, t_src.size - 1)
    f = ((t - t_src[i - 1]) / (t_src[i] - t_src[i - 1])).reshape((-1,) + (1,) * len(shape))
    out = np.empty((t.size,) + tuple(shape))
    for a, b, y in chunks:  # the times whose two neighbours are rows a … b
        lo, hi = np.searchsorted(i, [a + 1, b + 1], side="left")
        ii = i[lo:hi] - a
        out[lo:hi] = y[ii - 1] * (1 - f[lo:hi]) + y[ii] * f[lo:hi]
    return out


def _running_sums(t_imu: np.ndarray, step):
    """Chunks (a, b, rows a … b) of the running sum over IMU intervals of ``step(a, b)``
    (the b − a intervals from sample a, a (b − a, ...) array), zero at the first sample; the
    sum continued from each chunk's end: the same additions in the same order as one cumsum
    over the whole recording."""
    carry = None
    for a in range(0, t_imu.size - 1, FOLD_CHUNK):
        b = min(a + FOLD_CHUNK, t_imu.size - 1)
        st = step(a, b)
        carry = np.zeros((1,) + st.shape[1:]) if carry is None else carry
        rows = np.cumsum(np.concatenate([carry, st]), axis=0)
        yield a, b, rows
        carry = rows[-1:]


def _rotation_steps(t_imu: np.ndarray, q_WB: np.ndarray):
    """step(a, b) of ∫R_WB dt: the trapezoid over each interval from sample a to b."""
    def step(a: int, b: int) -> np.ndarray:
        R = quat.to_matrix(q_WB[a:b + 1])
        return 0.5 * (R[1:] + R[:-1]) * np.diff(t_imu[a:b + 1])[:, None, None]
    return step


def rotation_integral(t_imu: np.ndarray, q_WB: np.ndarray) -> np.ndarray:
    """(M, 3, 3) s: ∫R_WB dt from the first IMU sample (trapezoidal), what a constant vector
    in B (a bias) integrates to in W."""
    out = np.zeros((t_imu.size, 3, 3))
    for a, b, rows in _running_sums(t_imu, _rotation_steps(t_imu, q_WB)):
        out[a:b + 1] = rows
    return out


def orientation_track(t_imu: np.ndarray, q_WB: np.ndarray, w_B: np.ndarray,
                      t_frames: np.ndarray) -> OrientationTrack:
    """The orientation error's change between frames t_frames (n,) from the IMU's output
    orientation q_WB (M, 4) and gyro w_B (M, 3) rad/s at t_imu (M,) s (module docstring).
    The running sums over the IMU's samples are taken at the frames a chunk of samples at a
    time, never held whole (a 60-minute session's ∫R dt alone is 26 MB)."""
    gaps = gap_steps(t_imu)  # across dropped packets the gyro says nothing: no change there

    def rotvec_steps(a: int, b: int) -> np.ndarray:  # Σ rotvec(D_j)'s terms
        dq = gyro_steps(t_imu[a:b + 1], w_B[a:b + 1])  # the body's rotation over each interval
        D = quat.multiply(quat.multiply(q_WB[a + 1:b + 1], quat.conjugate(dq)),
                          quat.conjugate(q_WB[a:b]))
        r = quat.to_rotvec(D)
        r[gaps[a:b]] = 0.0
        return r

    c = _streamed_at(t_imu, t_frames, _running_sums(t_imu, rotvec_steps), (3,))
    G = _streamed_at(t_imu, t_frames, _running_sums(t_imu, _rotation_steps(t_imu, q_WB)), (3, 3))
    return OrientationTrack(_steps_in_place(c), _steps_in_place(G))


def _steps_in_place(y: np.ndarray) -> np.ndarray:
    """y (n, ...) made its steps y_k − y_{k−1} (row 0: zeros) in place, FOLD_FRAMES rows at a
    time from the last: np.diff's numbers without a second and third (n, ...) array."""
    for hi in range(y.shape[0], 1, -FOLD_FRAMES):
        lo = max(hi - FOLD_FRAMES, 1)
        y[lo:hi] -= y[lo - 1:hi - 1].copy()  # rows below lo are still the sums
    y[:1] = 0.0
    return y
