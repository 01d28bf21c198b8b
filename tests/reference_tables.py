"""The numeric-table readers as they were before session/numeric_text.py (commit 904a84a),
kept verbatim as the reference the streaming reader must equal (issue 15): text_table's
whole-lines parse (loadtxt over the data lines, else pandas row by row), text_head's
whole-file loadtxt of a long export's body, and plain_tables' regex-and-loadtxt read of a
trajectory. Tests only: nothing in armtrack_cli imports this."""

from __future__ import annotations

import io
import re
from pathlib import Path

import numpy as np

from armtrack_cli.core.errors import DataError
from armtrack_cli.core.limits import MAX_TEXT_BYTES
from armtrack_cli.session.files import regular_file
from armtrack_cli.session.plain_tables import MAX_POSITION_M, TRAJECTORY_NEEDS
from armtrack_cli.session.text_table import TextTable, read_text_lines

MISSING_TOKENS = {"", "nan", "na", "n/a", "null", "-nan"}
_EMPTY_CELL = re.compile(r"(?<![^,\n])(?=,|\n|$)")  # a cell with nothing in it


class Irregular(Exception):
    """The file is not the plain form: the pandas reader decides."""


def numbers_after(path: Path, header_at: int, delimiter: str | None,
                  n: int) -> tuple[np.ndarray, np.ndarray] | None:
    """(data (N, n), line_of (N,) 1-based) of every line after line ``header_at`` (0-based)
    when each is n numbers (or nan/inf) and nothing else, no line blank; else None."""
    if delimiter not in ("\t", ",", ";", None):
        return None
    try:
        data = np.loadtxt(path, delimiter=delimiter, skiprows=header_at + 1, dtype=float,
                          ndmin=2, comments=None, encoding="latin-1")
    except ValueError:
        return None
    lines, last = 0, b"\n"
    with open(path, "rb") as f:  # every line after the header a row: the rows' lines known
        for chunk in iter(lambda: f.read(1 << 20), b""):
            lines, last = lines + chunk.count(b"\n"), chunk[-1:]
    lines += last != b"\n"
    if data.shape != (lines - header_at - 1, n) or not data.shape[0]:
        return None
    return data, np.arange(header_at + 2, header_at + 2 + data.shape[0])


def split_row(line: str, delimiter: str | None) -> list[str]:
    """Fields of one row. " " splits field by field (two spaces = an empty field between)."""
    if delimiter is None:
        return line.split()
    if delimiter == " ":
        return line.strip("\r\n").split(" ")
    return [c.strip() for c in line.split(delimiter)]


def _fields(line: str, delimiter: str | None, n: int) -> list[str]:
    """Fields of a data row; a single-space row whose fields are aligned with runs of spaces
    (and so does not split into n field by field) falls back to runs of spaces."""
    cells = split_row(line, delimiter)
    while len(cells) > n and cells[-1] == "":
        cells.pop()
    if delimiter == " " and len(cells) != n and len(line.split()) == n:
        return line.split()
    return cells


def _plain_numbers(lines: list[str], header_at: int, delimiter: str | None, n: int,
                   skip_prefixes: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray] | None:
    """(data, line_of) read at C speed (numpy's loadtxt) when every data row is n numbers (or
    nan/inf) and nothing else: the common export, and the bulk of a long session's bytes
    (row-by-row lists of strings held a 60-minute IMU file's 360,000 rows as ~250 MB). None
    for anything else (an empty or "NA" cell, a ragged or truncated row, text), which the
    row-by-row parse then reads or names."""
    if delimiter not in ("\t", ",", ";", None):
        return None
    at = [i for i in range(header_at + 1, len(lines))
          if lines[i].strip() and not lines[i].startswith(skip_prefixes)]
    if not at:
        return None
    try:
        data = np.loadtxt([lines[i] for i in at], delimiter=delimiter, dtype=float, ndmin=2,
                          comments=None)
    except ValueError:
        return None
    if data.shape != (len(at), n):
        return None
    return data, np.asarray(at) + 1  # 1-based file lines


