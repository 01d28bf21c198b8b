"""The orientation-aware arm smoother (method ``arm-smoother``): the wrist (p, v), the IMU's
orientation error δθ and accelerometer bias b_a (and, with ``shoulder = "drifting"``, the
drifting arm: the upper arm's length change ℓ and the shoulder S) estimated over the whole
session at once, as a Gauss–Newton iterated extended
Kalman smoother. Equations and their derivation: docs/fusion.md.

State, d = 15 (19 with the drifting shoulder):  x = (p, v, δθ, b_a, b_g[, c][, ℓ, S])  in W, m,
m/s, rad, m/s², rad/s, m (b_g in B); d = 12 (16) without a gyroscope, or orientation_model =
"gauss-markov"; six more with camera_pose = "board": c = (φ, τ), the camera pose's correction
(fuse/camera_pose.py), static, its prior the board's covariance.
  - process (Tao & Hu eqs. 4–6 with both IMU errors; fuse/arm_state.py, the IMU folded by
    fuse/imu_fold.py), linear given the IMU;
    δθ changes as the gyroscope says (imu_fold.orientation_track: the output orientation's
    rotation against the gyro's, plus G b_g for the gyro's bias) with a small random walk
    (orientation_walk_deg); without a gyro, first-order Gauss–Markov (SD orientation_sd_deg,
    time constant orientation_tau_s); b_a, b_g slow random walks; ℓ and S random walks from
    the declared arm (``drift_noise``, ``drift_prior``);
  - camera (eq. 7): the patch pixel π(p) (π(p; c) with the pose's correction), σ =
    pixel_sigma (× √pixel_still_tau on still frames: camera_rows.py), gated by χ² (gate_chi2);
  - arm (eq. 15): |p − L2 u − S| − (L1 + ℓ) = 0 ± constraint_sigma_m, with the forearm
    u = exp(−[δθ]×) R̂ u_B from the corrected orientation (eq. 2).
Each iteration linearises camera and arm about the current smoothed trajectory and runs one
forward Kalman filter and RTS pass (fuse/smoother_kernel.py); the first trajectory is a robust
first pass (pf-constraint, RTS-smoothed), so the ray–sphere branch is first the particles'
choice; after the first iteration, runs of frames on the wrong one are moved to the other
where the IMU says so (fuse/branch_repair.py), which Gauss–Newton cannot do by itself.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from armtrack_cli.core import quaternion as quat
from armtrack_cli.fuse import branch_repair, camera_pose, camera_rows, imu_fold, rest, robust
from armtrack_cli.fuse.arm_state import (
    BA,
    BG,
    DRIFT,
    P_,
    TH,
    camera_slice,
    drift_prior,
    drift_slice,
    orientation_var,
    process,
    shoulder_slice,
    state_size,
)
from armtrack_cli.fuse.models import Arm, Projection
from armtrack_cli.fuse.settings import FuseSettings
from armtrack_cli.fuse.smoother_blocks import smooth_blocked

STEP_TOL_M = 1e-5  # a step that moves no wrist position more than this is converged (the
#                    iterated passes of fuse/imu_error.py and fuse/arm_refine.py stop there)
GN_STEP_M = 1e-3  # Gauss–Newton may stop once no wrist position moved more than this …
REMAINING_M = 5e-6  # … and the change still to come, extrapolated, is below this (``converged``)


def converged(step: float, previous: float) -> bool:
    """Whether Gauss–Newton may stop after an iteration that moved no wrist position more than
    ``step`` m, the one before it ``previous`` m: the step below GN_STEP_M and the change
    still to come, the geometric series of steps shrinking at the rate r = step / previous,
    step · r / (1 − r) = step² / (previous − step), below REMAINING_M. Its convergence here
    is near quadratic (3 mm, 28 µm, 0.75 µm, 20 nm on the 10-minute bench session: rates
    0.009, 0.027), so this stops after the 28 µm step, the trajectory within about a
    micrometre of the one after more (tests/test_fuse_compare.py); never after the first
    (no rate yet) nor after a step no smaller than the one before."""
    return bool(step < GN_STEP_M and np.isfinite(previous) and previous > step
                and step * step < REMAINING_M * (previous - step))


@dataclass(frozen=True)
class ImuSamples:
    """The IMU on the session clock: t (M,) s, q_WB (M, 4), f_B (M, 3) m/s² (specific force),
    w_B (M, 3) rad/s (gyroscope; None or NaN where the file has none)."""

    t: np.ndarray
    q_WB: np.ndarray
    f_B: np.ndarray
    w_B: np.ndarray | None = None

    def gyro(self) -> bool:
        return self.w_B is not None and bool(np.isfinite(self.w_B).all())


@dataclass(frozen=True)
class Smoothed:
    x: np.ndarray  # (n, d) smoothed state
    var: np.ndarray  # (n, 6) the variances of (p, v): all a trajectory reports of them
    q_WB: np.ndarray  # (n, 4) the corrected orientation R = exp(−[δθ]×) R̂
    elbow_var: np.ndarray  # (n, 3) the elbow's variances
    gated: np.ndarray  # (n,) bool, detections not used
    iterations: int
    gyro: bool  # δθ tracked by the gyroscope (state holds b_g) or Gauss–Markov
    runs_moved: int = 0  # runs moved to the other ray–sphere root, all repairs (branch_repair)


def projection_jacobians(proj: Projection, p: np.ndarray) -> np.ndarray:
    """∂π/∂p (n, 2, 3) at points p (n, 3): Projection.jacobian for every point at once."""
    return camera_pose.pixel_jacobians(proj, camera_pose.in_camera(proj, p)) @ proj.R


def corrected(q_hat: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
    """R = exp(−[δθ]×) R̂ as quaternions (n, 4): the IMU's orientation with its error removed;
    quat.ROWS_AT_ONCE rows at a time (their temporaries, a dozen arrays a row; every row's
    numbers its own)."""
    out = np.empty(q_hat.shape)
    for a, b in quat.row_spans(q_hat.shape[0]):
        ang = np.linalg.norm(dtheta[a:b], axis=1)
        axis = dtheta[a:b] / np.maximum(ang, 1e-300)[:, None]
        out[a:b] = quat.normalize(quat.multiply(quat.from_axis_angle(axis, -ang), q_hat[a:b]))
    return out


def forearm(q_hat: np.ndarray, dtheta: np.ndarray, arm: Arm) -> np.ndarray:
    """u (n, 3): the forearm axis in W from the corrected orientation (eq. 2)."""
    return quat.rotate(corrected(q_hat, dtheta), arm.forearm_B)


def linearise(X: np.ndarray, z: np.ndarray, q_hat: np.ndarray, proj: Projection, arm: Arm,
              shoulder: np.ndarray | None, camera: bool = False):
    """Camera rows (Hc (n, 2, d), zc (n, 2)) and arm row (Hk (n, d), zk (n,)) linearised about
    the trajectory X (n, d): h(x) ≈ h(x̄) + H (x − x̄), written as z' = H x with
    z' = z − h(x̄) + H x̄ (camera) and z' = H x̄ − r(x̄) (arm, whose measurement is r = 0).
    ``shoulder`` None: the drifting arm, the state's last four (ℓ, S); ``camera``: the
    state holds the pose's correction c (camera_slice), the projection is moved by it."""
    n, d = X.shape
    p = X[:, P_]
    Hc = np.zeros((n, 2, d))
    if camera:  # c is static: one pose for the block, its mean (equal on every frame)
        cs = camera_slice(d, shoulder is None)
        c = X[:, cs].mean(axis=0)
        Hc[:, :, cs] = camera_pose.pose_jacobians(proj, p, c)
        proj = camera_pose.moved(proj, c)
    Hc[:, :, P_] = projection_jacobians(proj, p)  # eq. 7
    zc = np.where(np.isfinite(z), z, 0.0) - proj(p) + np.einsum("kij,kj->ki", Hc, X)
    u = forearm(q_hat, X[:, TH], arm)
    S = X[:, shoulder_slice(d)] if shoulder is None else np.broadcast_to(shoulder, p.shape)
    L1 = arm.L1 + (X[:, d - DRIFT] if shoulder is None else 0.0)  # L1 + ℓ
    e = p - arm.L2 * u - S  # E − S (eq. 15)
    dist = np.linalg.norm(e, axis=1)
    nvec = e / dist[:, None]
    Hk = np.zeros((n, d))
    Hk[:, P_] = nvec
    Hk[:, TH] = -arm.L2 * np.cross(nvec, u)  # ∂u/∂δθ = [u]×: nᵀ[u]× = (n × u)ᵀ
    if shoulder is None:
        Hk[:, shoulder_slice(d)] = -nvec
        Hk[:, d - DRIFT] = -1.0
    zk = np.einsum("kj,kj->k", Hk, X) - (dist - L1)
    return Hc, zc, Hk, zk


