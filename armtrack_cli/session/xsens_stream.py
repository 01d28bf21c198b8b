"""An Xsens MT Manager text export read a chunk at a time (issue 15): xsens.read_mt_manager's
values and checks, then read_imu's, with its table never held whole (60 minutes at 100 Hz:
360,000 rows). Each chunk of numeric_text's rows goes through xsens's own per-row conversions
(orientation, NED, FreeAcc) and its checks, run on the chunk's rows with the previous chunk's
last row before them (so a step across chunks is checked as in the whole file); their errors
are raised after the last chunk, in read_mt_manager's order (imu_stream.Deferred)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from armtrack_cli.core.counted_median import CountedMedian
from armtrack_cli.core.errors import ImuFileError
from armtrack_cli.core.streams import ImuRows
from armtrack_cli.session import xsens
from armtrack_cli.session.imu_stream import Deferred, ImuStream, ReadChecks
from armtrack_cli.session.numeric_text import Layout, file_chunks, line_chunks, row_blocks
from armtrack_cli.session.text_table import TextTable, named_groups, sniff_delimiter, table_header
from armtrack_cli.session.xsens import _orientation, _vec

STF_TICK_S = 1e-4  # MT Manager's SampleTimeFine (read_mt_manager's stf_tick_s)
ORDER = ("counter_whole", "counter_repeats", "counter_back", "stf_ticks", "stf_order",
         "stf_rate", "stf_partial", "no_rate", "quat")  # xsens._times, then _build
_ACC, _FREE, _GYR = (["Acc_X", "Acc_Y", "Acc_Z"], ["FreeAcc_X", "FreeAcc_Y", "FreeAcc_Z"],
                     ["Gyr_X", "Gyr_Y", "Gyr_Z"])


def mt_manager_stream(path: Path, lines: list[str], rate_hz: float | None) -> ImuStream | None:
    """The export's samples as a stream (its header read and checked now), or None when it
    has no orientation or no accelerometer: read_imu reads it whole (it estimates orientation
    over the whole recording, or refuses the file naming what it lacks)."""
    header_rate, coord, header_at = xsens.mt_head(path, lines)
    delim = sniff_delimiter(lines[header_at])
    raw = table_header(path, lines[header_at], header_at, delim, ImuFileError)
    idx = named_groups(*xsens.GROUPS, rename=xsens._column_name)(raw)
    names = [xsens._column_name(h) for h in raw]
    empty = _table(names, idx, np.empty(0, np.int64), tuple(np.empty((0, len(g))) for g in idx))
    if _orientation(path, empty) is None or not (empty.has(*_ACC) or empty.has(*_FREE)):
        return None
    stream = ImuStream(str(path), "file", ())
    chunks = line_chunks(lines, header_at + 1) if getattr(lines, "whole", True) else \
        file_chunks(path, header_at + 1)
    rows = row_blocks(chunks, Layout(len(raw), delim, tuple(raw)), path, ImuFileError,
                      groups=idx)
    stream.chunks = _samples(path, rows, names, idx, _Clock(path, header_rate, rate_hz), coord,
                              stream)
    return stream


def _table(names: list[str], idx, line_of: np.ndarray, groups) -> TextTable:
    return TextTable(names, None, line_of, (), dict(zip(idx, groups)))


def _samples(path: Path, blocks, names, idx, clock: _Clock, coord: str, stream: ImuStream):
    """Each chunk's samples as read_mt_manager returns them; its errors and read_imu's after
    the last."""
    late, checks = Deferred(), ReadChecks(path)
    for rows in blocks:
        if not rows.line_of.size:  # a chunk of comments, or a truncated last line dropped
            continue
        tab = _table(names, idx, rows.line_of, rows.groups)
        t = clock.add(tab, late)
        q = _orientation(path, tab)
        late.run("quat", xsens.unit_orientation, path, q, tab.line_of)
        q = xsens.to_zup(q, coord)
        acc = _vec(tab, _ACC)
        acc = acc if acc is not None else xsens.from_free(_vec(tab, _FREE), q)
        gyr = _vec(tab, _GYR)
        c = ImuRows(t, q, acc, gyr if gyr is not None else np.full_like(acc, np.nan))
        checks.add(c)
        yield c
    stream.rate_hz = clock.finish(late)
    late.raise_first(ORDER)
    checks.check()


class _Clock:
    """xsens._times a chunk at a time: SampleTimeFine unwrapped (or PacketCounter steps
    summed) on from the previous chunk's last row, its checks on each chunk's rows with that
    row before them, the clock's steps kept for its median rate."""

    def __init__(self, path: Path, header_rate: float | None, rate_hz: float | None) -> None:
        self.path, self.header_rate, self.rate_hz = path, header_rate, rate_hz
        self.n, self.last = 0, None  # last: the previous row's line, counter, stf, sum, t
        self.mode = None  # "stf" (every SampleTimeFine finite so far) or "counter"
        self.stf_seen, self.stf_any, self.first_nan = False, False, None
        self.steps = CountedMedian()  # the clock's steps, for its median

    def add(self, tab: TextTable, late: Deferred) -> np.ndarray:
        n, path, last = tab.n_rows, self.path, self.last
        line = tab.line_of if last is None else np.r_[last[0], tab.line_of]
        counter, steps = _vec(tab, ["PacketCounter"]), None
        if counter is not None:
            c = counter[:, 0] if last is None else np.r_[last[1], counter[:, 0]]
            late.run("counter_whole", xsens.counter_whole, path, line, c)
            steps = np.mod(np.diff(c), xsens.COUNTER_WRAP)
            late.run("counter_repeats", xsens.counter_repeats, path, line, c, steps)
            late.run("counter_back", xsens.counter_back, path, line, c, steps)
        stf = _vec(tab, ["SampleTimeFine"])
        s = stf[:, 0] if stf is not None else None
        if s is not None:
            self._finite(s, tab.line_of)
        if self.mode == "stf":
            s = s if last is None else np.r_[last[2], s]
            late.run("stf_ticks", xsens.stf_ticks, path, line, s)
            late.run("stf_order", xsens.stf_order, path, line, s)
            d = np.mod(np.diff(s), xsens.STF_WRAP)
            u = np.cumsum(np.r_[0.0 if last is None else last[3], d])  # xsens._unwrap on
            t = u * STF_TICK_S
            with np.errstate(divide="ignore", invalid="ignore"):  # a repeat: refused anyway
                self.steps.add(np.diff(t) / (steps if steps is not None else 1))
        else:
            u, t = self._counter_times(n, steps)
        if last is not None:
            u, t = u[1:], t[1:]
        self.last = (tab.line_of[-1], counter[-1, 0] if counter is not None else None,
                     stf[-1, 0] if stf is not None else None, u[-1], t[-1])
        self.n += n
        return t

    def _finite(self, s: np.ndarray, line_of: np.ndarray) -> None:
        """SampleTimeFine's rows seen: all finite so far (the stf clock) or not."""
        ok = np.isfinite(s)
        self.stf_any = self.stf_any or bool(ok.any())
        if not ok.all() and self.first_nan is None:
            self.first_nan = int(line_of[int(np.flatnonzero(~ok)[0])])
        if self.mode is None:
            self.mode = "stf" if ok.all() else "counter"
        elif self.mode == "stf" and not ok.all():
            self.mode = "broken"  # missing in some rows but not all: refused after the last

    def _counter_times(self, n: int, steps: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """(the steps summed, t) of the chunk (the previous row first) without SampleTimeFine."""
        rate = self.header_rate or self.rate_hz
        first = self.last is None
        if steps is None:
            u = np.arange(self.n - (not first), self.n + n)
        else:
            u = np.cumsum(np.r_[0.0 if first else self.last[3], steps])
        if rate is None or self.mode == "broken":
            return u, np.full(u.shape, np.nan)
        return u, u / rate

    def finish(self, late: Deferred) -> float:
        """The clock's rate, and its errors that need every row."""
        if self.mode == "stf":
            if not self.steps.size:  # one sample: refused as too short
                return float(self.header_rate or self.rate_hz or np.nan)
            return late.run("stf_rate", xsens.stf_rate, self.path, self.header_rate,
                            self.steps.median())
        late.found.pop("stf_ticks", None)  # not checked where some SampleTimeFine is missing
        late.found.pop("stf_order", None)
        if self.stf_any:
            late.found.setdefault("stf_partial", xsens.stf_partial(self.path, self.first_nan))
            return np.nan
        rate = self.header_rate or self.rate_hz
        if rate is None:
            late.found.setdefault("no_rate", xsens.no_rate(self.path))
            return np.nan
        return rate
