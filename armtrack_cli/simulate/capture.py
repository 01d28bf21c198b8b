"""What every simulated session shares: the Qualisys frame and its markers, the lighting
flicker and sensor noise of the camera."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Qualisys frame -> W (to_world): the capture volume's axes are turned 90° about z from the
# board's and its origin lies elsewhere on the floor plan; z is up in both.
QTM_TO_WORLD = np.array([[0.0, -1.0, 0.0, 0.62], [1.0, 0.0, 0.0, -0.31], [0.0, 0.0, 1.0, 0.0],
                         [0.0, 0.0, 0.0, 1.0]])


def qualisys_markers(xyz_w: np.ndarray, noise_m: float, gaps: int, gap_marker: int,
                     rate_hz: float, rng: np.random.Generator) -> np.ndarray:
    """(N, M, 3) markers in the Qualisys frame (m): Rᵀ(X_W − T) plus noise, NaN gaps of
    0.1-0.4 s in marker ``gap_marker``."""
    R, T = QTM_TO_WORLD[:3, :3], QTM_TO_WORLD[:3, 3]
    xyz = (xyz_w - T) @ R + noise_m * rng.standard_normal(xyz_w.shape)
    n = xyz.shape[0]
    for _ in range(gaps):
        k, length = int(rng.integers(0, max(n - 50, 1))), int(rng.uniform(0.1, 0.4) * rate_hz)
        xyz[k:k + length, gap_marker] = np.nan
    return xyz


def to_world_toml() -> str:
    return "[" + ",".join("[" + ",".join(f"{v:g}" for v in row) + "]" for row in QTM_TO_WORLD) + "]"


class CameraNoise:
    """Per-frame lighting gain (0.7 Hz flicker + jitter) and a pool of sensor-noise images."""

    def __init__(self, seed: int, height: int, width: int, sigma: float = 2.0, pool: int = 6):
        self.rng = np.random.default_rng([seed, 7])
        self.pool = [self.rng.normal(0, sigma, (height, width, 3)).astype(np.float32)
                     for _ in range(pool)]

    def __call__(self, t: float) -> tuple[float, np.ndarray]:
        gain = 1.0 + 0.03 * np.sin(2 * np.pi * 0.7 * t) + self.rng.normal(0, 0.005)
        return gain, self.pool[self.rng.integers(len(self.pool))]


@dataclass(frozen=True)
class CaptureSettings:
    """What every simulated session sets: its length and seed, the camera, Qualisys."""

    duration_s: float = 20.0
    seed: int = 0
    fps: float = 30.0
    width: int = 640
    height: int = 480
    distortion: bool = True
    qualisys_hz: float = 100.0
    marker_noise_m: float = 0.0003
    gt_gaps: int = 0  # number of 0.1-0.4 s gaps in a Qualisys marker
    groundtruth_offset_s: float = -1.5  # session time = Qualisys time + offset
    calib_images: int = 0  # board images for intrinsic calibration (calib/); 0: intrinsics.yaml
