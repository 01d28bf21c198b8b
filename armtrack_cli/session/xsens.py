"""Xsens exports: MT Manager text files of every generation, and Xsens DOT CSV.

MT Manager: ``//`` comment header (legacy ``// Update Rate: 100.0Hz``; 2019+ ``// General
information:`` with ``// Coordinate system: ENU|NED|NWU``), then a tab/comma/semicolon/space
separated table. DOT: a ``sep=,`` first line, free-text metadata, SampleTimeFine in µs,
gyro in deg/s, FreeAcc (gravity removed, in the global frame).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from armtrack_cli.core import quaternion as quat
from armtrack_cli.core.errors import ImuFileError
from armtrack_cli.core.streams import ImuSamples
from armtrack_cli.session.imu_checks import unit_quaternions
from armtrack_cli.session.text_table import (
    TextTable,
    named_groups,
    parse_table,
    read_text_lines,
    sniff_delimiter,
    split_row,
)

GRAVITY = 9.81
STF_WRAP = 2**32  # SampleTimeFine is a uint32
COUNTER_WRAP = 2**16  # PacketCounter is a uint16
# NED is z-down: turn it 180° about x (x kept, y and z negated) to get a z-up frame. Xsens
# applies NED/NWU to the local frame only (MTi User Manual, "RotLocal"), so the calibrated
# data stay in the sensor frame S; ENU and NWU are already z-up and are used as they are.
Q_NED_TO_ZUP = np.array([0.0, 1.0, 0.0, 0.0])
_XYZ = ("X", "Y", "Z")
# the column groups a reader uses (_build): read each into an array of its own, nothing else
# kept (session/numeric_text.py; issue 15)
GROUPS = (("PacketCounter",), ("SampleTimeFine",),
          *(tuple(f"{g}_{a}" for a in _XYZ) for g in ("Acc", "FreeAcc", "Gyr", "Mag", "Euler")),
          ("Quat_q0", "Quat_q1", "Quat_q2", "Quat_q3"), ("Quat_W", "Quat_X", "Quat_Y", "Quat_Z"),
          tuple(f"Mat[{i}][{j}]" for i in (1, 2, 3) for j in (1, 2, 3)),
          ("Roll", "Pitch", "Yaw"))
_HEADER_HINTS = ("packetcounter", "sampletimefine", "acc_x", "quat_q0", "quat_w", "freeacc_x")


def looks_like_mt_manager(lines: list[str]) -> bool:
    if lines and lines[0].startswith("//"):
        return True
    for ln in lines[:200]:
        if ln.startswith("//") or not ln.strip():
            continue
        return any(h in ln.lower() for h in _HEADER_HINTS)
    return False


def looks_like_dot(lines: list[str]) -> bool:
    return bool(lines) and lines[0].strip().lower().startswith("sep=")


def _column_name(raw: str) -> str:
    """'Gyr_X (°/s)' -> 'Gyr_X'; units are read separately by _unit."""
    return re.split(r"[\s(\[]", raw.strip(), maxsplit=1)[0] if not raw.startswith("Mat[") else raw


def _vec(tab: TextTable, names: list[str]) -> np.ndarray | None:
    return tab.columns(*names) if tab.has(*names) else None


def _unwrap(v: np.ndarray, wrap: int) -> np.ndarray:
    """Counts that wrap at ``wrap``, made monotonic; differences taken modulo wrap."""
    out = np.empty(v.shape[0])
    out[0] = 0.0
    np.cumsum(np.mod(np.diff(v), wrap), out=out[1:])  # no copy of the sum (issue 15)
    return out


def _header_rate(path: Path, i: int, text: str) -> float:
    """The rate of an ``// Update Rate: 100.0Hz`` line, checked to be a sane number."""
    try:
        rate = float(text)
    except ValueError:
        raise ImuFileError(path, f"line {i + 1}: Update Rate {text!r} is not a number of Hz",
                           "correct or delete that header line") from None
    if not 1.0 <= rate <= 10000.0:
        raise ImuFileError(path, f"line {i + 1}: Update Rate {rate:g} Hz is outside 1 … 10000 Hz",
                           "correct or delete that header line")
    return rate


def _counter_steps(path: Path, line_of: np.ndarray, counter: np.ndarray) -> np.ndarray:
    """Steps between consecutive packet counters (1 = none lost), checked for repeats."""
    counter_whole(path, line_of, counter)
    d = np.mod(np.diff(counter), COUNTER_WRAP)
    counter_repeats(path, line_of, counter, d)
    counter_back(path, line_of, counter, d)
    return d


