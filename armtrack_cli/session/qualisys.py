"""Qualisys Track Manager 3-D TSV exports, new and old (SESSION_FORMAT.md, "Qualisys TSV").

Header ``KEY<TAB>value`` lines, then the table with or without a ``Frame Time …`` row and
with or without frame/time columns. Gaps (empty, NaN or all-zero cells) become NaN, never
the origin. Millimetres are converted to metres here.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from armtrack_cli.core.errors import GroundTruthError, did_you_mean
from armtrack_cli.core.limits import MAX_SESSION_S
from armtrack_cli.core.streams import MarkerTrajectories
from armtrack_cli.session.text_head import read_text_head
from armtrack_cli.session.text_table import parse_rows, parse_table

MM = 1e-3  # QTM exports millimetres
_KEY = re.compile(r"^[A-Z][A-Z0-9_]*(\t|$)")

MAX_MARKER_MM = 100_000.0  # 100 m: no motion-capture volume is larger


def _header(path: Path, lines: list[str]) -> tuple[dict[str, list[str]], int]:
    keys: dict[str, list[str]] = {}
    at = 0
    while at < len(lines) and (not lines[at].strip() or _KEY.match(lines[at])):
        parts = [p.strip() for p in lines[at].split("\t")]
        while len(parts) > 1 and parts[-1] == "":
            parts.pop()
        if parts[0]:
            keys[parts[0]] = parts[1:]
        at += 1
    return keys, at


def qualisys_head(path: Path) -> tuple[list[str], dict[str, list[str]], int, tuple[str, ...],
                                       float]:
    """(the file's head lines, its header keys, the table's first line, the marker names, the
    frame rate): a QTM 3D export's header, checked."""
    lines = read_text_head(path, GroundTruthError, "a Qualisys TSV export")  # the rest streamed
    keys, at = _header(path, lines)
    if "NO_OF_BODIES" in keys or "BODY_NAMES" in keys or keys.get("DATA_INCLUDED", [""])[0] == "6D":
        raise GroundTruthError(path, "is a 6DOF (rigid body) export",
                               "export 3D marker data from QTM (File > Export > TSV, 3D)")
    if "MARKER_NAMES" not in keys:
        raise GroundTruthError(path, "has no MARKER_NAMES line",
                               "is it a QTM 3D TSV export? (header keys seen: "
                               f"{', '.join(keys) or 'none'})")
    names = tuple(keys["MARKER_NAMES"])
    if not names:
        raise GroundTruthError(path, "MARKER_NAMES lists no markers")
    if len(set(names)) != len(names):
        raise GroundTruthError(path, "MARKER_NAMES names a marker twice")
    freq_text = (keys.get("FREQUENCY") or [""])[0]
    try:
        freq = float(freq_text)
    except ValueError:
        freq = float("nan")
    if not np.isfinite(freq) or freq <= 0:
        raise GroundTruthError(path, f"FREQUENCY is {freq_text!r}, not a frame rate",
                               "a QTM export states its frame rate in Hz")
    if at >= len(lines):
        raise GroundTruthError(path, "has a header but no data (truncated export?)")
    return lines, keys, at, names, freq


def read_qualisys(path: str | Path) -> MarkerTrajectories:
    path = Path(path)
    lines, keys, at, names, freq = qualisys_head(path)
    m = len(names)
    has_row = _names_row(lines[at])

    def groups(header: list[str]) -> tuple[tuple[int, ...], ...]:
        """The frame and time columns and the coordinates', each read into its own array:
        the table itself is not kept (issue 15)."""
        frame, time, first = _layout(header, has_row, m)
        return tuple((c,) for c in (frame, time) if c is not None) + (
            tuple(range(max(first, 0), len(header))),)

    if has_row:
        tab = parse_table(path, lines, at, "\t", GroundTruthError, groups=groups)
    else:
        fake = [f"c{k}" for k in range(len(lines[at].rstrip("\t\r\n").split("\t")))]
        tab = parse_rows(path, lines, at, fake, "\t", GroundTruthError, groups=groups)
    frame_col, time_col, first = _layout(tab.header, has_row, m)
    if (first not in (0, 1, 2)) if not has_row else (len(tab.header) - first != 3 * m):
        raise GroundTruthError(path, f"line {at + 1} has {len(tab.header)} columns, which does "
                               f"not fit {m} markers (MARKER_NAMES) x 3 coordinates"
                               + (f" after {first} frame/time columns" if has_row else ""),
                               "is MARKER_NAMES complete?")
    coords = tab.block(tuple(range(first, len(tab.header))))
    far = (coords > MAX_MARKER_MM) | (coords < -MAX_MARKER_MM)  # ±inf too; NaN (a gap) not
    if far.any():
        r, k = np.argwhere(far)[0]
        raise GroundTruthError(path, f"line {tab.line_of[r]}: marker {names[k // 3]} has "
                               f"{'XYZ'[k % 3]} = {coords[r, k]:g} mm, beyond any capture volume",
                               "the row is damaged: empty its cells (a gap)")
    t = _times(path, tab, time_col, frame_col, freq, coords.shape[0]).copy()
    coords *= MM  # in place (as (N, 3M): a (N, M, 3) view would be copied to multiply)
    xyz = coords.reshape(-1, m, 3)  # a view of the coordinates' own array: no copy
    xyz[np.all(xyz == 0.0, axis=2)] = np.nan  # QTM writes gaps as zeros in some versions
    xyz[np.any(np.isnan(xyz), axis=2)] = np.nan
    notes = list(tab.notes)
    n_frames = keys.get("NO_OF_FRAMES", [None])[0]
    if n_frames is not None and n_frames.isdigit() and int(n_frames) != xyz.shape[0]:
        notes.append(f"NO_OF_FRAMES says {n_frames}, the table has {xyz.shape[0]} rows")
    return MarkerTrajectories(str(path), t, names, xyz, freq, tuple(notes))


