"""The hand at rest, from the data, and what rest tells the arm smoother: its velocity is zero.

A camera sees the wrist's depth along its ray only through the arm constraint and the IMU's
double integral. Over the few seconds of a real trial an accelerometer bias of 0.03 m/s² or a
1° tilt (a 0.17 m/s² gravity leak) moves that integral by centimetres, and the camera cannot
see it along the ray. Where the hand rests, as at the start and end of most reaching and
drinking trials, the whole velocity is zero, along the ray too: a zero-velocity update
(ZUPT; Foxlin 2005, "Pedestrian tracking with shoe-mounted inertial sensors", IEEE CG&A 25(6))
pins it, and with it the acceleration error that would otherwise integrate there.

Rest is detected as Skog et al. 2010 ("Zero-velocity detection — an algorithm evaluation",
IEEE TBME 57(11)) test it — the gyroscope's rate and the specific force's departure from g
small over a window — and here also the patch still in the image over that window (a hand
moving slowly and straight can keep the IMU quiet; the camera sees it move). The gyroscope
must be quiet at every sample of the window (a turn is motion however short); the specific
force's departure from g is taken as its RMS over the window, as Skog's statistic averages
it: an every-sample test fails by chance on an accelerometer's white noise and on the
sub-millimetre tremor of a resting hand, whose accelerations (0.1-0.25 m/s² peaks on the
UE-ADL recordings' still spans) average out (docs/validation-from-mocap.md).

``with_rows`` hands the zero-velocity rows to the smoother kernel (fuse/smoother_kernel.py,
which takes one scalar row per step besides the camera's) as zero-length steps inserted
after each rest frame (F = I, b = 0, Q = 0: the state does not change across them), each
carrying one axis of v = 0, a block of frames at a time (arm_smoother._iterate); only the
real rows are kept.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armtrack_cli.fuse.models import GRAVITY_W

G = float(np.linalg.norm(GRAVITY_W))
V_ = slice(3, 6)  # the velocity's place in the arm smoother's state


@dataclass(frozen=True)
class RestTest:
    window_s: float = 0.3  # every IMU sample and detection within ±window/2 of the frame
    gyro_rad_s: float = 0.1  # |ω| below this (a resting hand's tremor: a few 0.01 rad/s)
    accel_m_s2: float = 0.15  # | |f| − g |, RMS over the window, below this
    px: float = 1.5  # the patch's centre moves less than this (max − min, per axis)


def _window_all(t: np.ndarray, ok: np.ndarray, centres: np.ndarray, half: float,
                least: float | None = None) -> np.ndarray:
    """For each centre time, whether ok holds at every t within ±half (and t covers it).
    ``least``: the window may be cut at t's first sample (the IMU's start, before the video)
    if at least this much of it remains."""
    bad = np.r_[0, np.cumsum(~ok)]
    lo = np.searchsorted(t, centres - half, side="left")
    hi = np.searchsorted(t, centres + half, side="right")
    first = centres - half if least is None else np.maximum(centres - half, t[0])
    need = 2 * half if least is None else least
    covered = (first >= t[0]) & (centres + half - first >= need - 1e-9) & (centres + half <= t[-1])
    return covered & (hi > lo) & (bad[hi] - bad[lo] == 0)


def _window_rms_below(t: np.ndarray, x: np.ndarray, centres: np.ndarray, half: float,
                      limit: float) -> np.ndarray:
    """For each centre time, whether the RMS of x over the samples within ±half is below
    limit (False where the window holds no sample)."""
    sq = np.r_[0.0, np.cumsum(x**2)]
    lo = np.searchsorted(t, centres - half, side="left")
    hi = np.searchsorted(t, centres + half, side="right")
    count = hi - lo
    return (count > 0) & (sq[hi] - sq[lo] < limit**2 * np.maximum(count, 1))


def rest_frames(t_imu: np.ndarray, f_B: np.ndarray, w_B: np.ndarray, t_frames: np.ndarray,
                z: np.ndarray, test: RestTest = RestTest(), video_from: int = 0) -> np.ndarray:
    """(n,) bool: frames at which the hand rests — IMU (t_imu (M,) s, f_B, w_B (M, 3)) quiet
    and the patch (z (n, 2) px, NaN where not reported) seen and still over the window.
    Frames before ``video_from`` (the IMU before the video started) have the IMU test only,
    with a window twice as long."""
    half = test.window_s / 2
    turning = np.linalg.norm(w_B, axis=1) >= test.gyro_rad_s
    dev = np.linalg.norm(f_B, axis=1) - G

    def quiet(centres: np.ndarray, h: float, least: float | None = None) -> np.ndarray:
        return (_window_all(t_imu, ~turning, centres, h, least)
                & _window_rms_below(t_imu, dev, centres, h, test.accel_m_s2))

    rest = quiet(t_frames, half)
    # before the video: the IMU alone, over twice the window, cut at the IMU's first sample
    # as long as a whole window's worth (window_s) is left (a trial whose hand rests only
    # in the IMU's first half second, then moves before the video starts)
    rest[:video_from] = quiet(t_frames[:video_from], 2 * half, test.window_s)
    tv, zv = t_frames[video_from:], z[video_from:]
    seen = np.isfinite(zv).all(axis=1)
    on_video = rest[video_from:] & _window_all(tv, seen, tv, half)
    cand = np.flatnonzero(on_video)  # the frames within ±half of each: a run (tv is sorted),
    lo = np.searchsorted(tv, tv[cand] - 2 * half, side="left")  # found inside a wider one
    hi = np.searchsorted(tv, tv[cand] + 2 * half, side="right")  # (linear in the session,
    for k, a, b in zip(cand, lo, hi):  # where the whole session at every frame was quadratic)
        near = np.abs(tv[a:b] - tv[k]) <= half
        on_video[k] = bool((np.ptp(zv[a:b][near], axis=0) < test.px).all())
    rest[video_from:] = on_video
    return rest


@dataclass(frozen=True)
class Inserted:
    """The smoother's step arrays with the zero-velocity steps inserted, and which are real."""

    arrays: tuple
    real: np.ndarray  # (n + 3 m,) bool


