"""The per-frame estimates of a method as the contract's trajectory table: column name ->
(n,) float64, in the contract's order (session/column_csv.write_columns writes it; no pandas
in fuse, issue 15)."""

from __future__ import annotations

import numpy as np

from armtrack_cli.fuse.methods import Estimates, Inputs
from armtrack_cli.fuse.models import Arm


def trajectory_table(t_frames: np.ndarray, frames: np.ndarray, est: Estimates, inp: Inputs,
                     arm: Arm | None) -> dict[str, np.ndarray]:
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
        q[frames] = inp.q_WB if est.q_WB is None else est.q_WB  # as the method corrected it
        elbow = arm.elbow(mean[:, :3], q)  # Tao & Hu eq. 2
        for k, a in enumerate("xyz"):
            cols[f"elbow_{a}"] = elbow[:, k]
    for k, a in enumerate("xyz"):
        cols[f"wrist_v{a}"] = mean[:, 3 + k]
    for k, a in enumerate("xyz"):
        cols[f"wrist_{a}_sd"] = sd[:, k]
    if arm is not None:  # the elbow is the wrist moved by a known vector: the same spread,
        esd = sd[:, :3]  # unless the method estimates the orientation too
        if est.elbow_var is not None:
            esd = full(est.sd[:, :3])
            esd[frames] = np.sqrt(np.maximum(est.elbow_var, 0))
        for k, a in enumerate("xyz"):
            cols[f"elbow_{a}_sd"] = esd[:, k]
    for k, a in enumerate("xyz"):
        cols[f"wrist_v{a}_sd"] = sd[:, 3 + k]
    if est.ess is not None:
        e = np.full(n, np.nan)
        e[frames] = est.ess
        cols["ess"] = e
    return cols


def impossible_rows(table: dict[str, np.ndarray], *, shoulder: np.ndarray | None, reach_m: float | None,
                    bound_m: float) -> np.ndarray:
    """(n,) True where the estimated wrist lies where no wrist can be: farther than
    ``reach_m`` from the shoulder (arm model), or than ``bound_m`` from W's origin."""
    w = np.c_[table["wrist_x"], table["wrist_y"], table["wrist_z"]]
    ok = np.isfinite(w).all(axis=1)
    far = np.zeros(len(w), bool)
    if shoulder is not None and reach_m is not None:
        far[ok] = np.linalg.norm(w[ok] - shoulder, axis=1) > reach_m
    else:
        far[ok] = np.linalg.norm(w[ok], axis=1) > bound_m
    return far


def blank(table: dict[str, np.ndarray], rows: np.ndarray) -> dict[str, np.ndarray]:
    """The rows left empty (missing) in every column but t."""
    return {c: x if c == "t" else np.where(rows, np.nan, x) for c, x in table.items()}
