"""What fuse refuses or blanks in an estimate before it is written, and the words it says
so in: one place for the whole-session run (pipeline/fuse.py) and the windowed one
(pipeline/fuse_windows.py)."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from armtrack_cli.core.errors import DataError
from armtrack_cli.core.limits import MAX_OBJECT_RANGE_M, REACH_MARGIN_M
from armtrack_cli.fuse.trajectory import impossible_rows


def beyond_reach(table: dict, arm) -> np.ndarray:
    """Rows whose wrist no arm of this model reaches (or beyond any object, without an arm)."""
    return impossible_rows(table, shoulder=arm.shoulder if arm else None,
                           reach_m=arm.L1 + arm.L2 + REACH_MARGIN_M if arm else None,
                           bound_m=MAX_OBJECT_RANGE_M)


def diverged(path: Path, method: str, t_bad: float, arm) -> DataError:
    """The error for an estimate that stops being finite at ``t_bad`` (s)."""
    return DataError(path, f"{method} diverged: its estimate is not finite from "
                     f"t = {t_bad:.3f} s; nothing was written",
                     ("check [arm] (shoulder_m, upper_arm_m, forearm_m), " if arm else "")
                     + "check the detections and the IMU, or try another method")


def nowhere_in_reach(path: Path, method: str) -> DataError:
    """The error for an estimate outside the arm's reach in every frame."""
    return DataError(path, f"{method} left the arm's reach in every frame; nothing was "
                     "written", "check [arm], [sync] and the detections")


def warn_blanked(path: Path, method: str, far: int, rows: int) -> None:
    """One warning line for the frames left empty because no wrist can be there."""
    warnings.warn(f"{path}: {far} of {rows} frames put the wrist where no wrist can be "
                  f"({method} drifted); they are left empty", stacklevel=2)
