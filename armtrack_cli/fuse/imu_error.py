"""A causal estimate of the IMU's orientation error δθ and accelerometer bias b_a, for the
forward filter (tao2008-pf-constraint, ``imu_error = "causal"``; issue 14).

Tao & Hu integrate a_W = R̂ f̂ + g (eq. 4) with the IMU's own orientation R̂. An MTw-class
orientation error δθ of ~1° leaks g·sin 1° ≈ 0.17 m/s² of gravity into a_W and the bias b_a
adds ~0.03 m/s²; under a card that is all the filter has. To first order (fuse/imu_fold.py)
the true acceleration is a_W = R̂ f̂ + g + [s]× δθ − R̂ b_a, s = R̂ f̂.

The offline arm smoother (fuse/arm_smoother.py) estimates δθ, b_a (and the gyro's bias b_g,
δθ's changes measured by the gyroscope) from every detection and the arm constraint (eq. 15).
Its *forward* Kalman pass alone is causal: the filtered state at frame k uses the IMU and the
detections up to k only. Here that pass runs by itself, with the same process and measurement
rows (arm_smoother.process, arm_smoother.linearise), linearised about a causal trajectory: first
the particle filter's own forward estimates, then the previous pass's filtered states (each
pass is causal, so the last one is). Detections are gated and re-acquired as fuse/robust.py
says. ``corrected`` then adds [s]× δθ − R̂ b_a, with the filtered δθ, b_a of frame k−1, to the
step into frame k: the particle filter runs on it forward, as online the two would side by side.
The recipe runs ``kalman_passes`` = 8 passes: linearised about a first run that lost the arm, a
pass stays near it, and each pass linearised about the one before comes back (issue 14,
docs/fusion.md); the last pass's velocity is also given to the particles (``kalman_velocity``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from armtrack_cli.fuse import arm_smoother, imu_fold
from armtrack_cli.fuse.models import Arm, Projection, Steps
from armtrack_cli.fuse.pf_kernel import _gate_code
from armtrack_cli.fuse.settings import FuseSettings
from armtrack_cli.fuse.smoother_kernel import _gate, _scalar_update

TH, BA = arm_smoother.TH, arm_smoother.BA


@njit(cache=True)
def forward(x0, P0, F, b, Q, Hc, zc, use_c, rc, Hk, zk, rk, gate, reacquire, inflate):
    """(xf (n, d) filtered means, codes (n,) int8): the Kalman filter of smoother_kernel.smooth
    forward only, each camera pair gated (fuse/robust.py: code 1 used, 2 gated, 3 re-acquired,
    when ``inflate`` (d,) is added to P's diagonal first); the arm row on every frame."""
    n, d = F.shape[0], x0.size
    xf = np.empty((n, d))
    codes = np.zeros(n, np.int8)
    x, P = x0.copy(), P0.copy()
    run = 0
    for k in range(n):
        if k > 0:
            x = F[k] @ x + b[k]
            P = F[k] @ P @ F[k].T + Q[k]
        if use_c[k]:
            code, run = _gate_code(_gate(x, P, Hc[k], zc[k], rc), gate, run, reacquire)
            codes[k] = code
            if code == 3:
                for i in range(d):
                    P[i, i] += inflate[i]
            if code != 2:
                _scalar_update(x, P, Hc[k, 0], zc[k, 0], rc)
                _scalar_update(x, P, Hc[k, 1], zc[k, 1], rc)
        elif run >= 0:  # no detection: as a gated one (robust.blind)
            run += 1
        _scalar_update(x, P, Hk[k], zk[k], rk)
        P = 0.5 * (P + P.T)
        xf[k] = x
    return xf, codes


def causal_errors(inp, first: np.ndarray, x0: np.ndarray, P0: np.ndarray, proj: Projection,
                  s: FuseSettings, arm: Arm, passes: int = 2) -> tuple[np.ndarray, ...]:
    """(δθ (n, 3) rad, b_a (n, 3) m/s², v (n, 3) m/s): the filtered estimates at each frame, from ``passes``
    forward passes; ``first`` (n, 6) the particle filter's forward (p, v), where the first pass
    is linearised. inp: methods.Inputs with the IMU samples and frame times."""
    imu, t = inp.imu, inp.t
    fd = imu_fold.fold(imu.t, imu.q_WB, imu.f_B, t, hold=s.imu_hold)
    gyro = s.orientation_model == "gyro" and imu.gyro()
    track = imu_fold.orientation_track(imu.t, imu.q_WB, imu.w_B, t) if gyro else None
    F, b, Q = arm_smoother.process(fd, s, None, float(np.median(np.diff(imu.t))), track)
    m0, Pm0 = arm_smoother.prior(x0, P0, s, None, gyro)
    infl = np.zeros(m0.size)
    infl[:6] = np.r_[np.full(3, s.reacquire_sigma_m**2), np.full(3, s.init_vel_sigma_m_s**2)]
    X = np.zeros((t.size, m0.size))
    X[:, :6] = first
    use_c = np.isfinite(inp.z).all(axis=1)
    gate = float(s.gate_chi2) if s.gate_chi2 > 0 else np.inf
    for _ in range(passes):
        Hc, zc, Hk, zk = arm_smoother.linearise(X, inp.z, inp.q_WB, proj, arm, arm.shoulder)
        X, _codes = forward(m0, Pm0, F, b, Q, Hc, zc, use_c, s.pixel_sigma**2, Hk, zk,
                            s.constraint_sigma_m**2, gate, int(s.reacquire_frames), infl)
    return X[:, TH], X[:, BA], X[:, 3:6]


def correction(fd: imu_fold.Folded, dtheta: np.ndarray, b_a: np.ndarray) -> tuple[np.ndarray,
                                                                                 np.ndarray]:
    """(Δdp, Δdv) (n, 3): what [s]× δθ − R̂ b_a adds to each step into frame k (imu_fold's
    A, B), δθ and b_a held at frame k−1's estimate (index 0: zero)."""
    th = np.vstack([np.zeros((1, 3)), dtheta[:-1]])
    ba = np.vstack([np.zeros((1, 3)), b_a[:-1]])
    ddp = np.einsum("kij,kj->ki", fd.A_p, th) - np.einsum("kij,kj->ki", fd.B_p, ba)
    ddv = np.einsum("kij,kj->ki", fd.A_v, th) - np.einsum("kij,kj->ki", fd.B_v, ba)
    return ddp, ddv


def corrected(inp, steps: Steps, dtheta: np.ndarray, b_a: np.ndarray) -> Steps:
    """The particle filter's steps with a_W corrected by the causal δθ, b_a (eqs. 5, 6)."""
    fd = imu_fold.fold(inp.imu.t, inp.imu.q_WB, inp.imu.f_B, inp.t, hold="sample")
    ddp, ddv = correction(fd, dtheta, b_a)
    return Steps(steps.dt, steps.dp + ddp, steps.dv + ddv, steps.q)
