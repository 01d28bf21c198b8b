"""What the report draws, as plain data: gathered from the work folder by pipeline/report.py."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd


@dataclass(frozen=True)
class Quality:
    frames: int = 0  # video frames in the trajectory's span
    tracked_pct: float = float("nan")  # frames with a detection, %
    imu_dropped: int | None = None  # IMU samples lost (packet-counter gaps)
    imu_gaps: int | None = None  # gaps longer than 1.5 sample intervals
    imu_longest_gap_s: float | None = None
    imu_samples: int | None = None
    reprojection_px: float = float("nan")  # board reprojection error of the calibration
    imu_offset_s: float | str | None = None
    groundtruth_offset_s: float | str | None = None


@dataclass(frozen=True)
class SessionReport:
    session_id: str
    subject: str
    date: str  # ISO date-time as recorded
    task: str
    side: str
    kind: str  # "arm", "palm" or "object"
    method: str | None  # method identifier (words.METHODS gives its plain name)
    trajectory: pd.DataFrame | None  # trajectory-METHOD.csv
    kinematics: pd.DataFrame | None  # kinematics-METHOD.csv (value cells are text)
    quality: Quality = field(default_factory=Quality)
    shoulder: np.ndarray | None = None  # (3,) m in W (arm model)
    truth_wrist: np.ndarray | None = None  # (N, 3) ground truth at the trajectory's frames
    errors: pd.DataFrame | None = None  # errors.csv, every method
    measures: pd.DataFrame | None = None  # measures.csv rows of this method
    notes: tuple[str, ...] = ()  # what could not be shown, in plain words

    def text(self) -> str:
        """Every text of the session's own (not the report's words) that a page may print."""
        return " ".join((self.session_id, self.subject, self.date, self.task, self.side,
                         self.method or "", *self.notes))

    @property
    def day(self) -> str:
        return self.date[:10] if self.date else "date not recorded"
