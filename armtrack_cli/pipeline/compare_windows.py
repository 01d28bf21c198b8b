"""`armtrack compare` on a session longer than one window (core/windows.py), a window at a
time (issue 15): the truth and the trajectories are kept in spills in the work folder
(compare/spilled.py) and read back a window at a time, so that what compare holds does not
grow with the session's length (the measures' inputs aside, pipeline/kinematics.py).

- The clock offset (declared: its check; "auto": its estimate) from a bounded span: the
  window-and-margins (WINDOW_S + 2 MARGIN_S = 340 s) at the middle of the reference
  trajectory's frames that the truth covers (at the declared offset; "auto": at 0), against
  the truth within the search's reach of it.
- errors.csv: each window's errors on its inner frames (error_rows), pooled exactly
  (compare.errors.pooled: counts, sums, sums of squares, maxima); frames without truth
  counted across windows.
- measures.csv: the truth's markers denoised a window at a time (compare/lowpass_windows.py)
  and sampled at the trajectory's frames, through measure_comparison_windowed.
"""

from __future__ import annotations

from functools import partial

import numpy as np

from armtrack_cli.compare.errors import pooled, truth_at
from armtrack_cli.compare.lowpass_windows import Run, denoised_rows, plan
from armtrack_cli.compare.score import JOINTS, Truth, score
from armtrack_cli.compare.spilled import SpilledTable
from armtrack_cli.compare.sync import estimate_offset
from armtrack_cli.core import windows as win
from armtrack_cli.core.errors import DataError
from armtrack_cli.measures.base import DEFAULT
from armtrack_cli.pipeline.kinematics import (
    XYZ,
    columns,
    measure_comparison_windowed,
    trajectory_inputs,
    truth_inputs,
)
from armtrack_cli.session.config import Session
from armtrack_cli.session.plain_tables import kinematics_rows
from armtrack_cli.session.spill import Spill
from armtrack_cli.session.workfolder import WorkFolder

EXTRA = 2  # truth rows read beyond a span either side: every frame's two neighbours


def session_windows(tab: SpilledTable) -> list[win.Window]:
    """core/windows.windows over a trajectory's span (its WINDOW_S read when called)."""
    return win.windows(tab.first, tab.last, win.WINDOW_S, win.MARGIN_S)


def sync_span(tab: SpilledTable, lo: float = -np.inf, hi: float = np.inf
              ) -> tuple[float, float]:
    """The span the offset is estimated on: one window and its margins at the middle of the
    trajectory's frames within [lo, hi] (where the truth is, at the offset searched about;
    the whole trajectory when they do not meet), the whole of a shorter one."""
    a, b = max(tab.first, lo), min(tab.last, hi)
    if not a < b:
        a, b = tab.first, tab.last
    half = 0.5 * (win.WINDOW_S + 2 * win.MARGIN_S)
    mid = 0.5 * (a + b)
    return max(tab.first, mid - half), min(tab.last, mid + half)


def bounded_offset(tab: SpilledTable, truth: SpilledTable, joint: str, rate: float, *,
                   search_s: float, centre_s: float, eye=None):
    """compare.sync.estimate_offset on sync_span of the trajectory ``tab`` and the truth's
    ``joint`` (raw clock) within the search's reach of it; None as estimate_offset gives."""
    start, stop = sync_span(tab, truth.first + centre_s, truth.last + centre_s)
    names = ("t", *(f"{joint}_{a}" for a in XYZ))
    if not all(n in tab.names for n in names):
        return None
    rows = tab.span(start, stop, names=names)
    est = columns(rows, names[1:])
    reach = search_s + 2.0 / rate
    raw = truth.span(start - centre_s - reach, stop - centre_s + reach, extra=EXTRA,
                     names=("t", joint))
    return estimate_offset(rows["t"], est, raw["t"], raw[joint], rate, search_s=search_s,
                           centre_s=centre_s, eye=eye)


def _truth_piece(truth: SpilledTable, t: np.ndarray, off: float, names) -> dict:
    """The truth's rows around frame times t (session clock), their clock shifted by off."""
    rows = truth.span(float(t[0]) - off, float(t[-1]) - off, extra=EXTRA, names=names)
    rows["t"] = rows["t"] + off
    return rows


def score_windowed(method: str, tab: SpilledTable, truth: SpilledTable, off: float,
                   rate: float, joints: tuple[str, ...]) -> tuple[list, dict]:
    """errors.csv's rows of one method and its frames without truth, a window at a time."""
    rows, excluded, n_rows = [], {}, 0
    for w in session_windows(tab):
        cols = tab.span(w.start, w.stop)
        own = w.inner(cols["t"])
        if not own.any():
            continue
        t = cols["t"][own]
        est = {j: columns(cols, [f"{j}_{a}" for a in XYZ])[own] for j in JOINTS
               if f"{j}_x" in cols}
        piece = _truth_piece(truth, t, off, ("t", *joints))
        s = score(method, t, est, Truth(piece.pop("t"), piece, rate))
        rows += s.rows
        for k, v in s.excluded.items():
            excluded[k] = excluded.get(k, 0) + v
        n_rows = len(s.rows)
    one = bool(rows) and len(rows) == n_rows  # a single window's rows: as they are
    return (rows if one else pooled(rows)), excluded