def parse_table(path: Path, lines: list[str], header_at: int, delimiter: str | None,
                error: type[DataError], *, skip_prefixes: tuple[str, ...] = ()) -> TextTable:
    """Parse lines[header_at] as the header and the non-blank lines after it as data.

    Trailing empty fields (a trailing delimiter) are ignored; a last line with too few
    fields is a truncated write and is dropped with a note; any other ragged row is an error.
    """
    header = split_row(lines[header_at], delimiter)
    while header and header[-1] == "":
        header.pop()
    if not header:
        raise error(path, f"line {header_at + 1}: the column header is empty")
    n = len(header)
    if getattr(lines, "whole", True):
        fast = _plain_numbers(lines, header_at, delimiter, n, skip_prefixes)
    else:  # a long file's head (session/text_head.py): its numbers from the file itself
        fast = None if skip_prefixes else numbers_after(path, header_at, delimiter, n)
    if fast is not None:
        return TextTable(header, *fast)
    if not getattr(lines, "whole", True):  # the row-by-row parse, over every line
        lines = read_text_lines(path, error, "a text table")
    rows: list[list[str]] = []
    line_no: list[int] = []
    notes: list[str] = []
    body = [(i, ln) for i, ln in enumerate(lines[header_at + 1:], start=header_at + 2)
            if ln.strip() and not ln.startswith(skip_prefixes)]
    for k, (i, ln) in enumerate(body):
        cells = _fields(ln, delimiter, n)
        if len(cells) != n:
            if k == len(body) - 1 and len(cells) < n and rows:
                notes.append(f"last line {i} has {len(cells)} of {n} fields (truncated write): "
                             "dropped")
                break
            sep = {"\t": "tab", ",": "comma", ";": "semicolon", " ": "space", None: "space"}[delimiter]
            raise error(path, f"line {i} has {len(cells)} fields but the header has {n} "
                        f"({sep}-separated)", "is the file cut short or mixing delimiters?")
        rows.append(cells)
        line_no.append(i)
    if not rows:
        raise error(path, "has a column header but no data rows (truncated?)")
    import pandas as pd  # the slow path only: plain numeric tables never get here

    frame = pd.DataFrame(rows, columns=range(n))
    data = np.empty((len(rows), n))
    for c in range(n):
        col = frame[c]
        num = pd.to_numeric(col, errors="coerce").to_numpy(dtype=float)
        bad = np.isnan(num) & ~col.str.lower().isin(MISSING_TOKENS).to_numpy()
        if bad.any():
            r = int(np.flatnonzero(bad)[0])
            raise error(path, f"line {line_no[r]}, column {header[c]!r}: {rows[r][c]!r} is not a "
                        "number")
        data[:, c] = num
    return TextTable(header, data, np.asarray(line_no), tuple(notes))



def _text(path: Path, hint: str, *, quotes: bool = False) -> str:
    regular_file(path, DataError, "a CSV table", hint=hint, max_bytes=MAX_TEXT_BYTES)
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError):
        raise Irregular from None
    if (not quotes and '"' in text) or "\r" in text:
        raise Irregular
    return text


def plain_trajectory(path: Path) -> dict[str, np.ndarray]:
    text = _text(path, "run `armtrack fuse SESSION --method M` first")
    head, _, body = text.partition("\n")
    names = head.split(",")
    if (len(set(names)) != len(names) or any(n != n.strip() or not n for n in names)
            or not set(TRAJECTORY_NEEDS) <= set(names) or not body.strip()):
        raise Irregular
    try:
        values = np.loadtxt(io.StringIO(_EMPTY_CELL.sub("nan", body.rstrip("\n"))),
                            delimiter=",", ndmin=2, dtype=float)
    except ValueError:
        raise Irregular from None
    if values.shape[1] != len(names) or np.isinf(values).any():
        raise Irregular
    cols = {n: np.ascontiguousarray(values[:, k]) for k, n in enumerate(names)}
    t = cols["t"]
    if np.isnan(t).any() or (np.diff(t) <= 0).any():
        raise Irregular
    pos = [n for n in names if n.split("_")[0] in ("wrist", "elbow", "shoulder")
           and n.rsplit("_", 1)[-1] in ("x", "y", "z") and "_v" not in n]
    if any((np.abs(np.nan_to_num(cols[n])) > MAX_POSITION_M).any() for n in pos):
        raise Irregular
    return cols

