"""The one reader of a delimited numeric table's body (issue 15): streamed in chunks of whole
lines, from the file (file_rows) or from lines already in memory (line_rows), so that a long
export is never held as text (a 60-minute Qualisys export held as lines took ~150 MB; this
holds its numbers and a chunk or two). Each chunk is read at C speed by numpy's loadtxt when it is
plain numbers (nan/inf spelt out, or an empty cell: NaN); anything else (an NA spelling, a
blank or comment line, a trailing delimiter, a ragged or truncated row, text) is read row by
row, which takes NA spellings as missing, drops a truncated last line with a note and names
the line and column of a cell that is not a number. Used by text_table.parse_table (IMU,
Qualisys, Vicon, video time stamps) and plain_tables (armtrack's own trajectory CSVs)."""

from __future__ import annotations

import io
import mmap
import re
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from armtrack_cli.core.errors import DataError

CHUNK_BYTES = 1 << 20  # 1 MB of text a chunk (~10,000 rows of an IMU export): its bytes,
#                        their copies and loadtxt's rows held at once (4 MB held ~20 MB more
#                        at the peak, no faster: 1.1 s for a 60-minute IMU or Qualisys export)
CHUNK_LINES = 10_000  # the same for lines already in memory
RESERVE_BYTES = 1 << 30  # _reserve's pages past the rows read are never touched nor resident
MISSING_TOKENS = frozenset({"", "nan", "na", "n/a", "null", "-nan"})
FAST_DELIMITERS = ("\t", ",", ";", None)  # what loadtxt splits as the row-by-row parse does
SEPARATOR = {"\t": "tab", ",": "comma", ";": "semicolon", " ": "space", None: "space"}
_EMPTY = {d: re.compile(rf"(?<![^{re.escape(d)}\n])(?={re.escape(d)}|\n|\Z)".encode())
          for d in FAST_DELIMITERS if d}  # where a cell has nothing in it


class Irregular(Exception):
    """A chunk is not plain numbers, and the caller reads plain numbers only."""


@dataclass(frozen=True)
class Rows:
    """data (N, n) float64, NaN = missing; line_of (N,) the 1-based file line of each row.
    Read in ``groups`` (read_rows): data is None and groups[i] (N, len(groups[i])) holds
    those columns, each group its own contiguous array."""

    data: np.ndarray | None
    line_of: np.ndarray
    notes: tuple[str, ...] = ()
    groups: tuple[np.ndarray, ...] = ()


@dataclass(frozen=True)
class Layout:
    """How the rows are written: n fields split by ``delimiter`` (None: runs of blanks; " ":
    single spaces), named ``header``; lines starting with one of ``skip`` are not rows."""

    n: int
    delimiter: str | None
    header: tuple[str, ...]
    skip: tuple[str, ...] = ()


def file_rows(path: Path, first_line: int, layout: Layout, error: type[DataError], *,
              by_row: bool = True, groups: tuple[tuple[int, ...], ...] | None = None) -> Rows:
    """The rows from line ``first_line`` (0-based) of the file to its end, streamed."""
    most = Path(path).stat().st_size // max(layout.n, 2) + 1  # a row takes n bytes at least
    if most * (layout.n + 1) * 8 > RESERVE_BYTES:  # beyond any session: the rows counted
        with open(path, "rb") as f:
            blocks = iter(lambda: f.read(CHUNK_BYTES), b"")
            most = sum(b.count(b"\n") + b.count(b"\r") for b in blocks) + 1
    return read_rows(_file_chunks(path, first_line), most, layout, path, error, by_row=by_row,
                     groups=groups)


def line_rows(path: Path, lines: list[str], first_line: int, layout: Layout,
              error: type[DataError], *, by_row: bool = True,
              groups: tuple[tuple[int, ...], ...] | None = None) -> Rows:
    """The rows from lines[first_line:] (a file's lines, 0-based), in chunks of CHUNK_LINES."""
    chunks = ((("\n".join(lines[k:k + CHUNK_LINES]) + "\n").encode(), k + 1,
               len(lines[k:k + CHUNK_LINES])) for k in range(first_line, len(lines), CHUNK_LINES))
    return read_rows(chunks, max(len(lines) - first_line, 0), layout, path, error,
                     by_row=by_row, groups=groups)


