"""Trajectories as TUM text (``t x y z qx qy qz qw``, one pose a line, space-separated), the
format ``evo_ape``/``evo_traj`` read, and as the same columns in a CSV with a header.

Rows with a missing value are left out (TUM has no NaN): a gap is a gap in time. Without an
orientation the identity (0 0 0 1) is written; evo's translation APE ignores it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from armtrack_cli.session.outputs import write_text

TUM_COLUMNS = ("t", "x", "y", "z", "qx", "qy", "qz", "qw")


def _rows(t: np.ndarray, xyz: np.ndarray, q_wxyz: np.ndarray | None) -> np.ndarray:
    q = np.tile([1.0, 0.0, 0.0, 0.0], (t.size, 1)) if q_wxyz is None else q_wxyz
    a = np.column_stack([t, xyz, q[:, 1:4], q[:, 0]])  # TUM: qx qy qz qw (scalar last)
    return a[np.isfinite(a).all(axis=1)]


def write_tum(path: str | Path, t: np.ndarray, xyz: np.ndarray,
              q_wxyz: np.ndarray | None = None) -> Path:
    """t (N,) s; xyz (N, 3) m; q_wxyz (N, 4) or None."""
    lines = [" ".join(f"{v:.9f}" for v in row) for row in _rows(t, xyz, q_wxyz)]
    return write_text(path, "\n".join(lines) + "\n")


def write_pose_csv(path: str | Path, t: np.ndarray, xyz: np.ndarray,
                   q_wxyz: np.ndarray | None = None) -> Path:
    lines = [",".join(TUM_COLUMNS)] + [",".join(f"{v:.9f}" for v in row)
                                       for row in _rows(t, xyz, q_wxyz)]
    return write_text(path, "\n".join(lines) + "\n")
