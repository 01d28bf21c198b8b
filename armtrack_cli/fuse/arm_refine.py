"""The "auto" arm refined by all the data: the arm smoother (fuse/arm_smoother.py) with the five
arm constants θ = (S, L1, L2) as static states.

The batch of fuse/arm_auto.py fits the elbow's sphere from a stretch of the session with a
constant orientation error. Here the whole session goes through the arm smoother's own model
(camera rays, eq. 7; the IMU with its orientation error tracked by the gyro and its
accelerometer bias, eqs. 4-6; the arm constraint as a measurement, eq. 15, with the elbow of
eq. 2), and θ joins its state: x' = (x, θ), θ_k = θ_{k−1} (no process noise), the arm row

    r = |p − L2 u(δθ) − S| − L1,   ∂r/∂S = −n,  ∂r/∂L1 = −1,  ∂r/∂L2 = −n·u,   n = (E − S)/|E − S|

besides its ∂r/∂p and ∂r/∂δθ (arm_smoother.linearise). Each Gauss–Newton iteration linearises
about the current trajectory and θ and runs one Kalman filter + RTS pass. Were the model linear
in (x, θ), the smoothed θ would be the maximiser of the marginal likelihood p(data | θ) times
θ's prior and its smoothed covariance the inverse of that log-posterior's curvature (a static
state's smoothed covariance is the same at every frame); linearised, it is the joint
(trajectory, arm) maximum instead. ``log_likelihood`` gives the forward pass's
Σ log N(innovation; 0, S) at a fixed arm, ``profile_log_likelihood`` log p(data | arm) with
the trajectory iterated to convergence, and ``maximise_quadratic`` searches it
(pipeline/arm_model.profile_maximum; validation/arm_auto.py measures the two against each
other and against the truth: docs/validation-arm-auto.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armtrack_cli.fuse import arm_smoother, arm_state, imu_fold
from armtrack_cli.fuse.models import Arm, Projection
from armtrack_cli.fuse.settings import FuseSettings
from armtrack_cli.fuse.smoother_kernel import smooth

N_ARM = 5  # S (3), L1, L2
STATIC_Q = 1e-14  # the static states' process variance: zero, less a hair for RTS's inverse
THETA_TOL_M = 1e-5  # … and converged when no arm constant moves more than this either


@dataclass(frozen=True)
class Refined:
    theta: np.ndarray  # (5,) S (m, in W), L1, L2 (m)
    cov: np.ndarray  # (5, 5) its posterior covariance
    iterations: int
    gated: int  # detections the χ² gate kept out in the last pass


@dataclass(frozen=True)
class Model:
    """The arm smoother's linear-Gaussian pieces for one session, the arm not yet in them."""

    F: np.ndarray
    b: np.ndarray
    Q: np.ndarray
    m0: np.ndarray
    P0: np.ndarray


def model(imu: arm_smoother.ImuSamples, t_frames: np.ndarray, x0: np.ndarray, P0: np.ndarray,
          s: FuseSettings) -> Model:
    """Process and prior as arm_smoother.run builds them (the paper's fixed shoulder; the
    rest update, off by default, not in it)."""
    fd = imu_fold.fold(imu.t, imu.q_WB, imu.f_B, t_frames, hold=s.imu_hold)
    gyro = s.orientation_model == "gyro" and imu.gyro()
    track = imu_fold.orientation_track(imu.t, imu.q_WB, imu.w_B, t_frames) if gyro else None
    F, b, Q = arm_state.process(fd, s, None, float(np.median(np.diff(imu.t))), track)
    m0, Pm0 = arm_smoother.prior(x0, P0, s, None, gyro)
    return Model(F, b, Q, m0, Pm0)


def augmented(m: Model, theta0: np.ndarray, theta_sd: np.ndarray) -> Model:
    """The model with θ appended as static states, prior N(theta0, diag(theta_sd²))."""
    n, d = m.b.shape
    D = d + N_ARM
    F = np.tile(np.eye(D), (n, 1, 1))
    F[:, :d, :d] = m.F
    Q = np.zeros((n, D, D))
    Q[:, :d, :d] = m.Q
    Q[:, d:, d:] = STATIC_Q * np.eye(N_ARM)
    P0 = np.zeros((D, D))
    P0[:d, :d], P0[d:, d:] = m.P0, np.diag(np.asarray(theta_sd, float) ** 2)
    return Model(F, np.c_[m.b, np.zeros((n, N_ARM))], Q, np.r_[m.m0, theta0], P0)


