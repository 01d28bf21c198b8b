"""The IMU's usable samples (finite accelerometer and orientation) for a windowed fuse, read
by time span on the IMU's own clock, so that each window takes its own rows (issue 15)."""

from __future__ import annotations

import numpy as np

from armtrack_cli.core.streams import ImuRows
from armtrack_cli.session.imu_stream import chunks_of  # noqa: F401  (for the tests)


class ArrayImu:
    """The recording read whole (session/imu.read_imu's ImuSamples), its usable rows by span."""

    def __init__(self, imu) -> None:
        ok = np.isfinite(imu.acc).all(axis=1) & np.isfinite(imu.quat).all(axis=1)
        ok = slice(None) if ok.all() else ok  # every sample usable: views, not copies
        self._rows = ImuRows(imu.t[ok], imu.quat[ok], imu.acc[ok], imu.gyr[ok])
        self.rate_hz = float(imu.rate_hz)
        self.orientation_source = imu.orientation_source
        self.path = imu.path

    @property
    def t_first(self) -> float:
        return float(self._rows.t[0])

    @property
    def t_last(self) -> float:
        return float(self._rows.t[-1])

    def rows(self, lo: float, hi: float) -> ImuRows:
        """The usable samples with lo <= t <= hi (s, the IMU's clock), as copies."""
        r = self._rows
        a, b = int(np.searchsorted(r.t, lo, "left")), int(np.searchsorted(r.t, hi, "right"))
        return ImuRows(r.t[a:b].copy(), r.quat[a:b].copy(), r.acc[a:b].copy(),
                       r.gyr[a:b].copy())

    def close(self) -> None:
        """Nothing held on disk (a spilled reader's close)."""


STRIDE = 1024  # every STRIDE-th sample's time kept in memory: a span's rows found on disk


class SpilledImu:
    """The usable samples kept on disk (session/spill.py, in the output folder) as they are read
    a chunk at a time, read back by span: memory a window's samples, whatever the length."""

    def __init__(self, folder, chunks, *, rate_hz: float | None = None,
                 orientation_source: str | None = None, path: str | None = None) -> None:
        """``chunks``: ImuRows; a session/imu_stream.ImuStream gives the rate, orientation
        source and path not given here (its rate is known once its chunks are read)."""
        from armtrack_cli.session.spill import Spill

        self._spill = Spill(folder)
        coarse: list[np.ndarray] = []
        try:
            for c in chunks:
                ok = np.isfinite(c.acc).all(axis=1) & np.isfinite(c.quat).all(axis=1)
                n0 = len(self._spill)
                t = c.t[ok]
                self._spill.append({"t": t, "quat": c.quat[ok], "acc": c.acc[ok],
                                    "gyr": c.gyr[ok]})
                coarse.append(t[(-n0) % STRIDE::STRIDE])  # the rows at multiples of STRIDE
                self.t_last = float(t[-1]) if t.size else getattr(self, "t_last", np.nan)
        except BaseException:
            self._spill.close()
            raise
        self.rate_hz = rate_hz if rate_hz is not None else chunks.rate_hz
        self.orientation_source = orientation_source or chunks.orientation_source
        self.path = path or chunks.path
        self._coarse = np.concatenate(coarse) if coarse else np.empty(0)
        self.t_first = float(self._coarse[0]) if self._coarse.size else np.nan

    def rows(self, lo: float, hi: float) -> ImuRows:
        """The usable samples with lo <= t <= hi (s, the IMU's clock)."""
        n = len(self._spill)
        a = max(0, int(np.searchsorted(self._coarse, lo, "left")) - 1) * STRIDE
        b = min(n, int(np.searchsorted(self._coarse, hi, "right")) * STRIDE)
        t = self._spill.read(a, b, ("t",))["t"]
        i, j = a + int(np.searchsorted(t, lo, "left")), a + int(np.searchsorted(t, hi, "right"))
        r = self._spill.read(i, j)
        return ImuRows(r["t"], r["quat"], r["acc"], r["gyr"])

    def close(self) -> None:
        self._spill.close()
