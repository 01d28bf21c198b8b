"""A long text export read without holding its lines: the head (where the format and the
column header are told) as lines; text_table.parse_table then streams the numeric body from
the file itself (session/numeric_text.py). A 60-minute IMU export (360,000 rows, 39 MB) held
as Python lines took ~95 MB while read; this holds the numbers only (issue 15)."""

from __future__ import annotations

from pathlib import Path

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
