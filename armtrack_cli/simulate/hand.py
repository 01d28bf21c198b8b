"""Hand kinematics for Cordella's palm-marker sessions.

The hand frame H (SESSION_FORMAT.md): origin at the WRIST marker, x towards MCP3, z out of the
back of the hand, y = z × x (the thumb side for a right hand). The forearm frame F is H in the
neutral pose of the first second; the arm does not rotate, so R_WF is constant and
R_FH = Rz(deviation) · Ry(flexion) · Rx(−pronation) (right hand; the left negates deviation and
pronation).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armtrack_cli.core import quaternion as quat
from armtrack_cli.simulate.kinematics import min_jerk
from armtrack_cli.simulate.tasks import HAND_TASKS

MARKERS = ("WRIST", "MCP2", "MCP3", "MCP4", "MCP5", "CMC1")
LINKS_M = (0.0, 0.085, 0.080, 0.075, 0.070, 0.045)
ANGLES_DEG = (0.0, 14.0, 0.0, -13.0, -26.0, 52.0)  # in-plane angle from x_H (towards MCP3)
NEUTRAL_S = 1.5


def palm_model(links=LINKS_M, angles_deg=ANGLES_DEG, side: str = "right") -> np.ndarray:
    """(6, 3) marker positions in H (m): each at its measured length and in-plane angle."""
    a = np.deg2rad(angles_deg) * (1.0 if side == "right" else -1.0)
    return np.stack([np.asarray(links) * np.cos(a), np.asarray(links) * np.sin(a),
                     np.zeros(len(links))], -1)


def R_FH(flexion, deviation, pronation, side: str = "right") -> np.ndarray:
    """(N, 4) quaternion of Rz(dev) · Ry(flex) · Rx(−pron), angles in radians."""
    s = 1.0 if side == "right" else -1.0
    qz = quat.from_axis_angle(np.array([0.0, 0, 1]), s * np.asarray(deviation))
    qy = quat.from_axis_angle(np.array([0.0, 1, 0]), np.asarray(flexion))
    qx = quat.from_axis_angle(np.array([1.0, 0, 0]), -s * np.asarray(pronation))
    return quat.multiply(quat.multiply(qz, qy), qx)


# (flexion, deviation, pronation) targets in degrees, each reached with minimum-jerk timing
ROM_SEQUENCE = [(55, 0, 0), (0, 0, 0), (-45, 0, 0), (0, 0, 0), (0, 18, 0), (0, 0, 0),
                (0, -28, 0), (0, 0, 0), (0, 0, 45), (0, 0, 0), (0, 0, -40), (0, 0, 0)]
GRASP_SEQUENCE = [(10, -8, 20), (20, -12, 35), (20, -12, 35), (0, 0, 0)]
# Cordella's Fig. 4: abduction/adduction (radial/ulnar deviation) from 25° to −25°, twice;
# and flexion-extension ±45°, twice
DEVIATION_SEQUENCE = [(0, 25, 0), (0, 0, 0), (0, -25, 0), (0, 0, 0)] * 2
FLEXION_SEQUENCE = [(45, 0, 0), (0, 0, 0), (-45, 0, 0), (0, 0, 0)] * 2
SEQUENCES = {"wrist-rom": ROM_SEQUENCE, "reach-grasp": GRASP_SEQUENCE,
             "wrist-deviation": DEVIATION_SEQUENCE, "wrist-flexion": FLEXION_SEQUENCE}


@dataclass(frozen=True)
class HandMotion:
    task: str
    duration_s: float
    wrist0: np.ndarray  # (3,) WRIST marker at rest, W
    q_WF: np.ndarray  # (4,) forearm frame (H at neutral) in W
    reach: np.ndarray  # (3,) wrist displacement of the reach (reach-grasp), W

    def angles(self, t: np.ndarray) -> np.ndarray:
        """(N, 3) flexion, deviation, pronation in radians."""
        seq = SEQUENCES[self.task]
        move = max(self.duration_s - 2 * NEUTRAL_S, 1e-6)
        u = np.clip((np.asarray(t, float) - NEUTRAL_S) / move, 0, 1) * len(seq)
        k = np.minimum(np.floor(u).astype(int), len(seq) - 1)
        f = min_jerk(u - k)[..., None]
        pts = np.deg2rad(np.array([(0, 0, 0)] + seq, float))
        return pts[k] * (1 - f) + pts[k + 1] * f

    def wrist(self, t: np.ndarray) -> np.ndarray:
        if self.task != "reach-grasp":  # the forearm rests on the table
            return np.broadcast_to(self.wrist0, np.shape(t) + (3,)).copy()
        move = max(self.duration_s - 2 * NEUTRAL_S, 1e-6)
        u = np.clip((np.asarray(t, float) - NEUTRAL_S) / move, 0, 1)
        go = min_jerk(np.clip(u * 2, 0, 1)) - min_jerk(np.clip(u * 4 - 3, 0, 1))  # out, hold, back
        return self.wrist0 + go[..., None] * self.reach

    def q_WH(self, t: np.ndarray, side: str = "right") -> np.ndarray:
        a = self.angles(t)
        return quat.multiply(self.q_WF, R_FH(a[..., 0], a[..., 1], a[..., 2], side))


def default_motion(task: str, duration_s: float) -> HandMotion:
    """Right hand on the table beside the board, fingers pointing away from the subject (−y_W),
    back of the hand up: x_F = −y_W, z_F = +z_W, y_F = +x_W (the thumb side)."""
    R = np.stack([[0.0, -1, 0], [1.0, 0, 0], [0.0, 0, 1]], -1)  # columns x_F, y_F, z_F in W
    q = quat.from_matrix(R)
    if task not in HAND_TASKS:
        raise ValueError(f"unknown hand task {task!r}; tasks are {', '.join(HAND_TASKS)}")
    return HandMotion(task, duration_s, np.array([0.40, 0.16, 0.035]), q,
                      np.array([0.0, -0.14, 0.06]))
