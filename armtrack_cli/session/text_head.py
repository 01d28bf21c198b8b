"""A long text export read without holding its lines: the head (where the format and the
column header are told) as lines, the numeric body straight from the file by numpy's C
reader. A 60-minute IMU export (360,000 rows, 39 MB) held as Python lines took ~95 MB while
read; this holds the numbers only (issue 15). Anything the C reader does not take as it
stands (a blank, empty or text cell, a ragged or truncated row) goes to the row-by-row parse
of text_table.parse_table, over every line, which reads it or names the line and column."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from armtrack_cli.core.errors import DataError
from armtrack_cli.core.limits import MAX_TEXT_BYTES
from armtrack_cli.session.files import regular_file

HEAD_BYTES = 1 << 20  # files up to this size are read whole, as lines


class TextHead(list):
    """The first whole lines of a text file (a list of str); ``whole``: no more follow."""

    whole = True


def read_text_head(path: Path, error: type[DataError], what: str) -> list[str]:
    """The file's lines (text_table.read_text_lines) when it is at most HEAD_BYTES long, else
    the whole lines of its first HEAD_BYTES, checked and decoded as read_text_lines does,
    as a TextHead with ``whole`` False."""
    from armtrack_cli.session.text_table import decode_text, read_text_lines

    regular_file(path, error, what, max_bytes=MAX_TEXT_BYTES)
    with open(path, "rb") as f:
        raw = f.read(HEAD_BYTES + 1)
    cut = raw.rfind(b"\n", 0, HEAD_BYTES)
    if len(raw) <= HEAD_BYTES or cut < 0:
        return read_text_lines(path, error, what)
    head = TextHead(decode_text(path, raw[:cut + 1], error, what).splitlines())
    head.whole = False
    return head


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