def arm_of(theta: np.ndarray, forearm_B: np.ndarray) -> Arm:
    return Arm(shoulder=np.asarray(theta[:3], float), L1=float(theta[3]), L2=float(theta[4]),
               forearm_B=forearm_B)


def linearise(X: np.ndarray, z: np.ndarray, q_hat: np.ndarray, proj: Projection,
              forearm_B: np.ndarray):
    """Camera and arm rows about X (n, d + 5) whose last five columns are θ: the arm
    smoother's rows (its fixed shoulder at θ) with the θ columns added (module docstring)."""
    d = X.shape[1] - N_ARM
    theta = X[0, d:]
    arm = arm_of(theta, forearm_B)
    Hc, zc, Hk, zk = arm_smoother.linearise(X[:, :d], z, q_hat, proj, arm, arm.shoulder)
    n = X.shape[0]
    nvec = Hk[:, arm_smoother.P_]  # (E − S)/|E − S|: arm_smoother.linearise's ∂r/∂p
    u = arm_smoother.forearm(q_hat, X[:, arm_smoother.TH], arm)
    Ha = np.c_[-nvec, -np.ones(n), -np.einsum("kj,kj->k", nvec, u)]  # ∂r/∂(S, L1, L2)
    Hk = np.c_[Hk, Ha]
    zk = zk + Ha @ theta  # z' = H x̄ − r(x̄) over the whole augmented x̄
    return np.concatenate([Hc, np.zeros((n, 2, N_ARM))], axis=2), zc, Hk, zk


def refine(imu: arm_smoother.ImuSamples, t_frames: np.ndarray, z: np.ndarray,
           q_hat: np.ndarray, first: np.ndarray, x0: np.ndarray, P0: np.ndarray,
           proj: Projection, s: FuseSettings, forearm_B: np.ndarray, prior_mean: np.ndarray,
           prior_sd: np.ndarray, theta0: np.ndarray) -> Refined:
    """θ from the whole session, its prior N(prior_mean, diag(prior_sd²)), iterated from
    theta0 (the sphere fit); ``first`` (n, 6) the first pass's (p, v) with theta0's arm
    (frames as arm_smoother.run takes them)."""
    m = augmented(model(imu, t_frames, x0, P0, s), prior_mean, prior_sd)
    D, d = m.m0.size, m.m0.size - N_ARM
    X = np.zeros((t_frames.size, D))
    X[:, :6], X[:, d:] = first, theta0
    use_c = np.isfinite(z).all(axis=1)
    use_k = np.ones(t_frames.size, bool)
    gate = float(s.gate_chi2) if s.gate_chi2 > 0 else np.inf  # 0: off
    iterations, step = 0, np.inf
    while iterations < 2 * s.smoother_iterations and step >= THETA_TOL_M:
        Hc, zc, Hk, zk = linearise(X, z, q_hat, proj, forearm_B)
        Xn, P, gated = smooth(m.m0, m.P0, m.F, m.b, m.Q, Hc, zc, use_c, s.pixel_sigma**2,
                              Hk, zk, use_k, s.constraint_sigma_m**2, gate)
        step = max(np.abs(Xn[:, :3] - X[:, :3]).max(), np.abs(Xn[0, d:] - X[0, d:]).max())
        X, iterations = Xn, iterations + 1
    return Refined(X[0, d:].copy(), P[0, d:, d:].copy(), iterations, int(gated.sum()))


def log_likelihood(m: Model, Hc, zc, use_c, rc: float, Hk, zk, use_k, rk: float) -> float:
    """Σ_k log N(y_k; 0, S_k) over the forward Kalman filter's innovations (camera pairs and
    the arm row, applied in the order smoother_kernel.smooth applies them)."""
    x, P, total = m.m0.copy(), m.P0.copy(), 0.0
    for k in range(m.b.shape[0]):
        if k > 0:
            x = m.F[k] @ x + m.b[k]
            P = m.F[k] @ P @ m.F[k].T + m.Q[k]
        rows = ([(Hc[k, 0], zc[k, 0], rc), (Hc[k, 1], zc[k, 1], rc)] if use_c[k] else []) \
            + ([(Hk[k], zk[k], rk)] if use_k[k] else [])
        for h, zz, r in rows:  # scalar rows in turn: the chain rule of the joint density
            Ph = P @ h
            s_ = float(h @ Ph + r)
            y = float(zz - h @ x)
            total -= 0.5 * (np.log(2 * np.pi * s_) + y * y / s_)
            gain = Ph / s_
            x = x + gain * y
            P = P - np.outer(gain, Ph)
    return total


