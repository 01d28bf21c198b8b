"""The generic IMU CSV read a chunk at a time (issue 15): imu_csv.read_generic_csv's values and
checks, then read_imu's, its table never held whole. Each chunk's checks run on its rows with
the previous chunk's last row before them; their errors are raised after the last chunk, in
read_generic_csv's order (imu_stream.Deferred)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from armtrack_cli.core.errors import ImuFileError
from armtrack_cli.core.streams import ImuRows
from armtrack_cli.session import imu_csv
from armtrack_cli.session.imu_checks import nominal_step
from armtrack_cli.session.imu_stream import Deferred, ImuStream, ReadChecks
from armtrack_cli.session.numeric_text import Layout, file_chunks, line_chunks, row_blocks
from armtrack_cli.session.text_table import TextTable, named_groups, table_header

ORDER = ("missing", "repeat", "back", "quat")  # imu_csv.check_times, then unit_q
_Q = ("qw", "qx", "qy", "qz")


def csv_stream(path: Path, lines: list[str]) -> ImuStream | None:
    """The CSV's samples as a stream (its header read and checked now), or None when it lacks
    a column it needs or has no quaternion: read_imu reads it whole (and refuses it, or
    estimates its orientation over the whole recording)."""
    header_at, delim = imu_csv.csv_head(path, lines)
    header = table_header(path, lines[header_at], header_at, delim, ImuFileError)
    idx = named_groups(*imu_csv.GROUPS)(header)
    if imu_csv.missing_columns(header) or not TextTable(header, None, np.empty(0)).has(*_Q):
        return None
    stream = ImuStream(str(path), "file", ())
    chunks = line_chunks(lines, header_at + 1) if getattr(lines, "whole", True) else \
        file_chunks(path, header_at + 1)
    rows = row_blocks(chunks, Layout(len(header), delim, tuple(header), imu_csv.SKIP), path,
                      ImuFileError, groups=idx)
    stream.chunks = _samples(path, rows, header, idx, stream)
    return stream


def _samples(path: Path, blocks, header: list[str], idx, stream: ImuStream):
    """Each chunk's samples as read_generic_csv returns them; its errors and read_imu's after
    the last."""
    late, checks = Deferred(), ReadChecks(path)
    t0, last, missing, steps = None, None, [None, 0], []
    for rows in blocks:
        if not rows.line_of.size:  # a chunk of comments, or a truncated last line dropped
            continue
        tab = TextTable(header, None, rows.line_of, (), dict(zip(idx, rows.groups)))
        t = tab.columns("t")[:, 0]
        nan = ~np.isfinite(t)
        if nan.any():  # the first row's line and the count, for one message
            missing[0] = missing[0] or int(tab.line_of[np.flatnonzero(nan)[0]])
            missing[1] += int(nan.sum())
        tt, line = (t, tab.line_of) if last is None else \
            (np.r_[last[0], t], np.r_[last[1], tab.line_of])
        d = np.diff(tt)
        late.run("repeat", imu_csv.times_repeat, path, tt, line, d)
        late.run("back", imu_csv.times_back, path, tt, line, d)
        t0 = t[0] if t0 is None else t0
        t_rel = t - t0
        steps.append(np.diff(t_rel if last is None else np.r_[last[2], t_rel]))
        last = (t[-1], tab.line_of[-1], t_rel[-1])
        q = tab.columns(*_Q)
        late.run("quat", imu_csv.unit_q, path, q, tab.line_of)
        c = ImuRows(t_rel, q, tab.columns("ax", "ay", "az"), tab.columns("gx", "gy", "gz"))
        checks.add(c)
        yield c
    if missing[1]:
        late.run("missing", imu_csv.times_missing, path, missing[0], missing[1])
    stream.rate_hz = 1.0 / nominal_step(np.concatenate(steps) if steps else np.empty(0))
    late.raise_first(ORDER)
    checks.check()