def _file_chunks(path: Path, first_line: int) -> Iterator[tuple[bytes, int, int]]:
    """(bytes of whole lines, 1-based line number of its first, lines) from line ``first_line`` on;
    a line break is "\\n", "\\r\\n" or "\\r" (as str.splitlines counts them)."""
    with open(path, "rb") as f:
        for _ in range(first_line):
            f.readline()
        line, carry = first_line + 1, b""
        for block in iter(lambda: f.read(CHUNK_BYTES), b""):
            block = carry + block
            cut = block.rfind(b"\n") + 1
            if cut:
                chunk, carry = _breaks(block[:cut], at_start=line == 1), block[cut:]
                lines = chunk.count(b"\n")
                yield chunk, line, lines
                line += lines
            else:
                carry = block
        if carry:
            chunk = _breaks(carry, at_start=line == 1)
            yield chunk, line, chunk.count(b"\n") + (not chunk.endswith(b"\n"))


def _breaks(raw: bytes, *, at_start: bool) -> bytes:
    """Line breaks as "\\n", a UTF-8 byte-order mark at the file's start dropped."""
    if at_start and raw.startswith(b"\xef\xbb\xbf"):
        raw = raw[3:]
    return raw.replace(b"\r\n", b"\n").replace(b"\r", b"\n") if b"\r" in raw else raw


def _decode(raw: bytes) -> str:
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        return raw.decode("latin-1")  # as text_table.decode_text: older Windows exports


def read_rows(chunks: Iterable[tuple[bytes, int, int]], most: int, layout: Layout, path: Path,
              error: type[DataError], *, by_row: bool = True,
              groups: tuple[tuple[int, ...], ...] | None = None) -> Rows:
    """Every row of ``chunks`` ((text, 1-based line of its first line, lines), at most ``most``
    rows in all), into one array filled in place; with ``groups`` (tuples of column indices),
    into one array per group and no other column kept: what a reader keeps is all that is
    held, no table beside it (issue 15). ``by_row=False``: a chunk that is not plain numbers
    raises Irregular instead of being read row by row."""
    parts = [_reserve((most, len(g))) for g in groups] if groups is not None else None
    data = _reserve((most, layout.n)) if parts is None else None
    line_of = _reserve((most,), np.int64)
    notes: list[str] = []
    k = 0
    for (text, first, lines), last in _marked_last(chunks):
        got = _plain(text, lines, layout)
        if got is None:
            if not by_row:
                raise Irregular
            got, at, note = _by_row(text, first, layout, path, error, last=last, after=k)
            notes += note
        else:
            at = np.arange(first, first + len(got))
        if parts is None:
            data[k:k + len(got)] = got
        else:
            for part, g in zip(parts, groups):
                np.take(got, g, axis=1, out=part[k:k + len(got)], mode="clip")  # unbuffered
        line_of[k:k + len(got)] = at
        k += len(got)
    if not k:
        if not by_row:
            raise Irregular
        raise error(path, "has a column header but no data rows (truncated?)")
    return Rows(None if data is None else data[:k], line_of[:k], tuple(notes),
                tuple(p[:k] for p in parts or ()))


def row_blocks(chunks: Iterable[tuple[bytes, int, int]], layout: Layout, path: Path,
               error: type[DataError], *, by_row: bool = True,
               groups: tuple[tuple[int, ...], ...] = ()) -> Iterator[Rows]:
    """read_rows a chunk at a time: each chunk's rows (Rows with ``groups``, each group its own
    array, and the chunk's notes) as soon as it is parsed, for a reader that keeps no table
    (compare's spilled truth, issue 15); the same rows, line numbers, notes and errors."""
    k = 0
    for (text, first, lines), last in _marked_last(chunks):
        got, notes = _plain(text, lines, layout), []
        if got is None:
            if not by_row:
                raise Irregular
            got, at, notes = _by_row(text, first, layout, path, error, last=last, after=k)
        else:
            at = np.arange(first, first + len(got))
        k += len(got)
        yield Rows(None, at, tuple(notes), tuple(np.ascontiguousarray(got[:, list(g)])
                                                 for g in groups))
    if not k:
        if not by_row:
            raise Irregular
        raise error(path, "has a column header but no data rows (truncated?)")


def file_chunks(path: Path, first_line: int) -> Iterator[tuple[bytes, int, int]]:
    """The file's text from line ``first_line`` (0-based) on, in chunks of whole lines."""
    return _file_chunks(path, first_line)


def line_chunks(lines: list[str], first_line: int) -> Iterator[tuple[bytes, int, int]]:
    """lines[first_line:] in chunks of CHUNK_LINES, as line_rows reads them."""
    return ((("\n".join(lines[k:k + CHUNK_LINES]) + "\n").encode(), k + 1,
             len(lines[k:k + CHUNK_LINES])) for k in range(first_line, len(lines), CHUNK_LINES))


