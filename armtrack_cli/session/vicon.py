"""Vicon Nexus "Trajectories" CSV exports.

Line 1 ``Trajectories`` (after a UTF-8 byte-order mark, which ``read_text_lines`` drops),
line 2 the rate in Hz, line 3 the marker names (``Subject:Marker``, one name then two empty
cells), line 4 ``Frame,Sub Frame,X,Y,Z,…``, line 5 the units (mm), then one row per frame;
empty cells are gaps. Only the first block (Trajectories) is read: a file may go on with
other blocks (e.g. ``Model Outputs``) after a blank line. Names lose their ``Subject:`` prefix
unless that would make two alike.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from armtrack_cli.core.errors import GroundTruthError
from armtrack_cli.core.streams import MarkerTrajectories
from armtrack_cli.session.c3d import UNITS_TO_M
from armtrack_cli.session.text_table import parse_table, read_text_lines


def looks_like_vicon(lines: list[str]) -> bool:
    return bool(lines) and lines[0].strip().strip(",").lower() == "trajectories"


def _names(path: Path, row: str) -> tuple[list[str], list[int]]:
    cells = [c.strip() for c in row.split(",")]
    at = [k for k, c in enumerate(cells) if c]
    full = [cells[k] for k in at]
    short = [n.split(":", 1)[-1] for n in full]
    names = short if len(set(short)) == len(short) else full
    if len(set(names)) != len(names):
        raise GroundTruthError(path, "line 3 names a marker twice")
    return names, at


def read_vicon_csv(path: str | Path, *, lines: list[str] | None = None) -> MarkerTrajectories:
    """Markers of a Nexus trajectories CSV as (N, M, 3) metres in the lab frame, NaN gaps."""
    path = Path(path)
    lines = lines if lines is not None else read_text_lines(path, GroundTruthError,
                                                            "a Vicon Nexus trajectories CSV")
    if not looks_like_vicon(lines) or len(lines) < 6:
        raise GroundTruthError(path, "is not a Vicon Nexus trajectories CSV (line 1 "
                               "'Trajectories', rate, names, Frame/X/Y/Z header, units, data)")
    try:
        rate = float(lines[1].split(",")[0])
    except ValueError:
        rate = float("nan")
    if not np.isfinite(rate) or rate <= 0:
        raise GroundTruthError(path, f"line 2 is {lines[1][:20]!r}, not the frame rate in Hz")
    names, at = _names(path, lines[2])
    end = next((i for i in range(5, len(lines)) if not lines[i].strip(", ")), len(lines))
    units = {u.strip().lower() for u in lines[4].split(",")[2:] if u.strip()}
    if len(units) != 1 or next(iter(units)) not in UNITS_TO_M:
        raise GroundTruthError(path, f"line 5 gives the units {sorted(units)}, expected one "
                               f"length unit ({', '.join(UNITS_TO_M)})")
    scale = UNITS_TO_M[units.pop()]
    tab = parse_table(path, lines[:end], 3, ",", GroundTruthError, skip_prefixes=(lines[4],))
    m = len(names)
    if tab.data.shape[1] < 2 + 3 * m or at != [2 + 3 * k for k in range(m)]:
        raise GroundTruthError(path, f"has {tab.data.shape[1]} columns for {m} markers "
                               "(Frame, Sub Frame, then X, Y, Z per marker)")
    frame = tab.data[:, 0]
    if not np.isfinite(frame).all() or (np.diff(frame) <= 0).any():
        raise GroundTruthError(path, "the Frame column is empty or does not increase")
    xyz = tab.data[:, 2:2 + 3 * m].reshape(-1, m, 3) * scale
    xyz[~np.isfinite(xyz).all(axis=2)] = np.nan
    return MarkerTrajectories(str(path), (frame - frame[0]) / rate, tuple(names), xyz, rate,
                              (f"first frame {int(frame[0])}",) + tab.notes)
