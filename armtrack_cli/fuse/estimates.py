"""What a method takes (``Inputs``: per camera frame, the IMU's step into it, the detection,
the IMU's orientation) and what it gives (``Estimates``: per frame, the wrist's mean and
covariance and what the method adds); fuse/methods.py runs the methods between them."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from armtrack_cli.fuse.arm_smoother import ImuSamples
    from armtrack_cli.fuse.models import Steps


@dataclass(frozen=True)
class Inputs:
    """Per camera frame k: the composite IMU step into k, the detection (NaN = none), the IMU
    orientation at the frame time."""

    steps: Steps  # None once the arm smoother lets it go (drop_steps)
    z: np.ndarray  # (n_frames, 2) px, NaN where the patch was not detected
    q_WB: np.ndarray  # (n_frames, 4)
    t: np.ndarray | None = None  # (n_frames,) s, the frames' times (arm-smoother)
    imu: ImuSamples | None = None  # the IMU samples themselves (arm-smoother)
    release_imu: bool = False  # the arm smoother takes ``imu`` away once it has them
    #                            (take_imu), and ``steps`` once its first pass is done
    #                            (drop_steps): fuse's inputs, run once (issue 15)

    def take_imu(self) -> ImuSamples | None:
        """``imu``; with release_imu, this Inputs (whoever holds it) holds them no more, so
        that they are freed as soon as the taker lets them go."""
        imu = self.imu
        if self.release_imu:
            object.__setattr__(self, "imu", None)  # frozen but for this hand-over
        return imu

    def drop_steps(self) -> None:
        """With release_imu, ``steps`` let go (None): the arm smoother folds the IMU's samples
        itself, and its first pass, the last to step the filter's model, is done."""
        if self.release_imu:
            object.__setattr__(self, "steps", None)


@dataclass(frozen=True)
class Estimates:
    mean: np.ndarray  # (n_frames, 6) wrist position and velocity
    cov: np.ndarray | None  # (n_frames, 6, 6); None where the method keeps ``var`` alone;
    #                         (n_frames, 21), the upper triangles, where only the means-only
    #                         smoother reads them (methods.run_particles, packed)
    ess: np.ndarray | None  # (n_frames,) particle filters only
    codes: np.ndarray | None = None  # (n_frames,) what became of each detection (robust.USED…)
    q_WB: np.ndarray | None = None  # (n_frames, 4) orientation corrected by the method, if any
    elbow_var: np.ndarray | None = None  # (n_frames, 3) where the method estimates it
    summary: dict | None = None  # what the method adds to fuse's summary
    var: np.ndarray | None = None  # (n_frames, 6) cov's diagonal, where cov is not kept

    @property
    def sd(self) -> np.ndarray:
        var = np.diagonal(self.cov, axis1=1, axis2=2) if self.var is None else self.var
        return np.sqrt(np.maximum(var, 0.0))