def _reserve(shape: tuple[int, ...], dtype=np.float64) -> np.ndarray:
    """An array of ``shape`` on a private anonymous mapping of its own (RssAnon, as np.empty's
    pages are): only the pages written become resident, as with np.empty, but without numpy's
    transparent-huge-page advice for arrays of 4 MB or more, under which each array's last
    written page faulted in a whole 2 MB (a reader's six arrays: up to 12 MB more than they
    hold; a 10-minute IMU read peaked 37 MB, 30 without). Freed with its last view."""
    size = int(np.prod(shape))
    buf = mmap.mmap(-1, max(size * np.dtype(dtype).itemsize, 1), flags=mmap.MAP_PRIVATE)
    return np.frombuffer(buf, dtype=dtype, count=size).reshape(shape)


def _marked_last(chunks: Iterable[tuple[bytes, int, int]]
                 ) -> Iterator[tuple[tuple[bytes, int, int], bool]]:
    """Each chunk that holds more than blank lines, and whether it is the last such."""
    held = None
    for chunk in chunks:
        if chunk[0] and not chunk[0].isspace():
            if held is not None:
                yield held, False
            held = chunk
    if held is not None:
        yield held, True


def _plain(text: bytes, lines: int, layout: Layout) -> np.ndarray | None:
    """The chunk's rows (one a line, every line of its ``lines`` a row) by loadtxt, or None."""
    d = layout.delimiter
    if d not in FAST_DELIMITERS or any(text.startswith(p.encode()) or b"\n" + p.encode() in text
                                       for p in layout.skip):
        return None
    body = text
    if text.endswith(b"\n\n"):  # blank lines at the end: no rows
        body = text.rstrip(b"\n")
        lines = body.count(b"\n") + 1
    try:
        data = _loadtxt(body, d)
    except ValueError:  # an empty cell (NaN) or anything else (row by row)
        if d is None or b"\n\n" in body or body.startswith(b"\n"):
            return None
        try:
            data = _loadtxt(_EMPTY[d].sub(b"nan", body.rstrip(b"\n")), d)
        except ValueError:
            return None
    return data if data.shape == (lines, layout.n) else None  # else a blank line: row by row


def _loadtxt(text: bytes, delimiter: str | None) -> np.ndarray:
    return np.loadtxt(io.BytesIO(text), delimiter=delimiter, dtype=float, ndmin=2,
                      comments=None)


def split_row(line: str, delimiter: str | None) -> list[str]:
    """Fields of one row. " " splits field by field (two spaces = an empty field between)."""
    if delimiter is None:
        return line.split()
    if delimiter == " ":
        return line.strip("\r\n").split(" ")
    return [c.strip() for c in line.split(delimiter)]


def _fields(line: str, delimiter: str | None, n: int) -> list[str]:
    """Fields of a data row, trailing empty ones beyond n dropped; a single-space row whose
    fields are aligned with runs of spaces (and so does not split into n field by field)
    falls back to runs of spaces."""
    cells = split_row(line, delimiter)
    while len(cells) > n and cells[-1] == "":
        cells.pop()
    if delimiter == " " and len(cells) != n and len(line.split()) == n:
        return line.split()
    return cells


def _number(cell: str) -> float | None:
    """A cell's value (NaN for a missing-value spelling), or None when it is not a number."""
    if cell.lower() in MISSING_TOKENS:
        return float("nan")
    if not cell.isascii() or "_" in cell:
        return None
    try:
        v = float(cell)
    except ValueError:
        return None
    return v if v == v else None  # a NaN spelt another way ("+nan"): not a missing value


def _by_row(text: bytes, first: int, layout: Layout, path: Path, error: type[DataError], *,
            last: bool, after: int) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """A chunk row by row: blank lines and lines starting with layout.skip are no rows; a last
    line (``last`` chunk) with too few fields, after other rows, is dropped with a note."""
    n, notes = layout.n, []
    body = [(i, ln) for i, ln in enumerate(_decode(text).split("\n"), start=first)
            if ln.strip() and not ln.startswith(layout.skip)]
    values: list[float] = []
    lines: list[int] = []
    for k, (i, ln) in enumerate(body):
        cells = _fields(ln, layout.delimiter, n)
        if len(cells) != n:
            if last and k == len(body) - 1 and len(cells) < n and (lines or after):
                notes.append(f"last line {i} has {len(cells)} of {n} fields (truncated write): "
                             "dropped")
                break
            raise error(path, f"line {i} has {len(cells)} fields but the header has {n} "
                        f"({SEPARATOR[layout.delimiter]}-separated)",
                        "is the file cut short or mixing delimiters?")
        row = [_number(c) for c in cells]
        if None in row:
            c = row.index(None)
            raise error(path, f"line {i}, column {layout.header[c]!r}: {cells[c]!r} is not a "
                        "number")
        values += row
        lines.append(i)
    return np.array(values, dtype=float).reshape(-1, n), np.array(lines, dtype=np.int64), notes
