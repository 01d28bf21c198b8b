"""Wrist angles from a ground-truth hand orientation (a QTM 6DOF rigid body on the hand,
``[groundtruth] hand``), by the contract's definition (SESSION_FORMAT.md, frame H): F is the
hand frame in the neutral pose of the first second (the chordal mean of R_WH over it),
R_FH = R_WFᵀ R_WH = Rz(deviation) · Ry(flexion) · Rx(−pronation) (core/wrist.py). compare
scores ukf-palm against it with F taken over the estimate's first second (compare/palm.py).
"""

from __future__ import annotations

import numpy as np

from armtrack_cli.compare.palm import pose


def wrist_angles_deg(t: np.ndarray, R_WH: np.ndarray, side: str = "right") -> np.ndarray:
    """(N, 3) flexion, deviation, pronation in degrees (NaN where R_WH is missing), F from the
    first second of the body's own record."""
    ok = np.isfinite(R_WH).all(axis=(1, 2))
    return pose(t, np.full((t.size, 3), np.nan), R_WH, side, start_t=float(t[ok][0])).angles_deg
