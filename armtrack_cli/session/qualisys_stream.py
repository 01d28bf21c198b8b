"""A QTM 3D TSV export read a chunk at a time (issue 15): session/qualisys.read_qualisys's
values, checks and messages, without its table (60 minutes at 100 Hz: 360,200 rows × every
marker) ever held whole. Each chunk of numeric_text's rows comes out as (t, xyz) as soon as
it is parsed; a problem read_qualisys finds after parsing the whole table (a coordinate beyond
any capture volume, a damaged clock) is remembered at its first line and raised, in
read_qualisys's order, once the last chunk is parsed (so a row that does not parse, anywhere,
is still the error reported first, as there)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np

from armtrack_cli.core.counted_median import CountedMedian
from armtrack_cli.core.errors import GroundTruthError
from armtrack_cli.core.limits import MAX_SESSION_S
from armtrack_cli.session.numeric_text import Layout, file_chunks, line_chunks, row_blocks
from armtrack_cli.session.qualisys import MAX_MARKER_MM, MM, _layout, _names_row, qualisys_head
from armtrack_cli.session.text_table import split_row


class _Clock:
    """read_qualisys's checks of the frame times, a chunk at a time: the first empty cell,
    the first step back, the median step (exact, from the steps' counts: a capture's steps
    take a handful of values), the span."""

    def __init__(self, path: Path, freq: float):
        self.path, self.freq = path, freq
        self.empty = self.back = None
        self.steps = CountedMedian()
        self.first = self.last = None

    def add(self, t: np.ndarray, line_of: np.ndarray) -> None:
        if self.empty is None and not np.isfinite(t).all():
            r = int(np.flatnonzero(~np.isfinite(t))[0])
            self.empty = f"line {line_of[r]}: the time/frame cell is empty"
        prev = t if self.last is None else np.r_[self.last, t]
        d = np.diff(prev)
        if self.back is None and (d <= 0).any():
            r = int(np.flatnonzero(d <= 0)[0])
            self.back = (f"line {line_of[r + len(t) - len(prev) + 1]}: time goes from "
                         f"{prev[r]:g} to {prev[r + 1]:g} s")
        self.steps.add(d)
        self.first = t[0] if self.first is None else self.first
        self.last = t[-1]

    def median_step(self) -> float:
        return self.steps.median() if self.steps.size else 1.0 / self.freq

    def check(self) -> None:
        """read_qualisys's _times errors, in its order."""
        path, freq = self.path, self.freq
        if self.empty:
            raise GroundTruthError(path, self.empty)
        if self.back:
            raise GroundTruthError(path, self.back, "frames must be in increasing time order")
        step = self.median_step()
        if abs(step * freq - 1.0) > 0.05:
            raise GroundTruthError(path, f"its Time column steps by {step:g} per frame, but "
                                   f"FREQUENCY {freq:g} Hz means {1 / freq:g} s (is the time in "
                                   "ms?)", "export Time in seconds, as QTM does")
        if self.last - self.first > MAX_SESSION_S:
            raise GroundTruthError(path, f"spans {(self.last - self.first) / 3600:.0f} h: its "
                                   "time is damaged")


def _table_header(path: Path, lines: list[str], at: int) -> tuple[list[str], int, bool]:
    """The table's column names, its first data line (0-based) and whether it names them."""
    if not _names_row(lines[at]):
        return [f"c{k}" for k in range(len(lines[at].rstrip("\t\r\n").split("\t")))], at, False
    header = [h[1:-1] if len(h) > 1 and h[0] == h[-1] == '"' else h
              for h in split_row(lines[at], "\t")]  # text_table.parse_table's header
    while header and header[-1] == "":
        header.pop()
    if not header:
        raise GroundTruthError(path, f"line {at + 1}: the column header is empty")
    return header, at + 1, True


def qualisys_chunks(path: str | Path) -> tuple[tuple[str, ...], float, Iterator]:
    """(marker names, frame rate, chunks): the header read and checked now, then each chunk
    as (t (n,) s from the file's clock, xyz (n, M, 3) m, NaN in gaps): read_qualisys's
    MarkerTrajectories t and xyz, row for row."""
    path = Path(path)
    lines, keys, at, names, freq = qualisys_head(path)
    return names, freq, _chunks(path, lines, at, len(names), freq)


def _chunks(path: Path, lines: list[str], at: int, m: int, freq: float) -> Iterator:
    header, first_line, has_row = _table_header(path, lines, at)
    frame_col, time_col, first = _layout(header, has_row, m)
    bad = (first not in (0, 1, 2)) if not has_row else (len(header) - first != 3 * m)
    groups = tuple((c,) for c in (frame_col, time_col) if c is not None) + (
        tuple(range(max(first, 0), len(header))),)
    chunks = line_chunks(lines, first_line) if getattr(lines, "whole", True) else \
        file_chunks(path, first_line)
    clock, far, k = _Clock(path, freq), None, 0
    for rows in row_blocks(chunks, Layout(len(header), "\t", tuple(header)), path,
                           GroundTruthError, groups=groups):
        n, coords = rows.line_of.size, rows.groups[-1]
        k += n
        if bad or far:
            continue  # the rest parsed for its errors, as read_qualisys parses it all first
        hit = (coords > MAX_MARKER_MM) | (coords < -MAX_MARKER_MM)
        if hit.any():
            r, c = np.argwhere(hit)[0]
            far = (f"line {rows.line_of[r]}: marker {{}} has {'XYZ'[c % 3]} = {coords[r, c]:g} "
                   "mm, beyond any capture volume", c // 3)
            continue
        t = rows.groups[groups.index((time_col,))][:, 0] if time_col is not None else \
            (rows.groups[0][:, 0] - 1) / freq if frame_col is not None else \
            np.arange(k - n, k) / freq
        clock.add(t, rows.line_of)
        coords *= MM
        xyz = coords.reshape(-1, m, 3)
        xyz[np.all(xyz == 0.0, axis=2)] = np.nan  # QTM writes gaps as zeros in some versions
        xyz[np.any(np.isnan(xyz), axis=2)] = np.nan
        yield np.array(t, dtype=float), xyz
    _raise_after(path, header, at, m, has_row, bad, far, clock)


def _raise_after(path: Path, header: list[str], at: int, m: int, has_row: bool, bad: bool,
                 far, clock: _Clock) -> None:
    """What read_qualisys raises once its table is parsed, in its order."""
    if bad:
        first = _layout(header, has_row, m)[2]
        raise GroundTruthError(path, f"line {at + 1} has {len(header)} columns, which does not "
                               f"fit {m} markers (MARKER_NAMES) x 3 coordinates"
                               + (f" after {first} frame/time columns" if has_row else ""),
                               "is MARKER_NAMES complete?")
    if far:
        names = qualisys_head(path)[3]
        raise GroundTruthError(path, far[0].format(names[far[1]]),
                               "the row is damaged: empty its cells (a gap)")
    clock.check()
