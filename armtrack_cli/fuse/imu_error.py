"""A causal estimate of the IMU's orientation error δθ and accelerometer bias b_a, for the
forward filter (tao2008-pf-constraint, ``imu_error = "causal"``; issue 14).

Tao & Hu integrate a_W = R̂ f̂ + g (eq. 4) with the IMU's own orientation R̂. An MTw-class
orientation error δθ of ~1° leaks g·sin 1° ≈ 0.17 m/s² of gravity into a_W and the bias b_a
adds ~0.03 m/s²; under a card that is all the filter has. To first order (fuse/imu_fold.py)
the true acceleration is a_W = R̂ f̂ + g + [s]× δθ − R̂ b_a, s = R̂ f̂.

The offline arm smoother (fuse/arm_smoother.py) estimates δθ, b_a (and the gyro's bias b_g,
δθ's changes measured by the gyroscope) from every detection and the arm constraint (eq. 15).
Its *forward* Kalman pass alone is causal: the filtered state at frame k uses the IMU and the
detections up to k only. Here that pass runs by itself, with the same process rows
(arm_state.process) and the same camera (eq. 7) and arm (eq. 15) rows as
arm_smoother.linearise, gated and re-acquired as fuse/robust.py says. ``corrected`` then adds
[s]× δθ − R̂ b_a, with the filtered δθ, b_a of frame k−1, to the step into frame k: the
particle filter runs on it forward, as online the two would side by side, and is given the
pass's velocity (``kalman_velocity``).

Where the rows are linearised (``kalman_linearise``). The recipe's "iterated": one pass, each
frame's rows linearised about its own update and iterated until the wrist moves less than
arm_smoother.STEP_TOL_M (the iterated EKF; ``iterated``), so the pass needs no trajectory
before it and the particle filter runs once. "passes" (the recipe before): ``kalman_passes``
passes linearised about a causal trajectory, first the particle filter's own forward
estimates, then the previous pass's filtered states; linearised about a first run that lost
the arm a pass stays near it, and each pass about the one before comes back
(docs/validation-forward-filter.md). Both are causal; at a frame where the passes have
converged they reach the iterated pass's fixed point.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from armtrack_cli.core import quaternion as quat
from armtrack_cli.fuse import arm_smoother, arm_state, imu_fold
from armtrack_cli.fuse.methods import camera_arrays
from armtrack_cli.fuse.models import Arm, Projection, Steps
from armtrack_cli.fuse.pf_guard_kernel import _gate_code
from armtrack_cli.fuse.projection_kernel import _pixel
from armtrack_cli.fuse.settings import FuseSettings
from armtrack_cli.fuse.smoother_kernel import _gate, _scalar_update

TH, BA = arm_smoother.TH, arm_smoother.BA
MAX_ITERATIONS = 20  # the iterated pass's linearisations per frame at most


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


@njit(cache=True)
def _camera_rows(x, cam, dist, z, H, zc):
    """The camera pair linearised at x (eq. 7): H (2, d) = ∂π/∂p in p's columns (as
    arm_smoother.projection_jacobians), zc = z − π(p̄) + H x̄. cam, dist as projection_kernel._pixel's."""
    R = cam[:9].reshape(3, 3)
    X = R @ x[:3] + cam[9:12]
    xn, yn, Z = X[0] / X[2], X[1] / X[2], X[2]
    k1, k2, t1, t2, k3 = dist[0], dist[1], dist[2], dist[3], dist[4]
    r2 = xn * xn + yn * yn
    rad = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    D = k1 + 2 * k2 * r2 + 3 * k3 * r2 * r2  # ∂rad/∂r²
    off = 2 * xn * yn * D + 2 * t1 * xn + 2 * t2 * yn
    Jd = np.array([[rad + 2 * xn * xn * D + 2 * t1 * yn + 6 * t2 * xn, off],
                   [off, rad + 2 * yn * yn * D + 6 * t1 * yn + 2 * t2 * xn]])
    Jn = np.array([[1 / Z, 0.0, -X[0] / Z**2], [0.0, 1 / Z, -X[1] / Z**2]])
    J = Jd @ Jn @ R
    u, v = _pixel(x[0], x[1], x[2], cam, dist)
    H[:, :] = 0.0
    H[0, :3], H[1, :3] = cam[12] * J[0], cam[13] * J[1]
    zc[0] = z[0] - u + H[0] @ x
    zc[1] = z[1] - v + H[1] @ x


@njit(cache=True)
def _arm_row(x, u_hat, shoulder, L1, L2, h):
    """The arm row linearised at x (eq. 15, as arm_smoother.linearise): h (d,), returns z' with
    the forearm u = exp(−[δθ]×) û (eq. 2), û = R̂ u_B, by Rodrigues' formula."""
    th = x[6:9]
    ang = np.sqrt(th @ th)
    u = u_hat.copy()
    if ang > 0.0:
        k = -th / ang
        u = u_hat * np.cos(ang) + np.cross(k, u_hat) * np.sin(ang) + k * (k @ u_hat) * (
            1 - np.cos(ang))
    e = x[:3] - L2 * u - shoulder
    dist = np.sqrt(e @ e)
    nv = e / dist
    h[:] = 0.0
    h[:3] = nv
    h[6:9] = -L2 * np.cross(nv, u)
    return h @ x - (dist - L1)


