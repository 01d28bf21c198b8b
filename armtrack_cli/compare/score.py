"""One method's trajectory scored against the ground truth: errors per joint and axis, and
the clinical measures of the truth over the frames the estimate covers."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armtrack_cli.compare.errors import error_rows, truth_at
from armtrack_cli.core.measures import MEASURES, measures

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
    measure_rows: list[dict]  # measures.csv rows: estimate beside truth
    excluded: dict[str, int]  # METHOD/JOINT -> estimated frames without truth (gaps)


def score(method: str, t: np.ndarray, est: dict[str, np.ndarray], truth: Truth, *,
          est_measures: dict[str, float], shoulder: np.ndarray | None) -> Score:
    """est: joint -> (n, 3) m at frame times t (s); est_measures: the estimate's clinical
    measures as fuse computed them (kinematics-METHOD.csv)."""
    rows, at, excluded = [], {}, {}
    for joint in JOINTS:
        if joint not in truth.xyz or joint not in est:
            continue
        at[joint] = truth_at(t, truth.t, truth.xyz[joint], truth.rate_hz)
        excluded[f"{method}/{joint}"] = int((np.isfinite(est[joint]).all(axis=1)
                                              & ~np.isfinite(at[joint]).all(axis=1)).sum())
        rows += error_rows(method, joint, est[joint], at[joint])
    mrows = []
    if "wrist" in at:
        ok = np.isfinite(est["wrist"]).all(axis=1)
        true_m = measures(t, np.where(ok[:, None], at["wrist"], np.nan), elbow=at.get("elbow"),
                          shoulder=shoulder)
        for k, unit in MEASURES.items():
            e = est_measures.get(k, np.nan)
            mrows.append({"method": method, "measure": k, "unit": unit, "estimate": e,
                          "truth": true_m[k], "difference": e - true_m[k]})
    return Score(rows, mrows, excluded)