def _names_row(line: str) -> bool:
    """Whether the table's first line names its columns: ``Frame Time R_SHO X …``, or
    ``R_SHO X …`` alone when frame and time were not exported; not a number."""
    cell = line.split("\t")[0].strip()
    try:
        float(cell)
    except ValueError:
        return cell != ""
    return False


def _layout(header: list[str], has_row: bool, m: int) -> tuple[int | None, int | None, int]:
    """The frame and time columns (None: absent) and the first coordinate's: named in a
    ``Frame Time …`` row, else told by the columns beyond the M markers' 3 M."""
    if has_row:
        low = [h.lower() for h in header]
        frame = low.index("frame") if "frame" in low else None
        time = low.index("time") if "time" in low else None
        return frame, time, len([c for c in (frame, time) if c is not None])
    first = len(header) - 3 * m
    return 0 if first >= 1 else None, 1 if first == 2 else None, first


def _times(path: Path, tab, time_col: int | None, frame_col: int | None, freq: float,
           n: int) -> np.ndarray:
    """Frame times (s from the first frame): the Time column, else Frame / FREQUENCY, else
    row / FREQUENCY; checked to be finite, increasing and ticking at FREQUENCY."""
    if time_col is not None:
        t = tab.block((time_col,))[:, 0]
    elif frame_col is not None:
        t = (tab.block((frame_col,))[:, 0] - 1) / freq
    else:
        t = np.arange(n) / freq
    if not np.isfinite(t).all():
        r = int(np.flatnonzero(~np.isfinite(t))[0])
        raise GroundTruthError(path, f"line {tab.line_of[r]}: the time/frame cell is empty")
    d = np.diff(t)
    if (d <= 0).any():
        r = int(np.flatnonzero(d <= 0)[0]) + 1
        raise GroundTruthError(path, f"line {tab.line_of[r]}: time goes from {t[r - 1]:g} to "
                               f"{t[r]:g} s", "frames must be in increasing time order")
    step = float(np.median(d)) if d.size else 1.0 / freq
    if abs(step * freq - 1.0) > 0.05:  # the Time column must tick at FREQUENCY
        raise GroundTruthError(path, f"its Time column steps by {step:g} per frame, but FREQUENCY "
                               f"{freq:g} Hz means {1 / freq:g} s (is the time in ms?)",
                               "export Time in seconds, as QTM does")
    if t[-1] - t[0] > MAX_SESSION_S:
        raise GroundTruthError(path, f"spans {(t[-1] - t[0]) / 3600:.0f} h: its time is damaged")
    return t


def select_markers(traj: MarkerTrajectories, wanted: dict[str, str], toml: Path) -> dict[str, int]:
    """{role: column} for the markers session.toml names; unknown names are an error."""
    out = {}
    for role, name in wanted.items():
        if name not in traj.names:
            raise missing_marker(traj, name, f"[groundtruth] markers.{role} in {toml.name}")
        out[role] = traj.names.index(name)
        if not np.isfinite(traj.xyz[:, out[role]]).all(axis=1).any():
            raise GroundTruthError(traj.path, f"marker {name!r} ({role}) is never seen: every "
                                   "frame is a gap", "check the marker labels in QTM")
    return out


def missing_marker(traj: MarkerTrajectories, name: str, where: str) -> GroundTruthError:
    """The error for a marker the file lacks; a 6DOF export says it holds bodies, not markers."""
    close = did_you_mean(name, traj.names)  # a typo: name the near one, not all of them
    if traj.rotations is not None:
        return GroundTruthError(traj.path, f"is a 6DOF (rigid body) export with no body {name!r} "
                                f"({where})", close or f"its bodies are {', '.join(traj.names)}: "
                                "name a body there, or export 3D markers from QTM")
    return GroundTruthError(traj.path, f"has no marker {name!r} ({where})",
                            close or f"its markers are {', '.join(traj.names)}")


def to_world(xyz: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Apply the 4x4 Qualisys -> W transform to (..., 3) points in metres; NaN stays NaN."""
    out = xyz @ T[:3, :3].T
    out += T[:3, 3]  # in place: one new array of the points' size, not two
    return out
