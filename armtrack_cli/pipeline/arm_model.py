"""`[arm] … = "auto"`: the arm model estimated from the session before fusing (the sphere
fit, fuse/arm_auto.py, refined by the whole session through the arm smoother, fuse/
arm_refine.py), and the session with it in place for every stage after fuse."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from armtrack_cli.core.errors import DataError
from armtrack_cli.fuse import arm_auto, arm_refine, models
from armtrack_cli.fuse.methods import run as run_method
from armtrack_cli.fuse.settings import FuseSettings
from armtrack_cli.session.arm_file import read_arm_estimate
from armtrack_cli.session.config import Session

ANCHORED_WALK = 0.001  # rad/√s: the gyro-anchored orientation's error is nearly constant (its
#                        white-noise walk: ~0.1° over 20 s; docs/validation-from-mocap.md)
REFINE_SHOULDER_SD_M = 0.10  # the refinement's prior on the shoulder about the sphere fit: wide
DECLARED_SD_M = 1e-6  # a declared constant, held in the refinement
PROFILE_STEP_SD = 2.0  # the quadratic fits' step: 2 SDs, a log-likelihood change of ~2, well
#                       above the smoother's convergence noise
REFINE_MAX_MOVE_M = 0.15  # a refinement that moves a constant further has lost its way


def estimate(session: Session, prepared) -> arm_auto.ArmEstimate:
    """The free parts of the arm from the most varied stretch of the filtered frames, with the
    IMU's orientation whose wandering error the gyro has replaced by a constant one
    (fuse/gyro_orientation.py; the batch estimates that constant)."""
    inp, st = prepared.inputs, arm_auto.AutoSettings(orientation_walk=ANCHORED_WALK)
    t_fr = prepared.t_frames[prepared.frames]
    q_WB = models.quat.interpolate(inp.imu.t, prepared.q_anchored, t_fr)
    steps = models.composite_steps(inp.imu.t, models.accel_world(prepared.q_anchored, inp.imu.f_B),
                                   t_fr, accel_noise=0.0, imu_period=1.0)
    f_W = models.quat.rotate(q_WB, session.imu.forearm_unit)
    w = arm_auto.varied_stretch(inp.z[::st.stride], f_W[::st.stride], st.max_frames)
    a, b = w.start * st.stride, min(inp.z.shape[0], w.stop * st.stride)
    idx = np.arange(a, b, st.stride)
    if np.isfinite(inp.z[idx]).all(axis=1).sum() < 20:
        raise DataError(session.toml_path, f'[arm] "auto" needs at least 20 detections; the '
                        f"stretch used has {int(np.isfinite(inp.z[idx]).all(axis=1).sum())}",
                        "declare the arm model, or check detect")
    arm = session.arm
    declared = {k: (None if k in arm.auto else v) for k, v in
                (("shoulder_m", arm.shoulder_m), ("upper_arm_m", arm.upper_arm_m),
                 ("forearm_m", arm.forearm_m))}
    return arm_auto.estimate_arm(arm_auto.coarsen(steps, st.stride, a, b), inp.z[idx],
                                 q_WB[idx], prepared.t_frames[prepared.frames[idx]],
                                 prepared.projection, session.imu.forearm_unit, declared, st)


def _first_pass(prepared, arm: models.Arm, s: FuseSettings):
    """x0, P0 and the first pass (pf-constraint, smoothed: (n, 6)) with this arm, as fuse
    starts the arm smoother."""
    inp = prepared.inputs
    x0 = np.zeros(6)
    x0[:3], _ = models.initial_wrist(prepared.projection, inp.z[0], arm=arm, q_WB=inp.q_WB[0],
                                     plane_height_m=s.init_plane_m)
    P0 = np.diag([s.init_pos_sigma_m**2] * 3 + [s.init_vel_sigma_m_s**2] * 3)
    return x0, P0, run_method("pf-constraint", inp, x0, P0, prepared.projection, s, arm).mean


def free_of(estimated) -> np.ndarray:
    """(5,) bool: which of arm_auto.PARAMS the names in ``estimated`` make free."""
    return np.r_[[("shoulder_m" in estimated)] * 3, "upper_arm_m" in estimated,
                 "forearm_m" in estimated]


def _prior(free: np.ndarray, theta: np.ndarray, shoulder: np.ndarray):
    """The refinement's prior (mean, SD) on all five constants: a free shoulder about
    ``shoulder`` (the sphere fit's) with REFINE_SHOULDER_SD_M, free lengths the anthropometric
    prior (fuse/arm_auto.py); a declared one (``theta``'s) held (DECLARED_SD_M)."""
    mean = np.where(free, np.r_[shoulder, arm_auto.PRIOR_L], theta)
    sd = np.where(free, np.r_[[REFINE_SHOULDER_SD_M] * 3, [arm_auto.PRIOR_SD_M] * 2],
                  DECLARED_SD_M)
    return mean, sd


def refined(session: Session, prepared, est: arm_auto.ArmEstimate,
            s: FuseSettings) -> arm_auto.ArmEstimate:
    """The sphere fit ``est`` refined by the whole session: the arm smoother with the arm as
    static states (fuse/arm_refine.py), iterated from the sphere fit and a first pass with its
    arm; SDs from the smoother's covariance. The sphere fit stands when the refinement does
    not end finite (or meets a singular matrix), within REFINE_MAX_MOVE_M of it and, when the
    sphere fit's shoulder is above arm_auto.SHOULDER_MIN_Z_M, above that too."""
    inp, fa = prepared.inputs, session.imu.forearm_unit
    theta0, free = np.r_[est.shoulder, est.upper_arm_m, est.forearm_m], free_of(est.estimated)
    mean, sd0 = _prior(free, theta0, est.shoulder)
    s1 = dataclasses.replace(s, method="pf-constraint", smoother="rts", shoulder="fixed")
    x0, P0, first = _first_pass(prepared, arm_refine.arm_of(theta0, fa), s1)
    try:
        r = arm_refine.refine(inp.imu, inp.t, inp.z, inp.q_WB, first, x0, P0,
                              prepared.projection, s1, fa, mean, sd0, theta0)
    except np.linalg.LinAlgError:  # a singular step: the sphere fit stands
        return est
    if not (np.isfinite(r.theta).all() and np.isfinite(r.cov).all()
            and np.abs(r.theta - theta0).max() < REFINE_MAX_MOVE_M
            and (not free[2] or r.theta[2] >= min(arm_auto.SHOULDER_MIN_Z_M, theta0[2]))):
        return est
    sd = np.where(free, np.sqrt(np.maximum(np.diag(r.cov), 0.0)), 0.0)
    return dataclasses.replace(est, shoulder=r.theta[:3].copy(), upper_arm_m=float(r.theta[3]),
                               forearm_m=float(r.theta[4]), sd=sd, sphere_fit=est.as_dict(),
                               refine_iterations=r.iterations)


def profile_maximum(session: Session, prepared, est: dict, s: FuseSettings, *,
                    rounds: int = 2):
    """The maximum of the profile log-posterior log p(data | arm) + log prior (the arm
    smoother's model; each evaluation's Gauss–Newton started from a first pass with ``est``'s
    arm, so the function moves smoothly with the arm) near the refined ``est`` (arm-auto.json's
    dict, ArmEstimate.as_dict), by quadratic
    fits with steps of PROFILE_STEP_SD SDs (arm_refine.maximise_quadratic; a move of at most
    3 SDs a round): the arm (5,), its log-posterior,
    the fitted Hessian (5, 5) and the move of the constants along the flattest direction
    that lowers the log-posterior by 1 (5,). What validation/arm_auto.py measures the
    likelihood's flatness with; ``rounds = 0`` fits the curvature at ``est`` alone."""
    fa, free = session.imu.forearm_unit, free_of(est["estimated"])
    theta0 = np.r_[est["shoulder_m"], est["upper_arm_m"], est["forearm_m"]]
    mean, sd0 = _prior(free, theta0, np.asarray(est.get("sphere_fit", est)["shoulder_m"]))
    s1 = dataclasses.replace(s, method="pf-constraint", smoother="rts", shoulder="fixed")
    sd = np.r_[est["shoulder_sd_m"], est["upper_arm_sd_m"], est["forearm_sd_m"]]
    start = _first_pass(prepared, arm_refine.arm_of(theta0, fa), s1)

    def log_posterior(theta):
        return log_likelihood(session, prepared, theta, s1, start) \
            - 0.5 * float(np.sum(((theta - mean)[free] / sd0[free]) ** 2))

    L = PROFILE_STEP_SD * np.diag(np.where(free, sd, 0.0))[:, free]
    theta, top, H = arm_refine.maximise_quadratic(log_posterior, theta0, L, rounds=max(rounds, 1),
                                                  max_step=1.5, step=rounds > 0)
    w, V = np.linalg.eigh(H[np.ix_(free, free)])
    flat = np.zeros(5)  # ½|λ|δ² = 1 along the eigenvector of the eigenvalue nearest zero
    flat[free] = V[:, -1] * (np.sqrt(2.0 / -w[-1]) if w[-1] < 0 else np.inf) * np.sign(
        V[np.argmax(np.abs(V[:, -1])), -1])
    return theta, top, H, flat


def log_likelihood(session: Session, prepared, theta: np.ndarray, s: FuseSettings,
                   start=None) -> float:
    """log p(data | arm θ = (S, L1, L2)): the arm smoother's (fuse/arm_refine.py), its
    Gauss–Newton started from ``start`` (x0, P0, first pass: _first_pass's) or, without it,
    from a first pass with this arm."""
    inp, arm = prepared.inputs, arm_refine.arm_of(theta, session.imu.forearm_unit)
    x0, P0, first = start if start is not None else _first_pass(prepared, arm, s)
    return arm_refine.profile_log_likelihood(inp.imu, inp.t, inp.z, inp.q_WB, first, x0, P0,
                                             prepared.projection, s, arm)


def estimate_with_offset(session: Session, prepared, prepare_again, s: FuseSettings):
    """The arm, and the IMU's offset with it: the offset was set before the arm was known (its
    depths then from the first detection's range, no sphere), so it is set again with the
    estimated arm's depths, "auto" estimated or a declared value checked (and warned about,
    pipeline/imu_offset.py), and an "auto" offset's arm is estimated again at the new offset.
    ``prepare_again(session)`` prepares a session whose arm is declared. Returns the estimate
    and the preparation it belongs to."""
    est = estimate(session, prepared)
    known = with_arm(session, est.shoulder, est.upper_arm_m, est.forearm_m)
    known = dataclasses.replace(known, arm=dataclasses.replace(known.arm, auto=()))
    again = prepare_again(known)
    if session.sync.imu_offset_s != "auto":
        prepared = dataclasses.replace(prepared, imu_offset=again.imu_offset)
    else:
        est, prepared = estimate(session, again), again
    return refined(session, prepared, est, s), prepared


def with_arm(session: Session, shoulder, upper_arm_m: float, forearm_m: float) -> Session:
    arm = dataclasses.replace(session.arm, shoulder_m=np.asarray(shoulder, float),
                              upper_arm_m=float(upper_arm_m), forearm_m=float(forearm_m))
    return dataclasses.replace(session, arm=arm)


def resolved(session: Session, work: str | Path) -> Session:
    """The session with fuse's estimate of an "auto" arm in place (unchanged otherwise; an
    "auto" arm without an estimate stays NaN: missing, as it is)."""
    if session.arm is None or not session.arm.auto:
        return session
    est = read_arm_estimate(work)
    if est is None:
        return session
    return with_arm(session, est["shoulder_m"], est["upper_arm_m"], est["forearm_m"])
