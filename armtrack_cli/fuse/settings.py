"""Fusion settings (recipe section [fuse]); defaults are Tao & Hu's where the paper gives them."""

from __future__ import annotations

from dataclasses import dataclass

METHODS = ("inertial", "ekf", "ukf", "pf", "pf-constraint")
PALM_METHODS = ("ukf-palm",)  # Cordella et al.: palm sessions (pipeline/palm.py)
SMOOTHERS = ("rts", "none")


@dataclass(frozen=True)
class FuseSettings:
    method: str = "pf-constraint"
    particles: int = 500  # Tao & Hu IV-A
    resampling: str = "residual"  # Tao & Hu III-E ("standard residual resampling")
    pixel_sigma: float = 4.0  # px, Tao & Hu III-B
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
    smoother: str = "rts"  # offline fixed-interval smoothing of the filtered estimates; the
    #                        tao2008-* recipes set "none" to reproduce the paper's filters
    seed: int = 0
