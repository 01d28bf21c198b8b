"""The IMU's orientation with its slowly varying error taken out by the gyroscope.

An MTw-class sensor's reported orientation q_k = E_k q_true,k carries an error E_k of about
1° that wanders over 5–50 s (its filter's magnetometer and accelerometer corrections), while
its gyroscope, integrated over a session's tens of seconds, turns exactly as the sensor does
(bias-compensated on board; the white noise's random walk is ~0.1° over 20 s). So:

    G_k = G_(k−1) ⊗ exp(½ ω_(k−½) Δt_k)           the gyro's integration (q̇ = ½ q ⊗ (0, ω))
    q_g,k = q_0 ⊗ G_k                              started at the first reported orientation
    e_k = log(q_k ⊗ q_g,k*)                        = E_k E_0⁻¹ (a world-frame rotation vector)
    a = mean_k e_k                                 (≈ log Ē E_0⁻¹)
    q̂_k = exp(a) ⊗ q_g,k                          = Ē q_true,k

leaves one constant error Ē (the reported error's mean over the span, a fraction of a degree)
instead of a wandering one, whose gravity leak Ē × g is a constant acceleration: a linear
velocity drift that any drift model absorbs without absorbing the motion. No trend is fitted
beside a: the reported error's own slow wander would pass into it (a gyro bias, which a trend
would model, is compensated on board in MTw-class sensors). Where the gyro is missing (NaN)
the step turns as the reported orientation does, and so does a step across dropped packets
(longer than 10 sample periods), whose rates are unknown.
"""

from __future__ import annotations

import numpy as np

from armtrack_cli.core import quaternion as quat


def gyro_steps(t: np.ndarray, gyr_B: np.ndarray) -> np.ndarray:
    """(M − 1, 4) the body's rotation over each IMU interval from the gyro's rates (M, 3)
    rad/s in B at t (M,) s, trapezoidal (q̇ = ½ q ⊗ (0, ω)); NaN where a rate is missing."""
    return quat.from_rotvec(0.5 * (gyr_B[1:] + gyr_B[:-1]) * np.diff(t)[:, None])


GAP_PERIODS = 10  # a step this many sample periods long spans dropped packets (module doc)


def gap_steps(t: np.ndarray) -> np.ndarray:
    """(M − 1,) bool: the IMU intervals longer than GAP_PERIODS median periods, dropped
    packets whose rates are unknown: the trapezoid would turn the body through the gap at
    its edges' mean rate (a 2 s gap in circling put the anchored orientation tens of degrees
    off for the rest of the session); the sensor's own filter ran through it."""
    d = np.diff(t)
    return d > GAP_PERIODS * np.median(d) if d.size else np.zeros(0, bool)


def integrate_gyro(t: np.ndarray, q_WB: np.ndarray, gyr_B: np.ndarray) -> np.ndarray:
    """(M, 4) q_0 ⊗ G_k: the gyro's rates (M, 3) rad/s in B, trapezoidal over each step,
    turning the first reported orientation q_WB[0]; a step without both rates, or across
    dropped packets (gap_steps), turns as the reported orientations do."""
    steps = gyro_steps(t, gyr_B)
    bad = ~np.isfinite(steps).all(axis=1) | gap_steps(t)
    if bad.any():  # the reported relative turn q_(k−1)* ⊗ q_k over those steps
        steps[bad] = quat.multiply(quat.conjugate(q_WB[:-1][bad]), q_WB[1:][bad])
    return quat.normalize(prefix_products(np.concatenate([quat.normalize(q_WB[:1]), steps])))


def prefix_products(q: np.ndarray) -> np.ndarray:
    """(M, 4) the running products q_0 ⊗ q_1 ⊗ … ⊗ q_k of (M, 4) quaternions, by doubling
    (Hillis & Steele 1986): pass j multiplies each product by the one 2^j before it, so
    ⌈log₂ M⌉ vectorised passes replace M sequential ones (the product is associative; the
    order of the factors is kept)."""
    out = np.array(q, dtype=float)
    step = 1
    while step < out.shape[0]:
        out[step:] = quat.multiply(out[:-step], out[step:])
        step *= 2
    return out


def gyro_anchored(t: np.ndarray, q_WB: np.ndarray, gyr_B: np.ndarray | None) -> np.ndarray:
    """(M, 4) the orientation with its wandering error replaced by one constant (module
    docstring); t (M,) s, q_WB (M, 4) reported, gyr_B (M, 3) rad/s. Without a gyroscope (None
    or all NaN) the reported orientation, unchanged."""
    if gyr_B is None or t.size < 3 or not np.isfinite(gyr_B).any():
        return q_WB
    q_g = integrate_gyro(t, q_WB, gyr_B)
    e = quat.to_rotvec(quat.multiply(quat.normalize(q_WB), quat.conjugate(q_g)))
    return quat.normalize(quat.multiply(quat.from_rotvec(e.mean(axis=0)), q_g))
