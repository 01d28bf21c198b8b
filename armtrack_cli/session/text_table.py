"""Delimited text tables as labs export them: comment headers, any delimiter, NaN cells.

Shared by the Xsens, generic CSV and Qualisys readers. Cells that are empty or NaN become
NaN (missing); any other non-numeric cell is an error naming its line and column.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from armtrack_cli.core.errors import DataError
from armtrack_cli.core.limits import MAX_TEXT_BYTES
from armtrack_cli.session.files import regular_file
from armtrack_cli.session.text_head import numbers_after

MISSING_TOKENS = {"", "nan", "na", "n/a", "null", "-nan"}


@dataclass(frozen=True)
class TextTable:
    """header: column names; data: (N, C) float64 with NaN; line_of: (N,) 1-based file lines."""

    header: list[str]
    data: np.ndarray
    line_of: np.ndarray
    notes: tuple[str, ...] = ()

    def index(self, name: str) -> int | None:
        """Column index by case-insensitive name, or None."""
        low = name.lower()
        for i, h in enumerate(self.header):
            if h.lower() == low:
                return i
        return None

    def has(self, *names: str) -> bool:
        return all(self.index(n) is not None for n in names)

    def columns(self, *names: str) -> np.ndarray:
        """(N, len(names)) array of the named columns."""
        return self.data[:, [self.index(n) for n in names]]


def read_text_lines(path: Path, error: type[DataError], what: str) -> list[str]:
    """Decode a text export (UTF-8 with or without BOM, else Latin-1) into lines.

    Binary files (NUL bytes) and empty files are refused with ``error``.
    """
    raw = regular_file(path, error, what, max_bytes=MAX_TEXT_BYTES).read_bytes()
    return decode_text(path, raw, error, what).splitlines()


def decode_text(path: Path, raw: bytes, error: type[DataError], what: str) -> str:
    """read_text_lines' checks and decoding of a file's bytes (or its head's)."""
    if not raw.strip():
        raise error(path, f"is empty, expected {what}")
    if b"\x00" in raw[:65536]:
        raise error(path, f"is a binary file, not {what}")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")  # older Windows exports (degree signs in cp1252)
    if sum(not (c.isprintable() or c in "\r\n\t") for c in text[:4096]) > 20:
        raise error(path, f"is not a text file, expected {what}")
    return text


def sniff_delimiter(header: str) -> str | None:
    """Tab, semicolon or comma by count in the header; else " " when the header's names are
    separated by single spaces (MT Manager 2022's space export, whose empty fields are
    consecutive single spaces), None for runs of spaces (aligned columns)."""
    counts = {d: header.count(d) for d in ("\t", ";", ",")}
    best = max(counts, key=counts.get)
    if counts[best] > 0:
        return best
    names = header.strip().split(" ")
    return " " if len(names) > 1 and "" not in names else None


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
