"""The per-frame estimates of a method as the contract's trajectory table."""

from __future__ import annotations

import numpy as np
import pandas as pd

from armtrack_cli.fuse.methods import Estimates, Inputs
from armtrack_cli.fuse.models import Arm


def trajectory_table(t_frames: np.ndarray, frames: np.ndarray, est: Estimates, inp: Inputs,
                     arm: Arm | None) -> pd.DataFrame:
    """Every video frame (t_frames, (n,) s); the filter's rows are ``frames``. Rows before the
    filter starts or after the IMU ends are empty (missing, not invented)."""
    n = t_frames.size
    full = lambda a: np.full((n,) + a.shape[1:], np.nan)  # noqa: E731
    mean, sd = full(est.mean), full(est.sd)
    mean[frames], sd[frames] = est.mean, est.sd
    cols = {"t": t_frames}
    for k, a in enumerate("xyz"):
        cols[f"wrist_{a}"] = mean[:, k]
    if arm is not None:
        q = full(inp.q_WB)
        q[frames] = inp.q_WB
        elbow = arm.elbow(mean[:, :3], q)  # Tao & Hu eq. 2
        for k, a in enumerate("xyz"):
            cols[f"elbow_{a}"] = elbow[:, k]
    for k, a in enumerate("xyz"):
        cols[f"wrist_v{a}"] = mean[:, 3 + k]
    for k, a in enumerate("xyz"):
        cols[f"wrist_{a}_sd"] = sd[:, k]
    if arm is not None:  # the elbow is the wrist moved by a known vector: the same spread
        for k, a in enumerate("xyz"):
            cols[f"elbow_{a}_sd"] = sd[:, k]
    for k, a in enumerate("xyz"):
        cols[f"wrist_v{a}_sd"] = sd[:, 3 + k]
    if est.ess is not None:
        e = np.full(n, np.nan)
        e[frames] = est.ess
        cols["ess"] = e
    return pd.DataFrame(cols)