@njit(cache=True)
def iterated(x0, P0, F, b, Q, z, use_c, rc, cam, dist, u_hat, shoulder, L1, L2, rk, gate,
             reacquire, inflate, tol, max_iter):
    """(xf (n, d) filtered means, codes (n,) int8, iterations (n,)): the Kalman filter of
    ``forward`` with camera and arm rows linearised at each frame about its own update,
    iterated until no wrist coordinate moves more than ``tol`` (m) or max_iter (the iterated
    EKF: Gauss–Newton on frame k's posterior; Bell & Cathey 1993). The gate is the
    linearisation about the prediction."""
    n, d = F.shape[0], x0.size
    xf = np.empty((n, d))
    codes = np.zeros(n, np.int8)
    iters = np.zeros(n, np.int64)
    Hc, zc, hk = np.zeros((2, d)), np.zeros(2), np.zeros(d)
    xp, Pp = x0.copy(), P0.copy()
    x, P = x0.copy(), P0.copy()
    run = 0
    for k in range(n):
        if k > 0:
            xp = F[k] @ xf[k - 1] + b[k]
            Pp = F[k] @ P @ F[k].T + Q[k]
        used = False
        if use_c[k]:
            _camera_rows(xp, cam, dist, z[k], Hc, zc)
            code, run = _gate_code(_gate(xp, Pp, Hc, zc, rc), gate, run, reacquire)
            codes[k] = code
            if code == 3:
                for i in range(d):
                    Pp[i, i] += inflate[i]
            used = code != 2
        elif run >= 0:  # no detection: as a gated one (robust.blind)
            run += 1
        lin = xp.copy()
        for it in range(max_iter):
            x, P = xp.copy(), Pp.copy()
            if used:
                _camera_rows(lin, cam, dist, z[k], Hc, zc)
                _scalar_update(x, P, Hc[0], zc[0], rc)
                _scalar_update(x, P, Hc[1], zc[1], rc)
            zk = _arm_row(lin, u_hat[k], shoulder, L1, L2, hk)
            _scalar_update(x, P, hk, zk, rk)
            step = np.max(np.abs(x[:3] - lin[:3]))
            lin = x
            iters[k] = it + 1
            if step <= tol:
                break
        P = 0.5 * (P + P.T)
        xf[k] = x
    return xf, codes, iters


def causal_errors(inp, first: np.ndarray | None, x0: np.ndarray, P0: np.ndarray,
                  proj: Projection, s: FuseSettings, arm: Arm, passes: int = 2
                  ) -> tuple[np.ndarray, ...]:
    """(δθ (n, 3) rad, b_a (n, 3) m/s², v (n, 3) m/s, linearisations (n,)): the filtered
    estimates at each frame and how often each frame's rows were linearised. ``s.kalman_linearise``
    "iterated": one pass, each frame linearised about its own update (``iterated``; ``first``
    unused); "passes": ``passes`` forward passes, the first linearised about ``first`` (n, 6),
    the particle filter's forward (p, v), each later one about the pass before.
    inp: methods.Inputs with the IMU samples and frame times."""
    imu, t = inp.imu, inp.t
    fd = imu_fold.fold(imu.t, imu.q_WB, imu.f_B, t, hold=s.imu_hold)
    gyro = s.orientation_model == "gyro" and imu.gyro()
    track = imu_fold.orientation_track(imu.t, imu.q_WB, imu.w_B, t) if gyro else None
    F, b, Q = arm_state.process(fd, s, None, float(np.median(np.diff(imu.t))), track)
    m0, Pm0 = arm_smoother.prior(x0, P0, s, None, gyro)
    infl = np.zeros(m0.size)
    infl[:6] = np.r_[np.full(3, s.reacquire_sigma_m**2), np.full(3, s.init_vel_sigma_m_s**2)]
    use_c = np.isfinite(inp.z).all(axis=1)
    gate = float(s.gate_chi2) if s.gate_chi2 > 0 else np.inf
    if s.kalman_linearise == "iterated":
        cam, dist = camera_arrays(proj)
        X, _codes, lin = iterated(m0, Pm0, F, b, Q, np.where(use_c[:, None], inp.z, 0.0), use_c,
                                  s.pixel_sigma**2, cam, dist, quat.rotate(inp.q_WB, arm.forearm_B),
                                  np.asarray(arm.shoulder, float), float(arm.L1), float(arm.L2),
                                  s.constraint_sigma_m**2, gate, int(s.reacquire_frames), infl,
                                  arm_smoother.STEP_TOL_M, MAX_ITERATIONS)
        return X[:, TH], X[:, BA], X[:, 3:6], lin
    X = np.zeros((t.size, m0.size))
    X[:, :6] = first
    for _ in range(passes):
        Hc, zc, Hk, zk = arm_smoother.linearise(X, inp.z, inp.q_WB, proj, arm, arm.shoulder)
        X, _codes = forward(m0, Pm0, F, b, Q, Hc, zc, use_c, s.pixel_sigma**2, Hk, zk,
                            s.constraint_sigma_m**2, gate, int(s.reacquire_frames), infl)
    return X[:, TH], X[:, BA], X[:, 3:6], np.full(t.size, passes)


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
