"""IMU measurements from exact kinematics, with documented, overridable error levels.

Specific force f_B = R_WBᵀ (a_W − g_W), g_W = (0, 0, −9.81) (SESSION_FORMAT.md: at rest with
B = W the accelerometer reads (0, 0, +9.81)); gyro = body angular rate ω_B. The output
orientation is the truth turned by a slowly varying error of about 1° RMS (MT9/MTw class).
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np
from scipy.signal import butter, sosfiltfilt

from armtrack_cli.core import quaternion as quat

GRAVITY_W = np.array([0.0, 0.0, -9.81])


@dataclass(frozen=True)
class ImuErrors:
    """Error levels of the simulated IMU (SI units). Defaults: an MT9/MTw-class sensor."""

    acc_noise: float = 0.02  # m/s², white, per axis
    acc_bias: float = 0.03  # m/s², constant, per axis (random sign)
    acc_residual: float = 0.0  # m/s², RMS of a 0-10 Hz band-limited residual
    acc_scale: float = 0.0  # fractional scale error, up to this per axis
    gyro_noise: float = 0.005  # rad/s, white
    gyro_bias: float = 0.0  # rad/s, constant, per axis (random sign)
    orientation_rms_deg: float = 1.0  # slowly varying orientation error of the output
    latency_s: float = 0.0  # the sensor reports the state this long ago

    @classmethod
    def preset(cls, name: str) -> ImuErrors:
        if name == "mtw":
            return cls()
        if name == "consumer":
            # Levels measured for a consumer-grade IMU against optical truth (brief, issue 3):
            # gyro bias 0.4-0.6 °/s, acc noise 0.05 m/s² + 0-10 Hz residual up to 0.3 m/s²,
            # scale error up to 2 %, about 4 ms latency.
            return cls(acc_noise=0.05, acc_bias=0.05, acc_residual=0.1, acc_scale=0.02,
                       gyro_noise=0.01, gyro_bias=np.deg2rad(0.5), orientation_rms_deg=2.0,
                       latency_s=0.004)
        if name == "ideal":
            return cls(**{f.name: 0.0 for f in fields(cls)})
        raise ValueError(f"unknown IMU preset {name!r}; presets are mtw, consumer, ideal")

    def override(self, **kw: float) -> ImuErrors:
        return replace(self, **{k: float(v) for k, v in kw.items() if v is not None})


def specific_force(q_WB: np.ndarray, acc_W: np.ndarray) -> np.ndarray:
    """f_B = R_WBᵀ (a_W − g_W)."""
    return quat.rotate(quat.conjugate(q_WB), acc_W - GRAVITY_W)


def orientation_error(t: np.ndarray, rms_deg: float, rng: np.random.Generator) -> np.ndarray:
    """(N, 4) slowly varying error rotations: a sum of sinusoids (0.02-0.2 Hz) per axis,
    scaled so the error angle has the requested RMS."""
    if rms_deg == 0:
        return np.tile([1.0, 0, 0, 0], (t.size, 1))
    freqs = rng.uniform(0.02, 0.2, (3, 3))
    phases = rng.uniform(0, 2 * np.pi, (3, 3))
    v = np.stack([np.sum(np.sin(2 * np.pi * freqs[k][:, None] * t + phases[k][:, None]), 0)
                  for k in range(3)], -1)
    v *= np.deg2rad(rms_deg) / np.sqrt(np.mean(np.sum(v**2, -1)))
    ang = np.linalg.norm(v, axis=-1)
    axis = v / np.maximum(ang, 1e-12)[:, None]
    return quat.from_axis_angle(axis, ang)


def measure(t: np.ndarray, q_WB: np.ndarray, acc_W: np.ndarray, omega_B: np.ndarray,
            errors: ImuErrors, rate_hz: float, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Noisy accelerometer, gyro and output orientation at times t (already latency-shifted)."""
    n = t.size
    sign = lambda: rng.choice([-1.0, 1.0], 3)  # noqa: E731
    acc_bias = errors.acc_bias * sign()
    gyro_bias = errors.gyro_bias * sign()
    scale = 1.0 + errors.acc_scale * rng.uniform(-1, 1, 3)
    f = specific_force(q_WB, acc_W) * scale + acc_bias + errors.acc_noise * rng.standard_normal((n, 3))
    if errors.acc_residual > 0 and n > 30:
        sos = butter(4, min(10.0, 0.45 * rate_hz), fs=rate_hz, output="sos")
        r = sosfiltfilt(sos, rng.standard_normal((n, 3)), axis=0)
        f += errors.acc_residual * r / r.std(axis=0)
    g = omega_B + gyro_bias + errors.gyro_noise * rng.standard_normal((n, 3))
    q_out = quat.multiply(orientation_error(t, errors.orientation_rms_deg, rng), q_WB)
    return {"acc": f, "gyr": g, "quat": quat.normalize(q_out), "acc_bias": acc_bias,
            "gyro_bias": gyro_bias, "acc_scale": scale}
