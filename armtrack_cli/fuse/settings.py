"""Fusion settings (recipe section [fuse]); defaults are Tao & Hu's where the paper gives them."""

from __future__ import annotations

from dataclasses import dataclass, replace

from armtrack_cli.core.errors import ConfigError, did_you_mean
from armtrack_cli.core.methods import BUILT as METHODS
from armtrack_cli.core.methods import DEFAULT_METHOD

SMOOTHERS = ("rts", "none")
SHOULDERS = ("fixed", "drifting")
HOLDS = ("linear", "sample")  # fuse/imu_fold.py
IMU_ERRORS = ("none", "causal")  # pf-constraint's a_W correction (fuse/imu_error.py)
LINEARISATIONS = ("passes", "iterated")  # its Kalman pass's (fuse/imu_error.py)
ORIENTATION_MODELS = ("gyro", "gauss-markov")  # fuse/arm_smoother.py
CAMERA_POSES = ("fixed", "board")  # fuse/camera_pose.py


@dataclass(frozen=True)
class FuseSettings:
    method: str = DEFAULT_METHOD
    particles: int = 500  # Tao & Hu IV-A
    resampling: str = "residual"  # Tao & Hu III-E ("standard residual resampling")
    pixel_sigma: float = 4.0  # px, Tao & Hu III-B
    pixel_still_tau: float = 1.0  # arm-smoother: the camera rows' variance × this where the patch
    #                               is still (detect's error correlated over τ frames there:
    #                               fuse/camera_rows.py); 1: every row independent, σ² each
    pixel_still_px: float = 0.5  # … still: the detections move less than this, px per frame
    accel_noise: float = 1.0  # m/s² per IMU sample: IMU noise, bias and the gravity leak of
    #                           a ~1° orientation error (0.17 m/s²), with margin for latency
    constraint_sigma_m: float = 0.01  # upper-arm length, Tao & Hu eq. 15 (see fuse/methods.py)
    walk_pos_m: float = 0.005  # random-walk layer (eq. 17), per frame, on positions (the paper:
    #                           0.01; with smoothing a smaller walk keeps the cloud on the
    #                           constraint, measured in docs/validation.md)
    walk_vel_m_s: float = 0.01  # … and on velocities
    pf_resample_ess: float = 1.0  # plain PF: resample when ESS < this × N (1.0: every frame)
    init_pos_sigma_m: float = 0.03
    init_vel_sigma_m_s: float = 0.05
    init_plane_m: float = 0.07  # sessions without [arm]: the start lies on z = this (m)
    ukf_alpha: float = 0.5
    ukf_beta: float = 2.0
    ukf_kappa: float = 0.0
    gate_chi2: float = 13.8  # χ²(2) at 99.9 %: a detection whose innovation Mahalanobis²
    #                         exceeds it is not used (counted as gated); 0 turns gating off.
    #                         Every method's camera update, arm-smoother's included
    reacquire_frames: int = 10  # this many gated detections in a row and the next one is used
    #                             anyway, the filter re-acquired (fuse/robust.py says how)
    reacquire_sigma_m: float = 0.10  # Gaussian filters: position SD added on re-acquiring
    reseed_share: float = 0.5  # pf-constraint: share of particles re-seeded on the ray-sphere
    #                            intersections when the colour layer collapses or re-acquires
    reseed_ess: float = 0.01  # ... collapse: ESS after the colour weights below this × N
    reseed_sigma_m: float = 0.005  # spread of the re-seeded particles about an intersection
    reseed_prior_m: float = 0.05  # SD added to the predicted cloud's when it weighs the two
    #                               intersections against each other
    kalman_passes: int = 2  # imu_error = "causal": forward Kalman passes, each linearised
    #                         about the one before (the first about the particles' own)
    kalman_linearise: str = "passes"  # imu_error = "causal": "passes" (above) or "iterated":
    #                                   one pass, each frame linearised about its own update
    kalman_velocity: float = 0.0  # pf-constraint with imu_error = "causal": after each frame
    #                               the cloud's velocities move this share of the way to the
    #                               causal Kalman pass's velocity (fuse/imu_error.py); 0: off
    imu_bias_window_s: float = 0.0  # pf-constraint: > 0 runs it on a_W less the acceleration
    #                                 error fitted causally over this many seconds of its own
    #                                 earlier estimates (fuse/imu_bias.py); 0: off
    imu_error: str = "none"  # pf-constraint: "causal" runs it on a_W corrected by the IMU's
    #                          orientation error and accelerometer bias as a forward Kalman
    #                          pass estimates them up to each frame (fuse/imu_error.py)
    smoother: str = "rts"  # offline fixed-interval smoothing of the filtered estimates; the
    #                        tao2008-* recipes set "none" to reproduce the paper's filters
    seed: int = 0
    # the orientation-aware arm smoother (method arm-smoother, fuse/arm_smoother.py)
    smoother_accel_noise: float = 0.1  # m/s² per IMU sample: what is left of the IMU's error
    #                                    once its orientation error and bias are estimated
    orientation_sd_deg: float = 2.5  # per axis, the IMU orientation error's SD: wider than an
    #                                MTw's ~1° (0.6° per axis), measured best (docs/fusion.md)
    heading_sd_deg: float = 2.5  # … and about the vertical (heading), seen only by the arm
    orientation_tau_s: float = 2.0  # its correlation time (first-order Gauss–Markov)
    orientation_model: str = "gyro"  # δθ's changes: as the gyroscope measures them ("gyro";
    #                                  without a gyro, or "gauss-markov": the process above)
    orientation_walk_deg: float = 0.05  # °/√s, δθ's change the gyro does not explain (its
    #                                     angle random walk: an MTw's 0.01 °/s/√Hz is 0.01)
    gyro_bias_sd_deg_s: float = 0.5  # °/s per axis, prior of the gyro's bias
    gyro_bias_walk_deg_s: float = 0.001  # °/s/√s, its random walk
    accel_bias_sd: float = 0.05  # m/s² per axis, prior of the accelerometer bias
    accel_bias_walk: float = 0.001  # m/s²/√s, its random walk
    imu_hold: str = "linear"  # IMU between samples: "linear" (first-order hold) or "sample"
    smoother_iterations: int = 10  # Gauss–Newton iterations at most
    branch_repair: bool = True  # after the first, runs of frames on the wrong ray–sphere root
    #                            moved to the other where the IMU agrees (fuse/branch_repair.py)
    shoulder: str = "fixed"  # "fixed" (Tao & Hu) or "drifting": shoulder and upper-arm length
    #                          states that start at the declared arm and wander (docs/fusion.md)
    shoulder_sd_m: float = 0.11  # per axis, how far the declared shoulder may be off …
    shoulder_walk_m_s: float = 0.011  # … and its random walk, m/√s per axis
    upper_arm_sd_m: float = 0.06  # how far the declared upper-arm length may be off …
    upper_arm_walk_m_s: float = 0.023  # … and its random walk, m/√s
    shoulder_offset_x_m: float = 0.0  # the drifting arm's prior mean: the centre the elbow turns
    shoulder_offset_y_m: float = 0.0  # about lies this far from the declared shoulder (W, m) …
    shoulder_offset_z_m: float = 0.0  # (docs/validation-from-mocap.md measures it; 0: declared)
    upper_arm_offset_m: float = 0.0  # … and its radius this far from the declared upper arm
    rest_velocity_sd_m_s: float = 0.0  # > 0: where the hand rests (fuse/rest.py) its velocity is
    #                                    zero within this SD (m/s, per axis); 0: off
    camera_pose: str = "fixed"  # arm-smoother: "fixed", the board's pose as calibrate solved it;
    #                            "board", corrected with it from the board's covariance as prior
    #                            (fuse/camera_pose.py)
    pre_roll_s: float = 1.0  # with the rest update: the arm smoother starts this long before the
    #                          first frame where the IMU recorded before it (fuse/arm_smoother.py)


