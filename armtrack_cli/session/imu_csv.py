"""The contract's generic IMU CSV: ``t,ax,ay,az,gx,gy,gz`` [+ ``mx,my,mz``] [+ ``qw,qx,qy,qz``].

t in s, specific force in m/s², rate in rad/s, field in µT, quaternion (w, x, y, z) B -> W.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from armtrack_cli.core.errors import ImuFileError
from armtrack_cli.core.streams import ImuSamples
from armtrack_cli.session.imu_checks import rate_and_dropped, unit_quaternions
from armtrack_cli.session.text_table import (
    header_line,
    named_groups,
    parse_table,
    read_text_lines,
    sniff_delimiter,
)

REQUIRED = ("t", "ax", "ay", "az", "gx", "gy", "gz")
SKIP = ("#",)  # comment lines among the rows
GROUPS = (("t",), ("ax", "ay", "az"), ("gx", "gy", "gz"), ("mx", "my", "mz"), ("qw", "qx", "qy", "qz"))


def looks_like_generic_csv(lines: list[str]) -> bool:
    """A header that starts t and names ax, or names every required column in any order
    (a lab's export may add an index or a temperature column, or quote its names)."""
    at = header_line(lines[:50])
    if at is None:
        return False
    cells = [c.strip().strip('"').lower()
             for c in lines[at].replace(";", ",").replace("\t", ",").split(",")]
    return bool(cells) and ((cells[0] == "t" and "ax" in cells) or set(REQUIRED) <= set(cells))


def check_times(path: Path, t: np.ndarray, line_of: np.ndarray, column: str = "t") -> None:
    """Times must be present, finite and strictly increasing."""
    nan = ~np.isfinite(t)
    if nan.any():
        times_missing(path, line_of[np.flatnonzero(nan)[0]], int(nan.sum()), column)
    d = np.diff(t)
    times_repeat(path, t, line_of, d)
    times_back(path, t, line_of, d)


# check_times' checks one by one, for imu_csv_stream.py (a chunk's rows, the previous last)
def times_missing(path: Path, line: int, count: int, column: str = "t") -> None:
    raise ImuFileError(path, f"line {line}: column {column!r} is empty or NaN in "
                       f"{count} rows", "sample times cannot be missing")


def times_repeat(path: Path, t: np.ndarray, line_of: np.ndarray, d: np.ndarray) -> None:
    if (d == 0).any():
        r = int(np.flatnonzero(d == 0)[0]) + 1
        raise ImuFileError(path, f"line {line_of[r]}: time {t[r]:g} s repeats the previous row")


def times_back(path: Path, t: np.ndarray, line_of: np.ndarray, d: np.ndarray) -> None:
    if (d < 0).any():
        r = int(np.flatnonzero(d < 0)[0]) + 1
        raise ImuFileError(path, f"line {line_of[r]}: time goes back from {t[r - 1]:g} to "
                           f"{t[r]:g} s", "rows must be in time order")


def csv_head(path: Path, lines: list[str]) -> tuple[int, str]:
    """The header line's index and its delimiter, refused unless commas."""
    header_at = header_line(lines)
    if header_at is None:
        raise ImuFileError(path, "has no header line")
    delim = sniff_delimiter(lines[header_at])
    if delim != ",":
        seen = {"\t": "tabs", ";": "semicolons", None: "spaces"}[delim]
        raise ImuFileError(path, f"is separated by {seen}, not commas",
                           "the generic IMU CSV is comma-separated: t,ax,ay,az,gx,gy,gz")
    return header_at, delim


def missing_columns(header: list[str]) -> list[str]:
    names = [h.lower() for h in header]
    return [c for c in REQUIRED if c not in names]


def unit_q(path: Path, q: np.ndarray, line_of: np.ndarray) -> np.ndarray:
    """q normalised in place, refused at the first row not near unit norm (its line named)."""
    return unit_quaternions(path, q, lambda r: f"line {line_of[r]}", "quaternion (qw,qx,qy,qz)",
                            "is the order (w, x, y, z)?")


def read_generic_csv(path: Path, *, lines: list[str] | None = None) -> ImuSamples:
    lines = lines if lines is not None else read_text_lines(path, ImuFileError, "an IMU CSV")
    header_at, delim = csv_head(path, lines)
    tab = parse_table(path, lines, header_at, delim, ImuFileError, skip_prefixes=SKIP,
                      groups=named_groups(*GROUPS))  # only what is returned kept (issue 15)
    missing = missing_columns(tab.header)
    if missing:
        raise ImuFileError(path, f"lacks column(s) {', '.join(missing)}",
                           f"the generic CSV needs {','.join(REQUIRED)}; header is "
                           f"{','.join(tab.header)}")
    t = tab.columns("t")[:, 0]
    check_times(path, t, tab.line_of)
    t = t - t[0]
    acc = tab.columns("ax", "ay", "az")
    gyr = tab.columns("gx", "gy", "gz")
    mag = tab.columns("mx", "my", "mz") if tab.has("mx", "my", "mz") else None
    q = None
    if tab.has("qw", "qx", "qy", "qz"):
        q = unit_q(path, tab.columns("qw", "qx", "qy", "qz"), tab.line_of)
    rate, dropped = rate_and_dropped(t)
    return ImuSamples(str(path), "csv", t, acc, gyr, mag, q, rate, dropped,
                      "file" if q is not None else "none", tab.notes)
