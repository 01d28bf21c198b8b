"""Wrist angles from a ground-truth hand orientation (a QTM 6DOF rigid body on the hand,
``[groundtruth] hand``), by the contract's definition (SESSION_FORMAT.md, frame H):

F is the hand frame in the neutral pose of the first second (the chordal mean of R_WH over
it); R_FH = R_WFᵀ R_WH = Rz(deviation) · Ry(flexion) · Rx(−pronation), so with
R = Rz(a) Ry(b) Rx(c): a = atan2(R10, R00), b = −asin(R20), c = atan2(R21, R22). For a left
hand deviation and pronation are negated.
"""

from __future__ import annotations

import numpy as np

NEUTRAL_S = 1.0


def mean_rotation(R: np.ndarray) -> np.ndarray:
    """(3, 3) chordal L2 mean of rotations (N, 3, 3): the mean matrix projected onto SO(3)."""
    U, _, Vt = np.linalg.svd(np.nanmean(R, axis=0))
    return U @ np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))]) @ Vt


def wrist_angles_deg(t: np.ndarray, R_WH: np.ndarray, side: str = "right") -> np.ndarray:
    """(N, 3) flexion, deviation, pronation in degrees (NaN where R_WH is missing)."""
    ok = np.isfinite(R_WH).all(axis=(1, 2))
    first = ok & (t - t[np.flatnonzero(ok)[0]] <= NEUTRAL_S)
    R_WF = mean_rotation(R_WH[first])
    R = np.einsum("ji,njk->nik", R_WF, R_WH)  # R_FH = R_WFᵀ R_WH
    dev = np.arctan2(R[:, 1, 0], R[:, 0, 0])
    flex = -np.arcsin(np.clip(R[:, 2, 0], -1.0, 1.0))
    pron = -np.arctan2(R[:, 2, 1], R[:, 2, 2])
    s = 1.0 if side == "right" else -1.0
    out = np.degrees(np.column_stack([flex, s * dev, s * pron]))
    out[~ok] = np.nan
    return out