def _layout(rest: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each row's frame, its place after it (0 the frame's own, 1–3 its zero-velocity rows)
    and whether it is one of those."""
    reps = 1 + 3 * rest.astype(int)
    idx = np.repeat(np.arange(rest.size), reps)
    pos = np.arange(idx.size) - np.repeat(np.cumsum(reps) - reps, reps)  # 0 real, 1-3 virtual
    return idx, pos, pos > 0


def steps_with_rows(rest: np.ndarray, F, b, Q) -> Inserted:
    """with_rows' steps alone (F, b, Q): the inserted ones of zero length (F = I, b = 0, Q = 0),
    for a pass that needs no measurement rows (the smoother's backward, smoother_blocks.py)."""
    if not rest.any():
        return Inserted((F, b, Q), np.ones(rest.size, bool))
    idx, _, virt = _layout(rest)
    F2, b2, Q2 = F[idx], b[idx], Q[idx]
    F2[virt], b2[virt], Q2[virt] = np.eye(F.shape[1]), 0.0, 0.0
    return Inserted((F2, b2, Q2), ~virt)


def with_rows(rest: np.ndarray, sd_m_s: float, rk: float, F, b, Q, Hc, zc, use_c, Hk, zk,
              use_k) -> Inserted:
    """The kernel's arrays (frames first) with three zero-length steps after each rest frame,
    carrying v_x, v_y, v_z = 0 ± sd_m_s. The kernel's scalar rows all have variance rk, so
    each row is scaled by √rk / sd_m_s (a row h, z with variance σ² is h c, z c with c² σ²)."""
    steps = steps_with_rows(rest, F, b, Q)
    if not rest.any():  # nothing to insert: the arrays themselves, no copies
        return Inserted((*steps.arrays, Hc, zc, use_c, Hk, zk, use_k), steps.real)
    idx, pos, virt = _layout(rest)
    Hk2, zk2 = Hk[idx], zk[idx]
    Hk2[virt] = 0.0
    Hk2[virt, V_.start + pos[virt] - 1] = np.sqrt(rk) / sd_m_s
    zk2[virt] = 0.0
    arrays = (*steps.arrays, Hc[idx], zc[idx], use_c[idx] & ~virt, Hk2, zk2, use_k[idx] | virt)
    return Inserted(arrays, ~virt)
