"""Arm kinematics for the rehabilitation tasks (Tao & Hu set-up): fixed shoulder, wrist
paths with minimum-jerk timing a few cm above the table, elbow on the circle where the
|E − S| = L1 and |E − W| = L2 spheres meet, chosen by a smoothly varying swivel angle.

Everything is a function of session time t (s) so that derivatives can be taken with a
high-order central difference at any instant (exact to ~1e-9 for these smooth paths).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from armtrack_cli.core import quaternion as quat
from armtrack_cli.simulate import calibration_move
from armtrack_cli.simulate.tasks import ARM_TASKS

TASKS = ARM_TASKS
REST_S = 1.5  # still at the start and end of every task (lets filters start from rest)


@dataclass(frozen=True)
class ArmGeometry:
    shoulder: np.ndarray  # (3,) m in W
    upper_arm_m: float  # L1
    forearm_m: float  # L2


@dataclass(frozen=True)
class Task:
    name: str
    duration_s: float
    centre: np.ndarray  # (3,) workspace centre in W, m
    size_m: float  # radius / half-size / reach distance
    pronation_deg: float = 8.0  # amplitude of the small pronation/supination
    swivel_deg: float = 10.0  # amplitude of the swivel-angle variation
    swivel_rest_deg: float = 50.0  # elbow swung out from its lowest point (arm off the table)
    calibration_s: float = 0.0  # the calibration movement's length after the first rest (0: none;
    #                             calibration_move.py); duration_s includes it


def min_jerk(s: np.ndarray) -> np.ndarray:
    """Flash & Hogan minimum-jerk profile 10s³ − 15s⁴ + 6s⁵ on [0, 1], clipped outside."""
    s = np.clip(s, 0.0, 1.0)
    return s**3 * (10 - 15 * s + 6 * s * s)


def _progress(t: np.ndarray, duration: float, segments: int) -> np.ndarray:
    """Piecewise minimum-jerk progress 0..segments over the moving part of the task."""
    move = max(duration - 2 * REST_S, 1e-6)
    u = np.clip((np.asarray(t, float) - REST_S) / move, 0.0, 1.0) * segments
    k = np.minimum(np.floor(u), segments - 1)
    return k + min_jerk(u - k)


def wrist_path(task: Task, t: np.ndarray) -> np.ndarray:
    """(N, 3) wrist joint positions in W."""
    t = np.asarray(t, float)
    c, a = task.centre, task.size_m
    if task.name == "circle":
        laps = max(1, int(round((task.duration_s - 2 * REST_S) / 5.0)))
        th = 2 * np.pi * _progress(t, task.duration_s, laps)
        xy = np.stack([a * np.cos(th), a * np.sin(th)], -1) - [a, 0]
    elif task.name == "figure8":
        loops = max(1, int(round((task.duration_s - 2 * REST_S) / 6.0)))
        th = 2 * np.pi * _progress(t, task.duration_s, loops)
        xy = np.stack([a * np.sin(th), 0.6 * a * np.sin(th) * np.cos(th)], -1)
    elif task.name == "rectangle":
        corners = np.array([[-1, -0.6], [1, -0.6], [1, 0.6], [-1, 0.6]]) * a
        laps = max(1, int(round((task.duration_s - 2 * REST_S) / 8.0)))
        p = _progress(t, task.duration_s, 4 * laps)
        k = np.floor(p).astype(int)
        f = (p - k)[..., None]
        xy = corners[k % 4] * (1 - f) + corners[(k + 1) % 4] * f
    elif task.name == "reach":
        reps = max(1, int(round((task.duration_s - 2 * REST_S) / 4.0)))
        p = _progress(t, task.duration_s, 2 * reps)
        out = np.where(np.floor(p).astype(int) % 2 == 0, p % 1.0, 1.0 - p % 1.0)
        out = np.where(p >= 2 * reps, 0.0, out)
        xy = np.stack([0.3 * a * out, -a * out], -1)  # towards the camera side and across
    else:
        raise ValueError(f"unknown task {task.name!r}; tasks are {', '.join(TASKS)}")
    lift = 0.012 * np.sin(np.pi * np.clip((t - REST_S) / max(task.duration_s - 2 * REST_S, 1e-6),
                                          0, 1)) ** 2
    return np.concatenate([xy, lift[..., None]], -1) + c


def activity(task: Task, t: np.ndarray, ramp_s: float = 0.6) -> np.ndarray:
    """0 while the arm rests at the start and end, 1 while it moves, minimum-jerk between."""
    t = np.asarray(t, float)
    return min_jerk((t - REST_S) / ramp_s) * min_jerk((task.duration_s - REST_S - t) / ramp_s)


def swivel(task: Task, t: np.ndarray) -> np.ndarray:
    """Swivel angle (rad) of the elbow about the shoulder–wrist axis, smooth in t."""
    t = np.asarray(t, float)
    wobble = activity(task, t) * np.sin(2 * np.pi * (t - REST_S) / 7.3)
    return np.deg2rad(task.swivel_rest_deg + task.swivel_deg * wobble)


def elbow_position(arm: ArmGeometry, wrist: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """(N, 3) elbow on the intersection circle of the two spheres.

    With d = |W − S|, the circle's centre is S + a·n (n = (W − S)/d, a = (d² + L1² − L2²)/2d)
    and its radius r = √(L1² − a²). phi = 0 puts the elbow at the circle's lowest point
    (the natural pose of an arm resting towards the table); phi turns it about n.
    """
    S = arm.shoulder
    v = wrist - S
    d = np.linalg.norm(v, axis=-1, keepdims=True)
    n = v / d
    L1, L2 = arm.upper_arm_m, arm.forearm_m
    a = (d**2 + L1**2 - L2**2) / (2 * d)
    r = np.sqrt(np.maximum(L1**2 - a**2, 0.0))
    down = np.array([0.0, 0.0, -1.0])
    u = down - np.sum(down * n, -1, keepdims=True) * n  # 'down' projected off the axis
    u /= np.linalg.norm(u, axis=-1, keepdims=True)
    w = np.cross(n, u)
    ph = np.asarray(phi)[..., None]
    return S + a * n + r * (np.cos(ph) * u + np.sin(ph) * w)


def sensor_orientation(elbow: np.ndarray, wrist: np.ndarray, pronation: np.ndarray,
                       forearm_axis: str = "+y") -> np.ndarray:
    """(N, 4) R_WB: the forearm axis points elbow -> wrist, z_B out of the back of the wrist
    (as near world-up as the forearm allows), turned by ``pronation`` (rad) about the forearm."""
    y = wrist - elbow
    y /= np.linalg.norm(y, axis=-1, keepdims=True)
    up = np.array([0.0, 0.0, 1.0])
    z = up - np.sum(up * y, -1, keepdims=True) * y
    z /= np.linalg.norm(z, axis=-1, keepdims=True)
    x = np.cross(y, z)
    R = np.stack([x, y, z], -1)  # columns are B's axes in W
    q = quat.multiply(quat.from_matrix(R), quat.from_axis_angle(np.array([0.0, 1.0, 0.0]),
                                                                 np.asarray(pronation)))
    return quat.multiply(q, _axis_alignment(forearm_axis))


def _axis_alignment(forearm_axis: str) -> np.ndarray:
    """Fixed rotation C (B' -> B) with C · e_axis = e_y, so the named axis runs along the forearm."""
    e = {"x": [1.0, 0, 0], "y": [0, 1.0, 0], "z": [0, 0, 1.0]}[forearm_axis[1]]
    a = np.array(e) * (1.0 if forearm_axis[0] == "+" else -1.0)
    b = np.array([0.0, 1.0, 0.0])
    c = np.cross(a, b)
    if np.linalg.norm(c) < 1e-9:
        return np.array([1.0, 0, 0, 0]) if a @ b > 0 else np.array([0.0, 0, 0, 1.0])
    return quat.from_axis_angle(c / np.linalg.norm(c), np.arccos(np.clip(a @ b, -1, 1)))


def pronation(task: Task, t: np.ndarray) -> np.ndarray:
    """Small pronation/supination (rad) about the forearm while the arm moves."""
    t = np.asarray(t, float)
    return np.deg2rad(task.pronation_deg) * activity(task, t) * np.sin(2 * np.pi * (t - REST_S) / 4.1)


@dataclass(frozen=True)
class ArmState:
    """Exact kinematics at times t (session clock). Positions m, velocities m/s, in W."""

    t: np.ndarray
    shoulder: np.ndarray
    elbow: np.ndarray
    wrist: np.ndarray
    wrist_vel: np.ndarray
    wrist_acc: np.ndarray
    elbow_vel: np.ndarray
    q_WB: np.ndarray  # (N, 4) sensor orientation B -> W
    omega_B: np.ndarray  # (N, 3) body angular rate, rad/s


def _pose(arm: ArmGeometry, task: Task, t: np.ndarray):
    """Wrist, swivel and pronation at times t: the task's, with the calibration movement (when
    the task has one) between the first rest and the task, the task played after it."""
    C = task.calibration_s
    if C <= 0:
        return wrist_path(task, t), swivel(task, t), pronation(task, t)
    inner = replace(task, duration_s=task.duration_s - C, calibration_s=0.0)
    tau = calibration_move.task_clock(t, REST_S, C)
    rest = wrist_path(inner, np.array([REST_S]))[0]
    dW, dphi = calibration_move.offsets(arm.shoulder, rest, t, REST_S, C)
    return wrist_path(inner, tau) + dW, swivel(inner, tau) + dphi, pronation(inner, tau)


_H = 1e-3  # central-difference step (s)
_D1 = np.array([1, -8, 0, 8, -1]) / (12 * _H)  # 5-point first derivative, O(h^4)
_D2 = np.array([-1, 16, -30, 16, -1]) / (12 * _H**2)  # 5-point second derivative, O(h^4)


def arm_state(arm: ArmGeometry, task: Task, t: np.ndarray, forearm_axis: str = "+y") -> ArmState:
    t = np.asarray(t, float)
    offs = np.arange(-2, 3) * _H
    tt = t[None, :] + offs[:, None]  # (5, N)
    W, phi, pro = _pose(arm, task, tt)
    E = elbow_position(arm, W, phi)
    q = sensor_orientation(E, W, pro, forearm_axis)
    wrist_vel = np.einsum("k,kni->ni", _D1, W)
    wrist_acc = np.einsum("k,kni->ni", _D2, W)
    elbow_vel = np.einsum("k,kni->ni", _D1, E)
    # body rate: ω_B = 2 · vec(q* ⊗ q̇), with q̇ by the same 5-point stencil
    qdot = np.einsum("k,kni->ni", _D1, q)
    omega = 2 * quat.multiply(quat.conjugate(q[2]), qdot)[:, 1:]
    return ArmState(t, np.broadcast_to(arm.shoulder, W[2].shape).copy(), E[2], W[2], wrist_vel,
                    wrist_acc, elbow_vel, q[2], omega)
