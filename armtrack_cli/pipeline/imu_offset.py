"""The IMU's clock offset for fuse: declared in [sync] imu_offset_s and checked against the
data, or "auto" and estimated from it (fuse/imu_sync.py). As compare does for the ground
truth (pipeline/compare.py): the estimate, its SD, ``from: auto|declared``, and one warning
line when a declared value disagrees with the data by more than 3 SD (and WARN_FLOOR_S)."""

from __future__ import annotations

import warnings
from functools import partial
from pathlib import Path

import numpy as np

from armtrack_cli.core.errors import DataError
from armtrack_cli.core.threads import Done, Lazy, Then
from armtrack_cli.fuse import models
from armtrack_cli.fuse.imu_sync import ImuOffset, SyncProblem, estimate_imu_offset
from armtrack_cli.fuse.sync_windows import check_windows

AUTO_SEARCH_S = 3.0  # "auto": offsets from −3 to +3 s are searched
CHECK_SEARCH_S = 0.5  # a declared offset is checked within ±0.5 s of itself
WARN_FLOOR_S = 0.05  # … and warned about beyond 3 SD and beyond this: the estimator's own
#                      error stays within 10 ms on the simulated tasks, but a real session's
#                      unmodelled errors may not (docs/validation-sync.md)


def resolve_imu_offset(session, imu_file: Path, t_imu: np.ndarray, q_WB: np.ndarray,
                       a_W: np.ndarray, t_frames: np.ndarray, uv: np.ndarray,
                       proj: models.Projection, arm: models.Arm | None, *,
                       beside: bool = False) -> tuple[float, Then | Done]:
    """The offset to use (s; session time = IMU time + offset) and how it was set (its
    ``result()``: a dict). t_imu, q_WB, a_W: the IMU's valid samples on its own clock;
    t_frames, uv: the detections on the session clock (NaN = none). With ``beside``, a
    declared offset's check (which cannot change the offset used, only warn) runs on a second
    thread while the caller goes on (core/threads.py); its warning comes with ``result()``,
    on the caller's thread. The check scores a long session's most informative windows
    (fuse/sync_windows.py): its cost and memory do not grow with the session, so it runs
    beside however long the session."""
    declared = session.sync.imu_offset_s != "auto"
    centre = float(session.sync.imu_offset_s) if declared else 0.0
    if declared and session.arm is not None and session.arm.auto:
        # the check takes its depths from the arm, which fuse estimates after the offset; it
        # checks then (pipeline/arm_model.estimate_with_offset)
        return centre, Done({"value": centre, "from": "declared",
                             "unchecked": '[arm] is "auto": estimated after the offset'})
    problem = SyncProblem(t_imu, a_W, q_WB, t_frames, uv, proj, arm)
    search = CHECK_SEARCH_S if declared else AUTO_SEARCH_S
    if declared:
        problem = check_windows(problem, centre, search)  # here: the whole arrays let go
        if beside:
            return centre, Then(Lazy(estimate_imu_offset, problem, centre_s=centre,
                                     search_s=search), partial(_judged, imu_file, centre))
        return centre, Done(_judged(imu_file, centre, estimate_imu_offset(
            problem, centre_s=centre, search_s=search)))
    off = estimate_imu_offset(problem, centre_s=centre, search_s=search)
    if off is None or not np.isfinite(off.sd_s):
        raise DataError(imu_file, "its clock offset cannot be estimated: within "
                        f"±{AUTO_SEARCH_S:g} s too few frames with a detection meet the "
                        "IMU's recording", "declare [sync] imu_offset_s in seconds")
    return off.estimate_s, Done({"value": round(off.estimate_s, 4), "sd": round(off.sd_s, 4),
                                 "from": "auto", "frames": off.frames})


def _judged(imu_file: Path, centre: float, off: ImuOffset | None) -> dict:
    """How a declared offset was set, with the data's estimate and SD; one warning line when
    they disagree by more than 3 SD (and WARN_FLOOR_S)."""
    info = {"value": centre, "from": "declared"}
    if off is not None and np.isfinite(off.sd_s):
        info.update(estimate=round(off.estimate_s, 4), sd=round(off.sd_s, 4))
        if abs(off.estimate_s - centre) > max(3 * off.sd_s, WARN_FLOOR_S):
            warnings.warn(f"{imu_file}: the data put its clock offset at {off.estimate_s:+.3f} "
                          f"± {off.sd_s:.3f} s, not the declared {centre:+.3f} s; check [sync] "
                          "imu_offset_s", stacklevel=1)
    return info