# _counter_steps' and _times' checks one by one: xsens_stream.py runs each on a chunk's rows
# (the previous chunk's last row before them) and raises the first of each, in this order
def counter_whole(path: Path, line_of: np.ndarray, counter: np.ndarray) -> None:
    bad = ~np.isfinite(counter) | (counter < 0) | (counter != np.round(counter))
    if bad.any():
        r = int(np.flatnonzero(bad)[0])
        raise ImuFileError(path, f"line {line_of[r]}: PacketCounter is empty or not a "
                           f"whole number ({counter[r]})")


def counter_repeats(path: Path, line_of: np.ndarray, counter: np.ndarray, d: np.ndarray) -> None:
    if (d == 0).any():
        r = int(np.flatnonzero(d == 0)[0]) + 1
        raise ImuFileError(path, f"line {line_of[r]}: PacketCounter {int(counter[r])} "
                           "repeats the previous packet", "is the file two recordings pasted together?")


def counter_back(path: Path, line_of: np.ndarray, counter: np.ndarray, d: np.ndarray) -> None:
    if (d > COUNTER_WRAP // 2).any():
        r = int(np.flatnonzero(d > COUNTER_WRAP // 2)[0]) + 1
        raise ImuFileError(path, f"line {line_of[r]}: PacketCounter jumps back from "
                           f"{int(counter[r - 1])} to {int(counter[r])}",
                           "rows are out of order or the file mixes recordings")


def stf_ticks(path: Path, line_of: np.ndarray, stf: np.ndarray) -> None:
    bad = (stf < 0) | (stf >= STF_WRAP) | (stf != np.round(stf))
    if bad.any():
        r = int(np.flatnonzero(bad)[0])
        raise ImuFileError(path, f"line {line_of[r]}: SampleTimeFine {stf[r]:g} is not "
                           "a tick count (a whole number from 0 to 2^32 − 1)")


def stf_order(path: Path, line_of: np.ndarray, stf: np.ndarray) -> None:
    back = np.diff(stf)
    # a wrap at 2^32 jumps back by nearly 2^32; a smaller step back is a damaged row
    bad = (back <= 0) & (back > -STF_WRAP / 2)
    if bad.any():
        r = int(np.flatnonzero(bad)[0]) + 1
        raise ImuFileError(path, f"line {line_of[r]}: SampleTimeFine steps back or "
                           f"repeats ({int(stf[r - 1])} then {int(stf[r])})",
                           "rows are out of order or the file mixes recordings")


def stf_rate(path: Path, header_rate: float | None, median_step: float) -> float:
    """The SampleTimeFine clock's rate (from its median step), checked against the header's."""
    rate = float(1.0 / median_step)  # the clock itself, not a header line
    if header_rate is not None and abs(header_rate / rate - 1.0) > 0.05:
        raise ImuFileError(path, f"states Update Rate {header_rate:g} Hz but its "
                           f"SampleTimeFine clock runs at {rate:.4g} Hz",
                           "correct or delete the Update Rate header line")
    return rate


def stf_partial(path: Path, line: int) -> ImuFileError:
    return ImuFileError(path, f"line {line}: SampleTimeFine is missing in some rows but not all")


def no_rate(path: Path) -> ImuFileError:
    return ImuFileError(path, "states no update rate and has no SampleTimeFine",
                        "set [imu] rate_hz in session.toml to the rate it was recorded at")


def _times(path: Path, tab: TextTable, *, stf_tick_s: float, header_rate: float | None,
           rate_hz: float | None) -> tuple[np.ndarray, float, int, list[str]]:
    """Stream times (s from the first sample), nominal rate, dropped-sample count, notes.

    SampleTimeFine gives true times (unwrapped at 2^32); without it PacketCounter gives them
    at the nominal rate, so dropped packets keep their true place and nothing is shifted.
    """
    notes: list[str] = []
    counter = _vec(tab, ["PacketCounter"])
    steps = _counter_steps(path, tab.line_of, counter[:, 0]) if counter is not None else None
    dropped = int(np.sum(steps - 1)) if steps is not None else 0
    stf = _vec(tab, ["SampleTimeFine"])
    if stf is not None and np.isfinite(stf).all():
        stf_ticks(path, tab.line_of, stf[:, 0])
        stf_order(path, tab.line_of, stf[:, 0])
        t = _unwrap(stf[:, 0], STF_WRAP)
        t *= stf_tick_s
        per_step = np.diff(t) / (steps if steps is not None else 1)
        if per_step.size == 0:  # one sample has no clock rate; read_imu refuses it as too short
            return t, float(header_rate or rate_hz or np.nan), dropped, notes
        return t, stf_rate(path, header_rate, np.median(per_step)), dropped, notes
    if stf is not None and np.isfinite(stf).any():
        raise stf_partial(path, tab.line_of[int(np.flatnonzero(~np.isfinite(stf[:, 0]))[0])])
    rate = header_rate or rate_hz
    if rate is None:
        raise no_rate(path)
    if steps is None:
        notes.append("no PacketCounter: dropped samples cannot be detected")
        return np.arange(tab.n_rows) / rate, rate, 0, notes
    return np.concatenate([[0.0], np.cumsum(steps)]) / rate, rate, dropped, notes


def _orientation(path: Path, tab: TextTable) -> np.ndarray | None:
    """(N, 4) quaternions (w, x, y, z) R_GS from whichever orientation columns exist."""
    q = _vec(tab, ["Quat_q0", "Quat_q1", "Quat_q2", "Quat_q3"])
    if q is None:
        q = _vec(tab, ["Quat_W", "Quat_X", "Quat_Y", "Quat_Z"])  # DOT
    if q is not None:
        return q
    names = [f"Mat[{i}][{j}]" for i in (1, 2, 3) for j in (1, 2, 3)]
    m = _vec(tab, names)
    if m is not None:  # Mat[i][j] is R_GS[i-1][j-1] (checked against Quat_q in MT Manager 2022)
        R = m.reshape(-1, 3, 3)
        q = np.full((R.shape[0], 4), np.nan)
        ok = np.isfinite(R).all(axis=(1, 2))
        q[ok] = quat.from_matrix(R[ok])
        return q
    e = _vec(tab, ["Roll", "Pitch", "Yaw"])
    if e is None:
        e = _vec(tab, ["Euler_X", "Euler_Y", "Euler_Z"])  # DOT: roll, pitch, yaw
    if e is not None:  # degrees, R = Rz(yaw) Ry(pitch) Rx(roll)
        e = np.deg2rad(e)
        return quat.from_euler_zyx(e[:, 0], e[:, 1], e[:, 2])
    return None


def _build(path: Path, tab: TextTable, fmt: str, *, stf_tick_s: float, header_rate: float | None,
           rate_hz: float | None, gyro_scale: float, coord: str, notes: list[str]) -> ImuSamples:
    t, rate, dropped, tnotes = _times(path, tab, stf_tick_s=stf_tick_s, header_rate=header_rate,
                                      rate_hz=rate_hz)
    q = _orientation(path, tab)
    if q is not None:
        q = unit_orientation(path, q, tab.line_of)
        if coord == "NED":
            q = to_zup(q, coord)
            notes.append("orientation converted from NED to z-up (180° about x)")
    acc = _vec(tab, ["Acc_X", "Acc_Y", "Acc_Z"])
    absent: set[str] = set()  # channel groups the file does not export at all
    if acc is None:
        free = _vec(tab, ["FreeAcc_X", "FreeAcc_Y", "FreeAcc_Z"])
        if free is None or q is None:  # described by info; fuse refuses (imu.require_channels)
            acc = np.full((tab.n_rows, 3), np.nan)
            absent.add("Acc")
            notes.append("no accelerometer (Acc_X/Acc_Y/Acc_Z) columns; columns seen: "
                         + ", ".join(tab.header))
        else:
            acc = from_free(free, q)
            notes.append("specific force rebuilt from FreeAcc and orientation")
    gyr = _vec(tab, ["Gyr_X", "Gyr_Y", "Gyr_Z"])
    if gyr is None:
        gyr = np.full_like(acc, np.nan)
        absent.add("Gyr")
        notes.append("no gyroscope columns" if q is not None else
                     "neither gyroscope (Gyr_X..Z) nor orientation columns")
    elif gyro_scale != 1.0:  # the group's own array (TextTable.columns), scaled in place
        np.multiply(gyr, gyro_scale, out=gyr)
    mag = _vec(tab, ["Mag_X", "Mag_Y", "Mag_Z"])
    for name, arr in (("Acc", acc), ("Gyr", gyr)):
        for k, ax in enumerate("XYZ"):
            if name not in absent and np.isnan(arr[:, k]).all():
                notes.append(f"{name}_{ax} is empty (NaN) in every row")
    return ImuSamples(str(path), fmt, t, acc, gyr, mag, q, rate, dropped,
                      "file" if q is not None else "none", tuple(notes + tnotes + list(tab.notes)))


def unit_orientation(path: Path, q: np.ndarray, line_of: np.ndarray) -> np.ndarray:
    """q normalised in place, refused at the first row not near unit norm (its line named)."""
    return unit_quaternions(path, q, lambda r: f"line {line_of[r]}", "orientation quaternion",
                            "are the columns mislabelled or scaled?")


def to_zup(q: np.ndarray, coord: str) -> np.ndarray:
    """Quaternions R_GS of an export in ``coord`` with G made z-up (NED turned about x)."""
    return quat.multiply(Q_NED_TO_ZUP, q) if coord == "NED" else q


def from_free(free: np.ndarray, q: np.ndarray) -> np.ndarray:
    """FreeAcc = a_W (gravity removed, global frame): f_B = R_WBᵀ (a_W − g_W)."""
    return quat.rotate(quat.conjugate(q), free + np.array([0.0, 0.0, GRAVITY]))


def read_mt_manager(path: Path, *, rate_hz: float | None = None,
                    lines: list[str] | None = None) -> ImuSamples:
    """An MT Manager text export (legacy, 2019/2020, 2022; any delimiter)."""
    lines = lines if lines is not None else read_text_lines(path, ImuFileError,
                                                            "an Xsens MT Manager export")
    header_rate, coord, header_at = mt_head(path, lines)
    delim = sniff_delimiter(lines[header_at])
    tab = _table(path, lines, header_at, delim)
    notes = [f"coordinate system {coord}"] if coord != "ENU" else []
    return _build(path, tab, "xsens-mt", stf_tick_s=1e-4, header_rate=header_rate,
                  rate_hz=rate_hz, gyro_scale=1.0, coord=coord, notes=notes)


def mt_head(path: Path, lines: list[str]) -> tuple[float | None, str, int]:
    """An MT Manager export's header: its Update Rate (or None), coordinate system and the
    index of its column header line."""
    header_rate, coord = None, "ENU"
    header_at = None
    for i, ln in enumerate(lines):
        if ln.startswith("//"):
            m = re.search(r"update rate:\s*(.*?)\s*(hz)?\s*$", ln, re.I)
            if m:
                header_rate = _header_rate(path, i, m.group(1))
            m = re.search(r"coordinate system:\s*(\w+)", ln, re.I)
            if m:
                coord = m.group(1).upper()
                if coord not in ("ENU", "NED", "NWU"):
                    raise ImuFileError(path, f"line {i + 1}: coordinate system {coord!r} is not "
                                       "ENU, NED or NWU")
            continue
        if ln.strip():
            header_at = i
            break
    if header_at is None:
        raise ImuFileError(path, "has only comment lines: no column header and no data "
                           "(truncated export?)")
    return header_rate, coord, header_at


def _table(path: Path, lines: list[str], header_at: int, delim: str | None) -> TextTable:
    """The export's table, its column names without units, only GROUPS' columns kept."""
    tab = parse_table(path, lines, header_at, delim, ImuFileError,
                      groups=named_groups(*GROUPS, rename=_column_name))
    return TextTable([_column_name(h) for h in tab.header], tab.data, tab.line_of, tab.notes,
                     tab.groups)


def _unit(raw: str) -> str:
    m = re.search(r"[(\[]([^)\]]*)[)\]]", raw)
    return m.group(1).strip().lower() if m else ""


def read_dot(path: Path, *, rate_hz: float | None = None,
             lines: list[str] | None = None) -> ImuSamples:
    """An Xsens (Movella) DOT CSV export: ``sep=,`` line, metadata, then the table."""
    lines = lines if lines is not None else read_text_lines(path, ImuFileError,
                                                            "an Xsens DOT CSV export")
    delim = lines[0].strip()[4:5] or ","
    header_at = None
    for i, ln in enumerate(lines[1:], start=1):
        low = ln.lower()
        if "packetcounter" in low or "sampletimefine" in low:
            header_at = i
            break
    if header_at is None:
        raise ImuFileError(path, "is a DOT export (sep= line) without a PacketCounter/"
                           "SampleTimeFine header row")
    raw_header = split_row(lines[header_at], delim)
    tab = _table(path, lines, header_at, delim)
    gyr_units = [_unit(h) for h in raw_header if h.lower().startswith("gyr_")]
    # DOT reports angular rate in deg/s unless the header says rad/s
    gyro_scale = 1.0 if gyr_units and "rad" in gyr_units[0] else np.pi / 180.0
    return _build(path, tab, "xsens-dot", stf_tick_s=1e-6, header_rate=None, rate_hz=rate_hz,
                  gyro_scale=gyro_scale, coord="ENU", notes=[])