def profile_log_likelihood(imu: arm_smoother.ImuSamples, t_frames: np.ndarray, z: np.ndarray,
                           q_hat: np.ndarray, first: np.ndarray, x0: np.ndarray,
                           P0: np.ndarray, proj: Projection, s: FuseSettings,
                           arm: Arm) -> float:
    """log p(data | arm): the arm smoother iterated to convergence with this arm declared,
    then its forward pass's log-likelihood about the converged trajectory (detections the
    last pass gated left out, as the smoother leaves them)."""
    m = model(imu, t_frames, x0, P0, s)
    X = np.zeros((t_frames.size, m.m0.size))
    X[:, :6] = first
    use_c = np.isfinite(z).all(axis=1)
    use_k = np.ones(t_frames.size, bool)
    gate = float(s.gate_chi2) if s.gate_chi2 > 0 else np.inf
    for _ in range(s.smoother_iterations):
        Hc, zc, Hk, zk = arm_smoother.linearise(X, z, q_hat, proj, arm, arm.shoulder)
        Xn, _, gated = smooth(m.m0, m.P0, m.F, m.b, m.Q, Hc, zc, use_c, s.pixel_sigma**2,
                              Hk, zk, use_k, s.constraint_sigma_m**2, gate)
        step = np.abs(Xn[:, :3] - X[:, :3]).max()
        X = Xn
        if step < arm_smoother.STEP_TOL_M:
            break
    Hc, zc, Hk, zk = arm_smoother.linearise(X, z, q_hat, proj, arm, arm.shoulder)
    return log_likelihood(m, Hc, zc, use_c & ~gated, s.pixel_sigma**2, Hk, zk, use_k,
                          s.constraint_sigma_m**2)


def maximise_quadratic(fun, x0: np.ndarray, L: np.ndarray, *, rounds: int = 2,
                       max_step: float = 3.0, step: bool = True
                       ) -> tuple[np.ndarray, float, np.ndarray]:
    """Maximise a smooth ``fun`` near x0 in the coordinates y of x = x0 + L y (L (n, m): a
    square root of the expected covariance, so that fun is about −½|y|² + const there): each
    round fits a full quadratic to 1 + 2m + m(m−1)/2 values at unit steps (central differences
    for the gradient and the Hessian's diagonal, the four-point rule for its other entries),
    takes its Newton step (the Hessian's eigenvalues held at or below −1/max_step², the step at
    most max_step long) and keeps the new point when fun is higher there. Returns x, fun(x)
    and the fitted Hessian of fun in x's units (pseudo-inverse of L where L is not square);
    ``step = False`` fits the quadratic at x0 and stays there."""
    m = L.shape[1]
    x, f0 = np.asarray(x0, float), fun(x0)
    Hy = -np.eye(m)
    for _ in range(rounds):
        E = np.eye(m)
        fp = np.array([fun(x + L @ E[i]) for i in range(m)])
        fm = np.array([fun(x - L @ E[i]) for i in range(m)])
        g = (fp - fm) / 2
        Hy = np.diag(fp - 2 * f0 + fm)
        for i in range(m):
            for j in range(i + 1, m):
                Hy[i, j] = Hy[j, i] = fun(x + L @ (E[i] + E[j])) - fp[i] - fp[j] + f0
        if not step:
            break
        w, V = np.linalg.eigh(Hy)
        dy = -V @ ((V.T @ g) / np.minimum(w, -1.0 / max_step**2))
        dy *= min(1.0, max_step / max(np.linalg.norm(dy), 1e-300))
        fn = fun(x + L @ dy)
        if not fn > f0:
            break
        x, f0 = x + L @ dy, fn
    Li = np.linalg.pinv(L)
    return x, f0, Li.T @ Hy @ Li
