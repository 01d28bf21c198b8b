"""Delimited text tables as labs export them: comment headers, any delimiter, NaN cells.

Shared by the Xsens, generic CSV, Qualisys and Vicon readers. Cells that are empty or NaN
become NaN (missing); any other non-numeric cell is an error naming its line and column
(session/numeric_text.py reads the rows).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from armtrack_cli.core.errors import DataError
from armtrack_cli.core.limits import MAX_TEXT_BYTES
from armtrack_cli.session.files import regular_file
from armtrack_cli.session.numeric_text import (  # noqa: F401  (split_row: for the readers)
    Layout,
    file_rows,
    line_rows,
    split_row,
)

Groups = Callable[[list[str]], tuple[tuple[int, ...], ...]]  # header -> the column groups


@dataclass(frozen=True)
class TextTable:
    """header: column names; data: (N, C) float64 with NaN; line_of: (N,) 1-based file lines.
    Read in groups (parse_table's ``groups``): data is None and ``groups`` maps each group's
    column indices to its own (N, k) array, all that was kept of the rows."""

    header: list[str]
    data: np.ndarray | None
    line_of: np.ndarray
    notes: tuple[str, ...] = ()
    groups: dict[tuple[int, ...], np.ndarray] = field(default_factory=dict)

    @property
    def n_rows(self) -> int:
        return int(self.line_of.size)

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
        """(N, len(names)) array of the named columns: a group read as such itself (no copy:
        the reader's to keep or change), else a copy of the table's columns."""
        return self.block(tuple(self.index(n) for n in names))

    def block(self, idx: tuple[int, ...]) -> np.ndarray:
        """(N, len(idx)) array of the columns idx: columns() by index."""
        if idx in self.groups:
            return self.groups[idx]
        if self.data is None:
            raise KeyError(f"columns {idx} were not read (not one of the table's groups)")
        return self.data[:, list(idx)]


def named_groups(*groups: tuple[str, ...], rename: Callable[[str], str] = str) -> Groups:
    """parse_table's ``groups`` for column names: each group whose names the header (each
    name through ``rename``) holds, case-insensitively (the first such column, as
    TextTable.index finds it)."""
    def pick(header: list[str]) -> tuple[tuple[int, ...], ...]:
        tab = TextTable([rename(h) for h in header], None, np.empty(0))
        found = [tuple(tab.index(n) for n in g) for g in groups if tab.has(*g)]
        return tuple(dict.fromkeys(found))  # a group named twice is read once

    return pick


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


def header_line(lines: list[str], comment: str = "#") -> int | None:
    """The index of the first line that is neither blank nor a ``comment`` line (a table's
    header), or None."""
    return next((i for i, ln in enumerate(lines) if ln.strip() and not ln.startswith(comment)),
                None)


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


def parse_table(path: Path, lines: list[str], header_at: int, delimiter: str | None,
                error: type[DataError], *, skip_prefixes: tuple[str, ...] = (),
                groups: Groups | None = None) -> TextTable:
    """Parse lines[header_at] as the header and the non-blank lines after it as data (not
    those starting with one of ``skip_prefixes``), by session/numeric_text: from ``lines``
    when they are the whole file's, else (a long file's head, session/text_head.py) streamed
    from the file itself. Trailing empty fields (a trailing delimiter) are ignored; a last
    line with too few fields is a truncated write and is dropped with a note; any other
    ragged row, or a cell that is not a number, is an error naming its line (and column).
    With ``groups`` (the header -> tuples of column indices), only those columns are kept,
    each group in its own array (TextTable.groups)."""
    return parse_rows(path, lines, header_at + 1, table_header(path, lines[header_at], header_at,
                                                               delimiter, error),
                      delimiter, error, skip_prefixes=skip_prefixes, groups=groups)


def table_header(path: Path, line: str, header_at: int, delimiter: str | None,
                 error: type[DataError]) -> list[str]:
    """parse_table's column names of the header ``line`` (lines[header_at])."""
    header = [h[1:-1] if len(h) > 1 and h[0] == h[-1] == '"' else h  # R's write.csv quotes
              for h in split_row(line, delimiter)]
    while header and header[-1] == "":
        header.pop()
    if not header:
        raise error(path, f"line {header_at + 1}: the column header is empty")
    return header


def parse_rows(path: Path, lines: list[str], first_line: int, header: list[str],
               delimiter: str | None, error: type[DataError], *,
               skip_prefixes: tuple[str, ...] = (), groups: Groups | None = None) -> TextTable:
    """The rows from lines[first_line] on (0-based) under the column names ``header``."""
    layout = Layout(len(header), delimiter, tuple(header), tuple(skip_prefixes))
    idx = groups(list(header)) if groups is not None else None
    if getattr(lines, "whole", True):
        rows = line_rows(path, lines, first_line, layout, error, groups=idx)
    else:
        rows = file_rows(path, first_line, layout, error, groups=idx)
    return TextTable(list(header), rows.data, rows.line_of, rows.notes,
                     dict(zip(idx or (), rows.groups)))
