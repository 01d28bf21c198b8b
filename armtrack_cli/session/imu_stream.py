"""An IMU recording read a chunk at a time (issue 15): fuse keeps its usable samples on disk as
they come (pipeline/fuse_imu.SpilledImu), so that no reader holds the whole recording. The
formats that stream (xsens_stream.py: the MT Manager export; imu_csv_stream.py: the generic
CSV) give read_imu's values row for row and its errors word for word; a problem read_imu
finds once the whole table is parsed is remembered and raised after the last chunk, in
read_imu's order, so a row that does not parse, anywhere, is still the error reported first.
The other formats (Xsens DOT, MCAP) and a recording without orientation (estimated over the
whole recording) are read whole by read_imu and cut into chunks."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

import numpy as np

from armtrack_cli.core.errors import ImuFileError
from armtrack_cli.core.streams import ImuRows, ImuSamples
from armtrack_cli.session import imu as whole


class ImuStream:
    """A recording's samples as ImuRows chunks (every row, usable or not); ``rate_hz`` is
    known once the last chunk is read (a clock's rate is the median of all its steps)."""

    def __init__(self, path: str, orientation_source: str, chunks: Iterable[ImuRows],
                 rate_hz: float = float("nan")) -> None:
        self.path, self.orientation_source, self.rate_hz = path, orientation_source, rate_hz
        self.chunks = chunks  # set by a streaming reader once made (it sets rate_hz at its end)

    def __iter__(self) -> Iterator[ImuRows]:
        return iter(self.chunks)


def imu_chunks(path: str | Path, *, rate_hz: float | None = None, topic: str | None = None,
               field: str | None = None) -> ImuStream:
    """read_imu(path, ...) as a stream: a chunk at a time where its format allows."""
    from armtrack_cli.session import imu_csv_stream, xsens_stream

    path = whole.imu_file(path)
    kind, lines = whole.sniff_format(path)
    stream = xsens_stream.mt_manager_stream(path, lines, rate_hz) if kind == "mt" else \
        imu_csv_stream.csv_stream(path, lines) if kind == "csv" else None
    if stream is not None:
        return stream
    imu = whole.read_imu(path, rate_hz=rate_hz, topic=topic, field=field)
    return ImuStream(imu.path, imu.orientation_source, chunks_of(imu), imu.rate_hz)


def chunks_of(imu: ImuSamples, rows: int = 65_536) -> Iterator[ImuRows]:
    """A recording read whole, as ImuRows chunks: for a reader that cannot stream its format."""
    for a in range(0, imu.n, rows):
        sl = slice(a, a + rows)
        yield ImuRows(imu.t[sl], imu.quat[sl], imu.acc[sl], imu.gyr[sl])


class Deferred:
    """The first error of each of a reader's checks, run chunk by chunk, raised in the order
    the whole reader runs them."""

    def __init__(self) -> None:
        self.found: dict[str, ImuFileError] = {}

    def run(self, slot: str, check: Callable, *args):
        """check(*args), its error kept under ``slot`` (the first one only) instead of raised."""
        try:
            return check(*args)
        except ImuFileError as e:
            self.found.setdefault(slot, e)
            return None

    def raise_first(self, order: tuple[str, ...]) -> None:
        for slot in order:
            if slot in self.found:
                raise self.found[slot]


class ReadChecks:
    """read_imu's checks of what a reader returns (check_units, check_usable, the length),
    on a recording with accelerometer and orientation seen a chunk at a time."""

    def __init__(self, path: Path) -> None:
        self.path, self.g, self.n = path, -1.0, 0
        self.mags: list[np.ndarray] = []  # |f| of every finite row: the median needs them all
        self.acc_ok = self.quat_ok = False
        self.beyond = Deferred()
        self.t0 = self.t1 = np.nan

    def add(self, c: ImuRows) -> None:
        self.g = max(self.g, whole.gyro_max(c.gyr))
        self.mags.append(whole.acc_magnitudes(c.acc))
        self.acc_ok = self.acc_ok or bool(np.isfinite(c.acc).all(axis=1).any())
        self.quat_ok = self.quat_ok or bool(np.isfinite(c.quat).all(axis=1).any())
        for name, field, bound, unit in whole.BOUNDS:
            if name not in self.beyond.found:
                self.beyond.run(name, whole.beyond_bound, self.path, name, getattr(c, field),
                                c.t, bound, unit, self.n)
        if c.t.size:
            self.t0 = c.t[0] if not self.n else self.t0
            self.t1 = c.t[-1]
        self.n += c.t.size

    def check(self) -> None:
        """read_imu's errors after its reader's, in its order."""
        path = self.path
        whole.gyro_units(path, self.g)
        mags = np.concatenate(self.mags) if self.mags else np.empty(0)
        self.mags = []  # freed before the median partitions the copy in place
        if mags.size >= 10:
            whole.acc_units(path, float(np.median(mags, overwrite_input=True)))
        whole.no_usable(path, acc=not self.acc_ok, quat=not self.quat_ok)
        self.beyond.raise_first(tuple(b[0] for b in whole.BOUNDS))
        if self.n:
            whole.clock_span(path, self.t1 - self.t0)
        whole.too_short(path, self.n)
