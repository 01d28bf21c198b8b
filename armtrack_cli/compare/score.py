"""One method's trajectory scored against the ground truth: errors per joint and axis. (The
clinical measures of the truth beside the estimate's: pipeline/kinematics.py.)"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armtrack_cli.compare.errors import error_rows, truth_at
from armtrack_cli.compare.residual import winter_lowpass_into
from armtrack_cli.measures.signal import lowpass

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


def lowpassed(truth: Truth, cutoff_hz: float) -> Truth:
    """The truth's markers low-passed at their own rate: 4th-order zero-lag Butterworth over
    each run of seen frames (gaps stay gaps), as labs filter marker data before computing
    kinematics (Winter, Biomechanics and Motor Control of Human Movement, 2009, ch. 2), so that
    sampling them at the trajectory's frames does not fold their noise into the measures."""
    return Truth(truth.t, {k: _runs_lowpassed(x, truth.rate_hz, cutoff_hz)
                           for k, x in truth.xyz.items()}, truth.rate_hz)


def denoised(truth: Truth, max_hz: float, *, own: bool = False) -> Truth:
    """The truth's markers low-passed at their own rate, each coordinate of each run of seen
    frames at the cut-off Winter's residual analysis picks for it (compare.residual; at most
    max_hz): the reference for the clinical measures. A fixed 6 Hz lets a slow reach's marker
    noise raise its peak speed by 2–3 % (docs/validation-measures.md). With ``own`` (the
    caller's markers are its own to overwrite) they are filtered in place, the same numbers
    without a second copy of each (9 MB a joint at 60 minutes; issue 15)."""
    return Truth(truth.t, {k: _runs_lowpassed(x, truth.rate_hz, max_hz, residual=True, own=own)
                           for k, x in truth.xyz.items()}, truth.rate_hz)


def _runs_lowpassed(x: np.ndarray, fs: float, fc: float, *, residual: bool = False,
                    own: bool = False) -> np.ndarray:
    out = x if own else x.copy()  # a run is read before it is written, and runs are apart
    edges = np.flatnonzero(np.diff(np.r_[0, np.isfinite(x).all(axis=1).astype(int), 0]))
    for a, b in zip(edges[::2], edges[1::2]):
        if residual:  # a run's coordinates side by side (each its own cut-off)
            winter_lowpass_into(x[a:b], fs, fc, out[a:b])
            continue
        for j in range(x.shape[1]):
            out[a:b, j] = lowpass(x[a:b, j:j + 1], fs, fc)[:, 0]
    return out


def truth_markers(t: np.ndarray, truth: Truth, *, take: bool = False) -> dict[str, np.ndarray]:
    """Every ground-truth marker at frame times t (s), NaN in gaps: role -> (n, 3) m. With
    ``take``, each marker is taken out of truth.xyz as it is sampled (truth.xyz left empty)."""
    if not take:
        return {k: truth_at(t, truth.t, xyz, truth.rate_hz) for k, xyz in truth.xyz.items()}
    return {k: truth_at(t, truth.t, truth.xyz.pop(k), truth.rate_hz) for k in list(truth.xyz)}


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