def checked(s: FuseSettings, where: str) -> FuseSettings:
    """``s`` if every choice names something that exists, else a ConfigError naming ``where``
    (the recipe, or --set) and the valid choices."""
    from armtrack_cli.filters.resampling import SCHEMES

    if s.method not in METHODS:
        raise ConfigError(where, f"[fuse] method = {s.method!r} is not a method",
                          did_you_mean(s.method, METHODS, what="methods"))
    if s.resampling not in SCHEMES:
        raise ConfigError(where, f"[fuse] resampling = {s.resampling!r} is not a scheme",
                          did_you_mean(s.resampling, SCHEMES, what="schemes"))
    if s.smoother not in SMOOTHERS:
        raise ConfigError(where, f"[fuse] smoother = {s.smoother!r} is not a smoother",
                          did_you_mean(s.smoother, SMOOTHERS, what="smoothers"))
    if not (s.gate_chi2 >= 0 and s.reacquire_frames >= 1 and 0 <= s.reseed_share <= 1
            and s.reseed_ess >= 0 and s.reseed_sigma_m >= 0 and s.reseed_prior_m >= 0
            and s.imu_bias_window_s >= 0 and 0 <= s.kalman_velocity <= 1
            and s.kalman_passes >= 1 and s.pixel_still_tau >= 1 and s.pixel_still_px >= 0):
        raise ConfigError(where, "[fuse] gate_chi2, reacquire_frames, reseed_*, imu_bias_window_s, "
                          "kalman_velocity, kalman_passes, pixel_still_* are out of range",
                          "gate_chi2 ≥ 0 (0: off), reacquire_frames ≥ 1, 0 ≤ reseed_share ≤ 1, "
                          "reseed_ess, reseed_sigma_m, reseed_prior_m, imu_bias_window_s ≥ 0, "
                          "0 ≤ kalman_velocity ≤ 1, kalman_passes ≥ 1, pixel_still_tau ≥ 1, "
                          "pixel_still_px ≥ 0")
    for key, value, valid in (("shoulder", s.shoulder, SHOULDERS), ("imu_hold", s.imu_hold, HOLDS),
                              ("imu_error", s.imu_error, IMU_ERRORS),
                              ("kalman_linearise", s.kalman_linearise, LINEARISATIONS),
                              ("orientation_model", s.orientation_model, ORIENTATION_MODELS),
                              ("camera_pose", s.camera_pose, CAMERA_POSES)):
        if value not in valid:
            raise ConfigError(where, f"[fuse] {key} = {value!r} is not one of {', '.join(valid)}",
                              did_you_mean(value, valid, what="choices"))
    if not isinstance(s.branch_repair, bool):
        raise ConfigError(where, f"[fuse] branch_repair = {s.branch_repair!r} is not a boolean",
                          "use true or false")
    if s.smoother_iterations < 1:
        raise ConfigError(where, f"[fuse] smoother_iterations = {s.smoother_iterations} is too "
                          "few", "use 1 or more")
    if s.particles < 10:
        raise ConfigError(where, f"[fuse] particles = {s.particles} is too few", "use 10 or more")
    return s


def with_flags(s: FuseSettings, **flags) -> FuseSettings:
    """Explicit command-line flags (those not None) win over the recipe."""
    return replace(s, **{k: v for k, v in flags.items() if v is not None})
