"""One method's trajectory scored against the ground truth: errors per joint and axis. (The
clinical measures of the truth beside the estimate's: pipeline/kinematics.py.)"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armtrack_cli.compare.errors import error_rows, truth_at

JOINTS = ("wrist", "elbow", "shoulder")


@dataclass(frozen=True)
class Truth:
    """Ground-truth markers on the session clock, in W."""

    t: np.ndarray  # (M,) s
    xyz: dict[str, np.ndarray]  # joint -> (M, 3) m, NaN in gaps
    rate_hz: float


@dataclass(frozen=True)
class Score:
    rows: list[dict]  # errors.csv rows
    excluded: dict[str, int]  # METHOD/JOINT -> estimated frames without truth (gaps)


def truth_markers(t: np.ndarray, truth: Truth) -> dict[str, np.ndarray]:
    """Every ground-truth marker at frame times t (s), NaN in gaps: role -> (n, 3) m."""
    return {k: truth_at(t, truth.t, xyz, truth.rate_hz) for k, xyz in truth.xyz.items()}


def score(method: str, t: np.ndarray, est: dict[str, np.ndarray], truth: Truth) -> Score:
    """est: joint -> (n, 3) m at frame times t (s)."""
    rows, excluded = [], {}
    for joint in JOINTS:
        if joint not in truth.xyz or joint not in est:
            continue
        at = truth_at(t, truth.t, truth.xyz[joint], truth.rate_hz)
        excluded[f"{method}/{joint}"] = int((np.isfinite(est[joint]).all(axis=1)
                                              & ~np.isfinite(at).all(axis=1)).sum())
        rows += error_rows(method, joint, est[joint], at)
    return Score(rows, excluded)
