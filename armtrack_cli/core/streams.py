"""The streams a session holds, as frozen dataclasses of time-first arrays.

Each stream keeps its own clock (seconds from its first sample). Missing values are NaN,
never zeros; dropped samples are simply absent rows, with their neighbours at true times.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class ImuSamples:
    """A wrist IMU recording, converted to the contract's conventions by its reader.

    t:    (N,) float64 s, stream clock, t[0] == 0, strictly increasing.
    acc:  (N, 3) specific force in B, m/s² (at rest, B = W: (0, 0, +9.81)). NaN = missing.
    gyr:  (N, 3) angular rate in B, rad/s. NaN = missing.
    mag:  (N, 3) magnetic field in B, µT (any consistent unit for orientation use), or None.
    quat: (N, 4) (w, x, y, z) rotating B into W, or None when the file has no orientation.
    """

    path: str
    fmt: str
    t: np.ndarray
    acc: np.ndarray
    gyr: np.ndarray
    mag: np.ndarray | None
    quat: np.ndarray | None
    rate_hz: float
    dropped: int = 0
    orientation_source: str = "file"
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def n(self) -> int:
        return int(self.t.shape[0])

    @property
    def duration_s(self) -> float:
        return float(self.t[-1] - self.t[0]) if self.n else 0.0


@dataclass(frozen=True)
class ImuRows:
    """Samples of an IMU recording on its clock, a chunk or a span of them: t (M,) s, quat
    (M, 4) B -> W, acc (M, 3) m/s², gyr (M, 3) rad/s (NaN where the file has no gyroscope)."""

    t: np.ndarray
    quat: np.ndarray
    acc: np.ndarray
    gyr: np.ndarray


@dataclass(frozen=True)
class MarkerTrajectories:
    """Optical markers (Qualisys), in the capture system's own frame.

    t:   (N,) float64 s, stream clock from the first frame.
    xyz: (N, M, 3) metres; NaN where the marker was not seen.
    rotations: (N, M, 3, 3) body -> capture frame for rigid bodies (QTM 6DOF), else None.
    """

    path: str
    t: np.ndarray
    names: tuple[str, ...]
    xyz: np.ndarray
    rate_hz: float
    notes: tuple[str, ...] = field(default_factory=tuple)
    rotations: np.ndarray | None = None

    def marker(self, name: str) -> np.ndarray:
        """(N, 3) positions of one marker."""
        return self.xyz[:, self.names.index(name), :]


@dataclass(frozen=True)
class VideoStream:
    """What a camera recording holds (frames are streamed, never all held).

    t: (N,) float64 s on the session clock (frame i at i / fps unless video_timestamps.csv).
    """

    path: str
    source: str  # "file" or "mcap"
    n_frames: int
    fps: float
    width: int
    height: int
    t: np.ndarray
    timestamps_from: str  # "fps", "video_timestamps.csv" or "mcap"
    topic: str | None = None


@dataclass(frozen=True)
class CameraModel:
    """Pinhole camera with OpenCV distortion; optionally its pose X_C = R_WC X_W + T_WC."""

    K: np.ndarray  # (3, 3)
    dist: np.ndarray  # (k,) OpenCV order k1 k2 p1 p2 [k3 ...]
    width: int
    height: int
    R_WC: np.ndarray | None = None  # (3, 3)
    T_WC: np.ndarray | None = None  # (3,) m
    reprojection_error_px: float | None = None

    @staticmethod
    def centre(R_WC: np.ndarray, T_WC: np.ndarray) -> np.ndarray:
        """The optical centre in W: X_C = 0 at X_W = −R_WCᵀ T_WC."""
        return -R_WC.T @ T_WC

    @property
    def centre_W(self) -> np.ndarray:
        """(3,) m, the camera's optical centre in W (needs the pose)."""
        return self.centre(self.R_WC, self.T_WC)


def time_gaps(t: np.ndarray, nominal_dt: float, factor: float = 1.5) -> np.ndarray:
    """Indices i where t[i+1] - t[i] exceeds ``factor`` nominal periods (a gap after sample i)."""
    if t.size < 2:
        return np.zeros(0, dtype=int)
    return np.flatnonzero(np.diff(t) > factor * nominal_dt)