def _markers_at(truth: SpilledTable, runs: dict[str, list[Run]], t: np.ndarray, off: float,
                rate: float) -> dict[str, np.ndarray]:
    """Every truth marker denoised and sampled at frame times t (session clock), a window at
    a time: role -> (n, 3), NaN in gaps (compare.score.truth_markers of denoised)."""
    out = {k: np.full((t.size, 3), np.nan) for k in runs}
    if not t.size:
        return out
    margin = int(round(win.MARGIN_S * rate))
    for w in win.windows(float(t[0]), float(t[-1]), win.WINDOW_S, win.MARGIN_S):
        own = w.inner(t)
        if not own.any():
            continue
        tt = t[own]
        lo = truth.search(float(tt[0]) - off, "left") - EXTRA
        hi = truth.search(float(tt[-1]) - off, "right") + EXTRA
        lo, hi = max(lo, 0), min(hi, len(truth))
        for k, rk in runs.items():
            rows = partial(_joint_rows, truth, k)
            first, last, x = denoised_rows(rows, rk, lo, hi, rate, DEFAULT.lowpass_hz, margin)
            t_truth = truth.rows(first, last, ("t",))["t"] + off
            out[k][own] = truth_at(tt, t_truth, x, rate)
    return out


def _joint_rows(truth: SpilledTable, joint: str, lo: int, hi: int) -> np.ndarray:
    return truth.rows(lo, hi, (joint,))[joint]


def truth_inputs_reader(session: Session, tab: SpilledTable, truth: SpilledTable,
                        runs: dict[str, list[Run]], off: float, rate: float, store=None):
    """read_truth(w) for measure_comparison_windowed: the truth's Inputs (truth_inputs) of the
    trajectory's frames in [w.start, w.stop]. With ``store`` (a session/spill.Spill the caller
    opened), each window's denoised markers are made once and read back from it after: the
    measures read each window 8-9 times, and denoising was most of compare's time."""
    made: dict[tuple[float, float], tuple[int, int]] = {}  # window -> its rows in store

    def markers(w: win.Window, t: np.ndarray) -> dict[str, np.ndarray]:
        if store is not None and (w.start, w.stop) in made:
            return store.read(*made[w.start, w.stop])
        out = _markers_at(truth, runs, t, off, rate)
        if store is not None:
            a = len(store)
            store.append(out)
            made[w.start, w.stop] = (a, len(store))
        return out

    def read(w: win.Window):
        cols = tab.span(w.start, w.stop)
        return truth_inputs(trajectory_inputs(cols, session), session, markers(w, cols["t"]))
    return read


def denoise_plan(truth: SpilledTable, roles: tuple[str, ...], rate: float
                 ) -> dict[str, list[Run]]:
    """Each role's runs of seen frames, the long ones with their cut-offs (pass one)."""
    inner = int(round(win.WINDOW_S * rate))
    margin = int(round(win.MARGIN_S * rate))
    return {k: plan(partial(_joint_rows, truth, k), len(truth), rate, DEFAULT.lowpass_hz,
                    inner, margin) for k in roles}


def scored_windowed(session: Session, work: WorkFolder, tabs: dict[str, SpilledTable],
                    truth: SpilledTable, roles: tuple[str, ...], off: float, rate: float
                    ) -> tuple[list, list, dict]:
    """errors.csv's rows, measures.csv's rows and the frames without truth, every method
    a window at a time (the truth on its own clock in ``truth``; session = it + off)."""
    rows, mrows, excluded = [], [], {}
    for m, tab in tabs.items():
        if truth.first + off > tab.last or truth.last + off < tab.first:
            raise DataError(session.groundtruth.file, f"does not overlap trajectory-{m}.csv in "
                            f"time (Qualisys {truth.first + off:.2f}…{truth.last + off:.2f} s, "
                            f"trajectory {tab.first:.2f}…{tab.last:.2f} s on the session "
                            "clock)", "check [sync] groundtruth_offset_s")
        r, e = score_windowed(m, tab, truth, off, rate, tuple(j for j in JOINTS if j in roles))
        rows += r
        excluded.update(e)
    runs = denoise_plan(truth, roles, rate)
    with Spill(work.path) as store:  # each window's denoised markers, made once
        for m, tab in tabs.items():
            read = truth_inputs_reader(session, tab, truth, runs, off, rate, store)
            mrows += measure_comparison_windowed(m, kinematics_rows(work / f"kinematics-{m}.csv"),
                                                 read, tab.first, tab.last)
    return rows, mrows, excluded