def prior(x0: np.ndarray, P0: np.ndarray, s: FuseSettings,
          shoulder: np.ndarray | None, gyro: bool = False,
          pose_cov: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The first frame's prior: (p, v) as the other methods start, δθ, b_a (, b_g) about
    zero, the camera pose's correction c about zero as uncertain as the board left it
    (``pose_cov``, when given), (ℓ, S) about the declared arm (``drift_prior``), and then
    the first wrist, which the pipeline placed on the declared sphere, as uncertain as that
    sphere."""
    d = state_size(gyro, pose_cov is not None, shoulder is not None)
    m, P = np.zeros(d), np.zeros((d, d))
    m[:6], P[:6, :6] = x0, P0
    P[TH, TH] = orientation_var(s)
    P[BA, BA] = s.accel_bias_sd**2 * np.eye(3)
    if gyro:
        P[BG, BG] = np.deg2rad(s.gyro_bias_sd_deg_s) ** 2 * np.eye(3)
    if pose_cov is not None:
        cs = camera_slice(d, shoulder is not None)
        P[cs, cs] = pose_cov
    if shoulder is not None:
        DR = drift_slice(d)
        m[DR], P[DR, DR] = drift_prior(shoulder, s)
        P[P_, P_] += np.trace(P[DR, DR]) * np.eye(3)  # the sphere's (ℓ, S) spread, any way
    return m, P


def resting(imu: ImuSamples, t_frames: np.ndarray, z: np.ndarray, s: FuseSettings,
            video_from: int = 0) -> np.ndarray:
    """(n,) bool: frames given a zero velocity (fuse/rest.py); none when rest_velocity_sd_m_s
    is 0 or the IMU file has no gyroscope. Frames before ``video_from``: the IMU's alone."""
    if s.rest_velocity_sd_m_s <= 0 or not imu.gyro():
        return np.zeros(t_frames.size, bool)
    return rest.rest_frames(imu.t, imu.f_B, imu.w_B, t_frames, z, video_from=video_from)


def pre_roll(imu: ImuSamples, t_frames: np.ndarray, z: np.ndarray, q_hat: np.ndarray,
             first: np.ndarray, s: FuseSettings):
    """Steps at the video's rate before its first frame, back over the IMU recorded before it
    (at most pre_roll_s; none when the rest update is off, the only thing that gives them
    weight): their times, no detections, the IMU orientation, the first pass's start at rest.
    A trial that starts moving leaves its first frame's velocity to the IMU's integral from
    a hand at rest, instead of a 5 cm/s prior the camera cannot correct along its ray.
    Without steps: the arrays given, not copies."""
    dt = float(np.median(np.diff(t_frames)))
    span = min(s.pre_roll_s, t_frames[0] - imu.t[0]) if s.rest_velocity_sd_m_s > 0 else 0.0
    m = int(np.floor(span / dt + 1e-9))
    if m == 0:
        return 0, t_frames, z, q_hat, first
    tp = t_frames[0] - dt * np.arange(m, 0, -1)
    fp = np.tile(np.r_[first[0, :3], 0.0, 0.0, 0.0], (m, 1))
    return (m, np.r_[tp, t_frames], np.vstack([np.full((m, 2), np.nan), z]),
            np.vstack([quat.interpolate(imu.t, imu.q_WB, tp), q_hat]), np.vstack([fp, first]))


def _given(box):
    """The array (or ImuSamples) in ``box``, a one-element list that is emptied, so that the
    caller holds it no more: it is freed when run lets it go (issue 15); else ``box``."""
    return box.pop() if isinstance(box, list) else box


def run(imu: ImuSamples | list, t_frames: np.ndarray, z: np.ndarray, q_hat: np.ndarray,
        first: np.ndarray | list, x0: np.ndarray, P0: np.ndarray, proj: Projection,
        s: FuseSettings, arm: Arm) -> Smoothed:
    """Smooth the session: frames at t_frames (n,) s with detections z (n, 2) px (NaN = none),
    the IMU orientation q_hat (n, 4) at each frame, ``first`` (n, 6) the first pass's (p, v).
    ``imu`` and ``first`` may each come in a one-element list, which run empties: then
    nothing holds the IMU's samples once they are folded, nor the first pass once the first
    iteration has linearised about it (fuse's peak memory, issue 15)."""
    imu, first = _given(imu), _given(first)
    shoulder = np.asarray(arm.shoulder, float) if s.shoulder == "drifting" else None
    m_pre, t_frames, z, q_hat, first = pre_roll(imu, t_frames, z, q_hat, first, s)
    period = float(np.median(np.diff(imu.t)))
    gyro = s.orientation_model == "gyro" and imu.gyro()
    still = resting(imu, t_frames, z, s, m_pre)
    t_imu, q_imu, f_B, w_B = imu.t, imu.q_WB, imu.f_B, imu.w_B
    del imu  # what the iterations need of it is track, fd and still: each of its arrays let
    #          go after its last use, the gyro's before the fold (fuse@60's peak, issue 15)
    track = imu_fold.orientation_track(t_imu, q_imu, w_B, t_frames) if gyro else None
    del w_B
    fd = imu_fold.fold(t_imu, q_imu, f_B, t_frames, hold=s.imu_hold)
    del t_imu, q_imu, f_B
    camera = s.camera_pose == "board" and proj.pose_cov is not None
    m0, Pm0 = prior(x0, P0, s, shoulder, gyro, proj.pose_cov if camera else None)
    start = [np.zeros((t_frames.size, m0.size))]  # _iterate's to let go
    start[0][:, :6] = first
    del first
    if shoulder is not None:
        start[0][:, drift_slice(m0.size)] = m0[drift_slice(m0.size)]
    use_c = np.isfinite(z).all(axis=1)
    use_k = np.ones(t_frames.size, bool)
    scale = camera_rows.row_scale(z, s.pixel_still_tau, s.pixel_still_px)
    X, var, elbow_var, gated, iterations, runs = _iterate(
        fd, track, period, (m0, Pm0), start, z, q_hat, proj, s, arm, shoulder, use_c, use_k,
        still, camera, scale)
    del fd, track  # the model's IMU, not held while the result is made (issue 15)
    X, q_hat = X[m_pre:], q_hat[m_pre:]  # the video's frames
    return Smoothed(X, var[m_pre:], corrected(q_hat, X[:, TH]), elbow_var[m_pre:],
                    gated[m_pre:], iterations, gyro, runs)


def _iterate(fd, track, period, prior_, start, z, q_hat, proj, s, arm, shoulder, use_c, use_k,
             still, camera=False, scale=None) -> tuple:
    """run()'s Gauss–Newton iterations, each a checkpointed pass (fuse/smoother_blocks.py:
    equal to the plain pass, memory flat in the session's length): the model built a block of
    frames at a time, with the zero-velocity rows of its resting frames (``still``,
    fuse/rest.py) inserted, and only the (p, v) and elbow variances kept (a covariance per
    frame would be 0.4 KB of every frame's 0.6 KB). After the first iteration, runs of frames
    on the wrong ray–sphere root are moved to the other (``repaired``), and again after each
    pass that followed a move (``repair_due``; no stop right after a move). Returns X, the (p, v)
    and elbow variances, the gated detections, the iterations run and the runs moved.
    ``start``: [the first trajectory], emptied: each pass writes its smoothed states over it
    as it goes, so one (n, d) trajectory is held, not two. ``scale``: camera_rows.row_scale."""
    X = _given(start)  # each pass's smoothed states written over it, block by block
    n = X.shape[0]
    sh_fixed = None if shoulder is not None else arm.shoulder
    rk = s.constraint_sigma_m**2
    var, elbow_var = np.empty((n, 6)), np.empty((n, 3))
    iterations, step, previous, gated, runs = 0, np.inf, np.inf, np.zeros(n, bool), 0
    last = 0  # runs the latest repair moved
    while iterations < s.smoother_iterations and (last > 0 or not converged(step, previous)):
        was, moved = {}, []  # a block's first row before this pass wrote it; each block's move

        def model(lo: int, hi: int, steps_only: bool = False, was=was, X=X) -> tuple:
            """The steps and rows of frames lo … hi − 1 (the steps alone: steps_only)."""
            F, b, Q = process(_rows(fd, lo, hi), s, shoulder, period,
                              None if track is None else _rows(track, lo, hi), camera)
            if steps_only:
                ins = rest.steps_with_rows(still[lo:hi], F, b, Q)
                return ins.arrays if not still[lo:hi].any() else (*ins.arrays, ins.real)
            Hc, zc, Hk, zk = linearise(_before(X, was, lo, hi), z[lo:hi], q_hat[lo:hi], proj,
                                       arm, sh_fixed, camera)
            Hc, zc = camera_rows.scaled(Hc, zc, scale, lo, hi)
            arrays = (F, b, Q, Hc, zc, use_c[lo:hi], Hk, zk, use_k[lo:hi])
            if not still[lo:hi].any():
                return arrays
            ins = rest.with_rows(still[lo:hi], s.rest_velocity_sd_m_s, rk, *arrays)
            return (*ins.arrays, ins.real)

        def keep(lo: int, hi: int, xs: np.ndarray, Ps: np.ndarray, was=was, moved=moved,
                 X=X) -> None:
            was[lo] = X[lo].copy()
            moved.append(np.abs(xs[:, P_] - X[lo:hi, P_]).max())
            X[lo:hi], var[lo:hi] = xs, np.diagonal(Ps[:, :6, :6], axis1=1, axis2=2)
            elbow_var[lo:hi] = _elbow_var(q_hat[lo:hi], xs, Ps, arm)

        gated = smooth_blocked(*prior_, model, n, rc=s.pixel_sigma**2, rk=rk,
                               gate=float(s.gate_chi2) if s.gate_chi2 > 0 else np.inf,  # 0: off
                               keep=keep)
        previous, step = step, np.max(moved)
        iterations += 1
        if repair_due(iterations, last, s.smoother_iterations) and s.branch_repair \
                and shoulder is None:
            X, last = repaired(X, z, q_hat, proj, arm, camera,
                               lambda lo, hi: process(_rows(fd, lo, hi), s, None, period,
                                                      None if track is None
                                                      else _rows(track, lo, hi), camera,
                                                      noise=False))
            runs += last
    return X, var, elbow_var, gated, iterations, runs


def repair_due(iterations: int, moved_last: int, most: int) -> bool:
    """Whether branch repair follows pass ``iterations`` (of at most ``most``): after the
    first, and again after each pass whose preceding repair moved a run (``moved_last``): that
    pass fitted the IMU's errors and spheres to the moved runs, and a wrong run the first
    errors agreed with may now show (lift14: a calibration movement's second lift moved, its
    first then); never after the last pass (its repair would go unsmoothed)."""
    return (iterations == 1 or moved_last > 0) and iterations < most


def repaired(X: np.ndarray, z: np.ndarray, q_hat: np.ndarray, proj: Projection, arm: Arm,
             camera: bool, steps: branch_repair.Steps) -> tuple[np.ndarray, int]:
    """branch_repair.repair on the trajectory X (n, d) of the paper's fixed shoulder: the
    roots of each detection's ray (through the camera as X corrects it, ``camera``) on the
    sphere of the orientation X corrects; (X repaired in place, the runs moved)."""
    if camera:
        proj = camera_pose.moved(proj, X[:, camera_slice(X.shape[1], False)].mean(axis=0))
    points = robust.ray_sphere_points(proj, arm, z, lambda: corrected(q_hat, X[:, TH]))
    return branch_repair.repair(X, points, steps, in_place=True)


def _before(X: np.ndarray, was: dict, lo: int, hi: int) -> np.ndarray:
    """X's rows lo … hi − 1 as the pass found them: the backward pass (smoother_blocks.py)
    linearises a block with the next block's first frame, which it has just written (``was``
    holds that row as it was)."""
    if hi - 1 not in was:
        return X[lo:hi]
    return np.concatenate([X[lo:hi - 1], was[hi - 1][None]])


def _rows(a, lo: int, hi: int):
    """Frames lo … hi − 1 of a per-frame dataclass (imu_fold.Folded, OrientationTrack)."""
    return type(a)(**{f.name: getattr(a, f.name)[lo:hi] for f in fields(a)})


def _elbow_var(q_hat: np.ndarray, x: np.ndarray, P: np.ndarray, arm: Arm) -> np.ndarray:
    """(n, 3) variances of the elbow E = p − L2 u(δθ) (eq. 2): the diagonal of J P Jᵀ,
    J = ∂E/∂x = [I, 0, −L2 [u]×, 0 …], from P's (p, δθ) blocks alone: row i of J is
    (e_i, −L2 [u]×_i), so var_i = P_pp,ii − 2 L2 [u]×_i P_θp,·i + L2² [u]×_i P_θθ [u]×_iᵀ
    (45 products a frame, not J P Jᵀ's 810)."""
    S = imu_fold.skew(forearm(q_hat, x[:, TH], arm))  # (n, 3, 3), row i: [u]×_i
    pp = np.diagonal(P[:, P_, P_], axis1=1, axis2=2)
    cross = np.einsum("nil,nli->ni", S, P[:, TH, P_])
    quad = np.einsum("nik,nkl,nil->ni", S, P[:, TH, TH], S)
    return pp - 2 * arm.L2 * cross + arm.L2**2 * quad
