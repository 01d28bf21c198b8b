"""A long session's inputs a window at a time (issue 15): the frames of one window
(core/windows.py) with that window's IMU samples alone, and the first window's preparation,
on which the IMU's clock offset is set (its check or "auto" estimate) and an "auto" arm
estimated: the span the recording guide asks the calibration movement to be in."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from armtrack_cli.core import quaternion as quat
from armtrack_cli.core.errors import DataError
from armtrack_cli.core.limits import REACH_MARGIN_M
from armtrack_cli.core.windows import MARGIN_S, WINDOW_S, Window, windows
from armtrack_cli.fuse import models
from armtrack_cli.fuse.arm_smoother import ImuSamples
from armtrack_cli.fuse.gyro_orientation import gyro_anchored
from armtrack_cli.fuse.methods import Inputs
from armtrack_cli.pipeline.imu_offset import AUTO_SEARCH_S, resolve_imu_offset
from armtrack_cli.session.spill import Spill

PAD_S = 1.0  # IMU samples read beyond a window's last frame (and before its first, at least
#              the arm smoother's pre_roll_s): the IMU held over its first and last steps


@dataclass(frozen=True)
class Sources:
    """What every window reads from: the video's frame times t_f (K,) s, which have a
    detection (K,) bool and the detections by row range (uv_rows: (n, 2) px, NaN = none;
    kept on disk), the IMU by span (pipeline/fuse_imu.py), the camera."""

    dest: Path
    t_f: np.ndarray
    det: np.ndarray
    uv: Spill  # its column "uv"
    imu: object  # fuse_imu.ArrayImu or SpilledImu
    projection: models.Projection

    def uv_rows(self, a: int, b: int) -> np.ndarray:
        return self.uv.read(a, b)["uv"]

    def close(self) -> None:
        """The files kept on disk removed."""
        self.uv.close()
        self.imu.close()


def span_inputs(src: Sources, offset: float, frames: np.ndarray, s) -> tuple | None:
    """(frames from the first detection among ``frames`` on, their Inputs with the IMU's
    samples of that span alone, on the session clock), or None when none has a detection."""
    det = src.det[frames]
    if not det.any():
        return None
    frames = frames[int(np.flatnonzero(det)[0]):]  # consecutive
    t_fr = src.t_f[frames]
    r = held_rows(src.imu, t_fr[0] - max(PAD_S, s.pre_roll_s) - offset,
                  t_fr[-1] + PAD_S - offset)
    t = r.t + offset  # session time = stream time + offset
    steps = models.composite_steps(t, models.accel_world(r.quat, r.acc), t_fr,
                                   accel_noise=s.accel_noise, imu_period=1.0 / src.imu.rate_hz)
    uv = src.uv_rows(int(frames[0]), int(frames[-1]) + 1)
    return frames, Inputs(steps, uv, quat.interpolate(t, r.quat, t_fr), t=t_fr,
                          imu=ImuSamples(t, r.quat, r.acc, r.gyr), release_imu=True)


def held_rows(imu, lo: float, hi: float):
    """imu.rows(lo, hi) (s, the IMU's clock), with the last sample before lo and the first
    after hi where a gap in the recording meets that end: the samples a whole-session run
    holds over the gap (models.composite_steps) and interpolates the orientation across.
    Without them a window starting in a gap had no orientation at its first frames (NaN:
    _initial_state failed, "min() arg is an empty sequence") and no acceleration there."""
    r = imu.rows(lo, hi)
    near = 1.5 / imu.rate_hz  # a sample this near an end: no gap there
    a = _beyond(imu, lo, -1) if (not r.t.size or r.t[0] - lo > near) else lo
    b = _beyond(imu, hi, +1) if (not r.t.size or hi - r.t[-1] > near) else hi
    return r if (a, b) == (lo, hi) else imu.rows(a, b)


def _beyond(imu, x: float, side: int) -> float:
    """The time of the IMU's nearest usable sample at or before (side -1) or at or after
    (+1) x, read over spans growing fourfold from PAD_S; x itself when there is none."""
    if (side < 0 and x <= imu.t_first) or (side > 0 and x >= imu.t_last):
        return x
    k = PAD_S
    while True:
        r = imu.rows(x - k, x) if side < 0 else imu.rows(x, x + k)
        if r.t.size:
            return float(r.t[-1] if side < 0 else r.t[0])
        k *= 4


def explained_from(src: Sources, offset: float, frames: np.ndarray, arm) -> np.ndarray:
    """``frames`` from the first detection among them whose camera ray the arm can reach
    (models.ray_misses_arm within REACH_MARGIN_M, at the IMU's orientation there), for a
    window after the first: a whole session's run meets a false detection there mid-stream
    and gates it (fuse/robust.py), while a window that started from it would be refused
    whole by _initial_state's check, the session with it. Empty when none is; ``frames``
    as they are without an arm."""
    if arm is None:
        return frames
    for j in np.flatnonzero(src.det[frames]):
        k = int(frames[j])
        t = float(src.t_f[k])
        r = src.imu.rows(t - PAD_S - offset, t + PAD_S - offset)
        q = quat.interpolate(r.t + offset, r.quat, np.array([t]))[0] if r.t.size else None
        if q is None or not np.isfinite(q).all() or models.ray_misses_arm(
                src.projection, src.uv_rows(k, k + 1)[0], arm, q) <= REACH_MARGIN_M:
            return frames[j:]  # (no IMU there: span_inputs and _initial_state say so)
    return frames[:0]


def session_frames(src: Sources, offset: float) -> slice:
    """The frames fuse runs over, as prepare() takes them: inside the IMU's span, from the
    first detection to the last frame."""
    inside = (src.t_f >= src.imu.t_first + offset) & (src.t_f <= src.imu.t_last + offset)
    det = inside & src.det
    if not det.any():
        raise DataError(src.dest / "detections.csv", "no detection falls inside the IMU "
                        "recording", "check [sync] imu_offset_s and that the patch was found")
    return slice(int(np.flatnonzero(det)[0]), int(np.flatnonzero(inside)[-1]) + 1)


def first_offset(session, src: Sources, arm, *, beside: bool) -> tuple[float, object]:
    """The IMU's offset (pipeline/imu_offset.py) on the first window's span alone: the frames
    within WINDOW_S + 2 MARGIN_S of the first detection the IMU can reach (its span at the
    declared offset, or at 0 for "auto", and AUTO_SEARCH_S + PAD_S either side: an IMU
    switched on minutes after the camera), the IMU's samples there and AUTO_SEARCH_S + PAD_S
    either side: its cost and memory as a one-window session's."""
    declared = session.sync.imu_offset_s != "auto"
    c = float(session.sync.imu_offset_s) if declared else 0.0
    pad = AUTO_SEARCH_S + PAD_S
    reach = (src.t_f >= src.imu.t_first + c - pad) & (src.t_f <= src.imu.t_last + c + pad)
    det = np.flatnonzero(src.det & reach)
    if det.size == 0:
        raise DataError(src.dest / "detections.csv", "no detection falls inside the IMU "
                        "recording", "check [sync] imu_offset_s and that the patch was found")
    lo = src.t_f[det[0]]
    span = Window(-np.inf, np.inf, lo, lo + WINDOW_S + 2 * MARGIN_S).read(src.t_f)
    r = src.imu.rows(src.t_f[span.start] - c - pad, src.t_f[span.stop - 1] - c + pad)
    if r.t.size < 3:
        raise DataError(src.dest / "detections.csv", "no detection falls inside the IMU "
                        "recording", "check [sync] imu_offset_s and that the patch was found")
    q_anch = gyro_anchored(r.t, r.quat, r.gyr)
    return resolve_imu_offset(session, session.imu.file, r.t, q_anch,
                              models.accel_world(q_anch, r.acc), src.t_f[span],
                              src.uv_rows(span.start, span.stop),
                              src.projection, arm, beside=beside)


def layout(src: Sources, offset: float) -> tuple[slice, list[Window]]:
    """The session's frames (a range) and its windows over them."""
    frames = session_frames(src, offset)
    return frames, windows(float(src.t_f[frames.start]), float(src.t_f[frames.stop - 1]))


def window_frames(src: Sources, frames: slice, w: Window) -> np.ndarray:
    """The session's frames a window reads (its inner span and margins)."""
    r = w.read(src.t_f[frames])
    return np.arange(frames.start + r.start, frames.start + r.stop)
