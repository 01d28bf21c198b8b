"""The clinical measures of a trajectory (fuse) and of the ground truth beside them (compare),
computed by ``armtrack_cli.measures``; this module only gathers their inputs from the session
and lays out the tables."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from armtrack_cli.core import windows as windows_mod
from armtrack_cli.core.windows import Window
from armtrack_cli.measures import CATALOGUE, Inputs, measure_rows
from armtrack_cli.measures.angles import hand_frames, wrist_angles_deg
from armtrack_cli.measures.windowed import measure_rows_windowed
from armtrack_cli.session.config import Session

if TYPE_CHECKING:
    import pandas as pd

XYZ = ("x", "y", "z")
WRIST_ANGLES = ("flexion_deg", "deviation_deg", "pronation_deg")


def columns(traj, names) -> np.ndarray | None:
    """(N, len(names)) float columns of a trajectory table (a DataFrame, or column -> array as
    session/plain_tables.py reads it), or None when one is missing."""
    if not all(c in traj for c in names):
        return None
    return np.column_stack([np.asarray(traj[c], dtype=float) for c in names])



def trajectory_inputs(traj: pd.DataFrame | dict, session: Session, *,
                      q_WB: np.ndarray | None = None) -> Inputs:
    """A trajectory-METHOD.csv table (+ the IMU orientation at its frames, when fuse has it)."""
    arm, imu = session.arm, session.imu
    ang_sd = columns(traj, [f"{a}_sd" for a in WRIST_ANGLES])
    return Inputs(
        t=np.asarray(traj["t"], dtype=float), wrist=columns(traj, [f"wrist_{a}" for a in XYZ]),
        task=session.meta.task or "", side=session.meta.side,
        elbow=columns(traj, [f"elbow_{a}" for a in XYZ]),
        shoulder=None if arm is None else np.asarray(arm.shoulder_m, float),
        q_WB=q_WB, forearm_axis=None if imu is None else imu.forearm_unit,
        wrist_angles=columns(traj, WRIST_ANGLES),
        wrist_sd=columns(traj, [f"wrist_{a}_sd" for a in XYZ]), angles_sd=ang_sd)


def _cell(v) -> str:
    return v if isinstance(v, str) else f"{v:.6f}"


KINEMATICS_COLUMNS = ("measure", "segment", "value", "sd", "unit", "t_start", "t_end")


def kinematics_cells(traj: pd.DataFrame | dict, session: Session, *,
                     q_WB: np.ndarray | None = None) -> list[dict]:
    """kinematics-METHOD.csv's rows: measure, segment, value (a number's text or "not
    computable: why"), sd (posterior uncertainty), unit (with the angle's convention),
    t_start, t_end (KINEMATICS_COLUMNS; outputs.write_rows writes them without pandas)."""
    rows = measure_rows(trajectory_inputs(traj, session, q_WB=q_WB))
    return [{**r, "value": _cell(r["value"])} for r in rows]


def kinematics_cells_windowed(read: Callable[[Window], dict], t0: float, t1: float,
                              session: Session) -> list[dict]:
    """kinematics_cells of a trajectory a stage holds a window at a time (issue 15):
    ``read(w)`` gives the trajectory table's columns (trajectory-METHOD.csv's names, and
    "q_WB" (N, 4) where the stage has the IMU's orientation) of its frames in [w.start,
    w.stop], in time order; [t0, t1] the trajectory's first and last frame times. A span of
    one window (core/windows.py) is read whole and measured as kinematics_cells measures it;
    a longer one a window at a time (measures/windowed.py, docs/measures.md)."""
    wins = _measure_windows(t0, t1)
    if len(wins) == 1:
        table = read(Window(-np.inf, np.inf, t0, t1))
        q_WB = table.pop("q_WB", None)
        return kinematics_cells(table, session, q_WB=q_WB)

    def inputs(w: Window) -> Inputs:
        table = read(w)
        q_WB = table.pop("q_WB", None)
        return trajectory_inputs(table, session, q_WB=q_WB)

    rows = measure_rows_windowed(inputs, wins)
    for r in rows:  # in place: a 60-minute session's 5,700 rows once, not twice
        r["value"] = _cell(r["value"])
    return rows


def _measure_windows(t0: float, t1: float) -> list[Window]:
    """core/windows.windows with its settings as they stand (tests shorten WINDOW_S)."""
    return windows_mod.windows(t0, t1, windows_mod.WINDOW_S, windows_mod.MARGIN_S)


def kinematics_table(traj: pd.DataFrame | dict, session: Session, *,
                     q_WB: np.ndarray | None = None) -> pd.DataFrame:
    """kinematics_cells as a DataFrame (the palm pipeline's and the report's tests' table)."""
    import pandas as pd

    return pd.DataFrame(kinematics_cells(traj, session, q_WB=q_WB),
                        columns=list(KINEMATICS_COLUMNS))


def truth_inputs(est: Inputs, session: Session, truth: dict[str, np.ndarray]) -> Inputs | None:
    """The ground truth's markers (role -> (N, 3) at the trajectory's frames) as Inputs, on the
    frames where the estimate exists; None when no wrist marker is named."""
    mask = np.isfinite(est.wrist).all(axis=1)[:, None]
    cut = {k: np.where(mask, v, np.nan) for k, v in truth.items()}
    if "wrist" in cut:  # arm sessions: the shoulder marker if named, else the model's
        return Inputs(t=est.t, wrist=cut["wrist"], task=est.task, side=est.side,
                      elbow=cut.get("elbow") if est.elbow is not None else None,
                      shoulder=cut.get("shoulder", est.shoulder))
    if {"WRIST", "MCP3", "CMC1"} <= set(cut):  # palm sessions: the hand frame from markers
        ang = None
        if est.wrist_angles is not None:
            R = hand_frames(cut["WRIST"], cut["MCP3"], cut["CMC1"], est.side)
            ang = wrist_angles_deg(est.t, R, est.side)
        return Inputs(t=est.t, wrist=cut["WRIST"], task=est.task, side=est.side, wrist_angles=ang)
    return None


def truth_pose_inputs(est: Inputs, wrist: np.ndarray, angles_deg: np.ndarray) -> Inputs:
    """A ground-truth wrist pose (a 6DOF hand body: WRIST (N, 3) and wrist angles (N, 3) deg,
    at the trajectory's frames) as Inputs, on the frames where the estimate exists."""
    mask = np.isfinite(est.wrist).all(axis=1)[:, None]
    return Inputs(t=est.t, wrist=np.where(mask, wrist, np.nan), task=est.task, side=est.side,
                  wrist_angles=np.where(mask, angles_deg, np.nan)
                  if est.wrist_angles is not None else None)


def _number(v) -> float:
    try:
        return float(v)
    except (TypeError, ValueError):
        return float("nan")


def _windows(est: list[dict]) -> list[tuple] | None:
    """The estimate's segments (t_start, t_end), in order of first appearance, each the first
    value present among its rows (what pandas' groupby(sort=False).first() gives)."""
    win: dict[str, list] = {}
    for r in est:
        if r["segment"] == "session":
            continue
        w = win.setdefault(r["segment"], [np.nan, np.nan])
        for k, c in enumerate(("t_start", "t_end")):
            v = r.get(c, np.nan)
            if np.isnan(w[k]) and not np.isnan(v):
                w[k] = v
    return [tuple(np.float64(v) for v in w) for w in win.values()] or None


def measure_comparison_windowed(method: str, est: list[dict],
                                read_truth: Callable[[Window], Inputs | None], t0: float,
                                t1: float) -> list[dict]:
    """measure_comparison with the ground truth's Inputs (truth_inputs') read a window at a
    time, ``read_truth(w)`` those of the trajectory's frames in [w.start, w.stop] (issue 15).
    A span of one window is read whole; a longer one measured a window at a time
    (measures/windowed.py), on the estimate's segments as measure_comparison does."""
    wins = _measure_windows(t0, t1)
    if len(wins) == 1:
        return measure_comparison(method, est, read_truth(Window(-np.inf, np.inf, t0, t1)))
    has_truth = read_truth(wins[0]) is not None
    rows = measure_rows_windowed(read_truth, wins, windows=_windows(est)) if has_truth else []
    return _comparison_rows(method, est, rows)


def measure_comparison(method: str, est: list[dict], truth: Inputs | None) -> list[dict]:
    """measures.csv rows: each estimated measure (kinematics-METHOD.csv's rows, as
    session/plain_tables.kinematics_rows reads them) with the same measure of the ground
    truth, the error (estimate − truth) and the error in % of truth."""
    windows = _windows(est)  # the estimate's segments
    return _comparison_rows(method, est, measure_rows(truth, windows=windows) if truth else [])


def _comparison_rows(method: str, est: list[dict], truth_rows: list[dict]) -> list[dict]:
    t_rows = {(r["measure"], r["segment"]): r["value"] for r in truth_rows}
    out = []
    for r in est:
        tv = t_rows.get((r["measure"], r["segment"]),
                        "not computable: the reference does not give this measure")
        e, t = _number(r["value"]), _number(tv)
        out.append({"method": method, "measure": r["measure"], "segment": r["segment"],
                    "unit": CATALOGUE.get(r["measure"], r["unit"]), "estimate": r["value"],
                    "estimate_sd": r["sd"], "truth": _cell(tv), "error": e - t,
                    "error_pct": 100 * (e - t) / abs(t) if t else float("nan")})
    return out
