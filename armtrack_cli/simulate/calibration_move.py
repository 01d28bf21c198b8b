"""The calibration movement (opt-in, `simulate --calibration-movement SECONDS`): a few seconds
after the first rest, before the task, that sweep the elbow over a broad 2-D patch of its
sphere about the shoulder, so that `[arm] … = "auto"` can fix the sphere's centre and radius
(docs/recording-guide.md gives it as the lab's protocol; docs/validation-arm-auto.md measures it).

What the patient does, from the task's rest pose: the hand is lifted from the table twice (up
to LIFT_M), moves forward and back one and a half times (FORWARD_M, away from the shoulder),
out and in a quarter-cycle later (OUT_M), while the elbow swings out and in about the
shoulder–wrist axis (SWIVEL_DEG about a mean SWIVEL_OUT_DEG further out than at rest). The
lift and the swivel run at different rates, so the elbow's direction from the shoulder covers
a patch, not one circle (a circle lies on a family of spheres). Everything is multiplied by a
minimum-jerk envelope that is still at both ends (the task's rest pose, with zero velocity and
acceleration), so positions stay smooth for the high-order-difference derivatives.
"""

from __future__ import annotations

import numpy as np

LIFT_M = 0.18  # the hand's highest lift above its rest pose
FORWARD_M = 0.10  # forward (away from the shoulder, horizontally) and back
OUT_M = 0.06  # out and in, across the forward direction
SWIVEL_DEG = 35.0  # the elbow's swing out and in about the shoulder–wrist axis
SWIVEL_OUT_DEG = 20.0  # … about a mean this much further out than at rest (clear of the table)
RAMP = 0.15  # share of the movement over which the envelope rises (and falls)
LIFTS, SWEEPS, SWINGS = 2.0, 1.5, 1.5  # cycles of the lift, the forward sweep, the swing


def _min_jerk(s: np.ndarray) -> np.ndarray:
    s = np.clip(s, 0.0, 1.0)
    return s**3 * (10 - 15 * s + 6 * s * s)


def offsets(shoulder: np.ndarray, rest_wrist: np.ndarray, t: np.ndarray, start_s: float,
            duration_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(…, 3) wrist offset (m, in W) and (…) swivel offset (rad) at session times t, for a
    movement from start_s lasting duration_s; zero outside it."""
    s = (np.asarray(t, float) - start_s) / duration_s
    env = _min_jerk(s / RAMP) * _min_jerk((1.0 - s) / RAMP)
    fwd = np.r_[rest_wrist[:2] - shoulder[:2], 0.0]
    fwd /= np.linalg.norm(fwd)
    out = np.array([-fwd[1], fwd[0], 0.0])
    lift = LIFT_M * env * (0.55 - 0.45 * np.cos(2 * np.pi * LIFTS * s))
    ahead = FORWARD_M * env * np.sin(2 * np.pi * SWEEPS * s)
    side = OUT_M * env * np.cos(2 * np.pi * SWEEPS * s)
    dW = lift[..., None] * np.array([0.0, 0.0, 1.0]) + ahead[..., None] * fwd \
        + side[..., None] * out
    dphi = np.deg2rad(env * (SWIVEL_OUT_DEG + SWIVEL_DEG * np.sin(2 * np.pi * SWINGS * s)))
    return dW, dphi


def task_clock(t: np.ndarray, start_s: float, duration_s: float) -> np.ndarray:
    """The task's own time: session time before the movement, held at its start during it
    (the task's rest pose), the session time less the movement's length after it."""
    t = np.asarray(t, float)
    return np.where(t < start_s, t, np.maximum(t - duration_s, start_s))
