"""Read any IMU file the contract names: the format is told by content, not by extension.

After reading, units are sanity-checked (deg/s where rad/s is expected, g where m/s² is) and
a recording without orientation gets one estimated offline (see ``orientation``).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from armtrack_cli.core.errors import ImuFileError
from armtrack_cli.core.limits import MAX_ACCEL_M_S2, MAX_GYRO_RAD_S, MAX_SESSION_S, MAX_TEXT_BYTES
from armtrack_cli.core.streams import ImuSamples
from armtrack_cli.session import imu_csv, imu_mcap, xsens
from armtrack_cli.session.files import regular_file
from armtrack_cli.session.orientation import estimate_orientation
from armtrack_cli.session.text_head import read_text_head

BLOCK_ROWS = 65_536  # the checks' temporaries: this many samples at a time (issue 15)
FORMATS = "Xsens MT Manager export, Xsens DOT CSV, generic CSV (t,ax,ay,az,gx,gy,gz) or MCAP"


def read_imu(path: str | Path, *, rate_hz: float | None = None, topic: str | None = None,
             field: str | None = None, estimate: bool = True,
             complete: bool = True) -> ImuSamples:
    """Load an IMU recording into contract conventions (B frame, SI, quaternions B -> W).

    ``complete=False`` (for ``info``) also returns exports that hold orientation only or
    acceleration only, their absent channels NaN; the fusion methods read with
    ``complete=True``, which refuses them naming what is missing (``require_channels``).
    """
    path = imu_file(path)
    kind, lines = sniff_format(path)
    if kind == "mcap":
        samples = imu_mcap.read_mcap_imu(path, topic=topic, field=field)
    elif kind == "dot":
        samples = xsens.read_dot(path, rate_hz=rate_hz, lines=lines)
    elif kind == "mt":
        samples = xsens.read_mt_manager(path, rate_hz=rate_hz, lines=lines)
    else:
        samples = imu_csv.read_generic_csv(path, lines=lines)
    check_units(samples)
    if complete:
        require_channels(samples)
    check_usable(samples)
    too_short(path, samples.n)
    if samples.quat is None and estimate and not np.isnan(samples.gyr).all():
        q = estimate_orientation(samples.gyr, samples.acc, samples.mag, samples.rate_hz)
        source = "estimated (VQF, gyro+acc+mag)" if samples.mag is not None else \
            "estimated (VQF, gyro+acc)"
        samples = dataclasses.replace(samples, quat=q, orientation_source=source)
    return samples


def imu_file(path: str | Path) -> Path:
    """The IMU file checked to be a regular file of a sane size."""
    return regular_file(path, ImuFileError, f"an IMU file ({FORMATS})",
                        hint="check [imu] file in session.toml", max_bytes=MAX_TEXT_BYTES)


def sniff_format(path: Path) -> tuple[str, list[str] | None]:
    """The file's format told by its content ("mcap", "dot", "mt" or "csv") and its head's
    lines (None for MCAP); any other content refused."""
    with open(path, "rb") as f:
        head = f.read(8)
    if head == imu_mcap.MAGIC:
        return "mcap", None
    if head.startswith(b"\x89MCAP"):
        raise ImuFileError(path, "is a damaged MCAP file (bad magic)")
    lines = read_text_head(path, ImuFileError, f"an IMU file ({FORMATS})")
    if xsens.looks_like_dot(lines):
        return "dot", lines
    if xsens.looks_like_mt_manager(lines):
        return "mt", lines
    if imu_csv.looks_like_generic_csv(lines):
        return "csv", lines
    first = next((ln for ln in lines if ln.strip()), "")[:60]
    raise ImuFileError(path, f"is not an IMU format armtrack reads (starts {first!r})",
                       f"expected {FORMATS}")


def acc_absent(s: ImuSamples) -> bool:
    """The export has no accelerometer columns at all (its reader noted so): info describes
    it; fusion refuses it. Columns present but empty are damage (``check_usable``)."""
    return any(n.startswith("no accelerometer") for n in s.notes)


def missing_channels(s: ImuSamples) -> list[str]:
    """What the fusion methods need that the recording lacks (empty: all there)."""
    lack = []
    if acc_absent(s):
        lack.append("accelerometer")
    if s.quat is None and np.isnan(s.gyr).all():
        lack.append("orientation (or a gyroscope to estimate it)")
    return lack


def require_channels(s: ImuSamples) -> None:
    """Refuse a recording the fusion methods cannot use, naming what it lacks."""
    path = Path(s.path)
    if acc_absent(s):
        raise ImuFileError(path, "has no Acc_X/Acc_Y/Acc_Z columns (no accelerometer): every "
                           "fusion method integrates acceleration",
                           "export the accelerometer (or FreeAcc with orientation); "
                           "`armtrack info` describes what the file holds")
    if s.quat is None and np.isnan(s.gyr).all():
        raise ImuFileError(path, "has no orientation and no gyroscope to estimate it from",
                           "export Gyr_X..Z or an orientation (quaternion, matrix or Euler); "
                           "`armtrack info` describes what the file holds")


def check_usable(s: ImuSamples) -> None:
    """Refuse a recording that has no usable sample, a physically impossible one, or a clock
    that runs for longer than any session (a damaged time column)."""
    path = Path(s.path)
    no_usable(path, acc=not acc_absent(s) and not np.isfinite(s.acc).all(axis=1).any(),
              quat=s.quat is not None and not np.isfinite(s.quat).all(axis=1).any())
    for name, field, bound, unit in BOUNDS:
        beyond_bound(path, name, getattr(s, field), s.t, bound, unit)
    if s.n:
        clock_span(path, s.t[-1] - s.t[0])


# check_usable's and check_units' checks one by one, for a reader that sees its rows a chunk
# at a time (session/xsens_stream.py) as for the whole recording
BOUNDS = (("accelerometer", "acc", MAX_ACCEL_M_S2, "m/s² (±16 g)"),
          ("gyroscope", "gyr", MAX_GYRO_RAD_S, "rad/s"))


def no_usable(path: Path, *, acc: bool, quat: bool) -> None:
    """Refuse a recording whose every accelerometer (``acc``) or orientation (``quat``)
    sample is empty."""
    if acc:
        raise ImuFileError(path, "has no usable accelerometer sample (every row is empty or NaN)",
                           "export the accelerometer (Acc_X..Z or ax, ay, az)")
    if quat:
        raise ImuFileError(path, "its orientation is empty (NaN) in every row",
                           "export the orientation, or remove its columns to have armtrack "
                           "estimate it from the gyroscope and accelerometer")


def beyond_bound(path: Path, name: str, arr: np.ndarray, t: np.ndarray, bound: float,
                 unit: str, first: int = 0) -> None:
    """Refuse the first sample of arr (samples ``first`` on of the recording) beyond bound."""
    for a in range(0, arr.shape[0], BLOCK_ROWS):  # a block at a time: no copy of arr
        big = np.abs(arr[a:a + BLOCK_ROWS]) > bound  # (NaN is not beyond it)
        if not big.any():
            continue
        k, ax = np.argwhere(big)[0] + (a, 0)
        raise ImuFileError(path, f"sample {k + first} (t = {t[k]:.3f} s): {name} {'xyz'[ax]} "
                           f"reads {arr[k, ax]:.4g}, beyond the {bound:g} {unit} a wrist IMU "
                           "measures", "the row is damaged: delete it (it becomes a gap)")


def clock_span(path: Path, span: float) -> None:
    if span > MAX_SESSION_S:
        raise ImuFileError(path, f"its clock spans {span / 3600:.0f} h, longer than any session",
                           "its time column is damaged")


def too_short(path: Path, n: int) -> None:
    if n < 2:
        raise ImuFileError(path, f"holds {n} sample: too short to use")


def check_units(s: ImuSamples) -> None:
    """Refuse values no wrist IMU in SI units produces, saying which unit they look like."""
    path = Path(s.path)
    gyro_units(path, max((gyro_max(b) for b in _blocks(s.gyr)), default=-1.0))
    rows = np.isfinite(s.acc).all(axis=1)
    if rows.sum() >= 10:
        acc_units(path, float(np.median(np.concatenate([acc_magnitudes(b) for b in
                                                        _blocks(s.acc)]))))


def gyro_max(gyr: np.ndarray) -> float:
    """The largest finite |rate| (-1 when none)."""
    return np.abs(gyr[np.isfinite(gyr)]).max(initial=-1.0)


def acc_magnitudes(acc: np.ndarray) -> np.ndarray:
    """|f| of the rows whose three axes are finite."""
    return np.linalg.norm(acc[np.isfinite(acc).all(axis=1)], axis=1)


def gyro_units(path: Path, g: float) -> None:
    if g > MAX_GYRO_RAD_S:
        raise ImuFileError(path, f"gyroscope reaches {g:.0f}, more than the 35 rad/s "
                           "(2000 °/s) any MEMS gyro measures",
                           "the values look like degrees per second; armtrack expects rad/s")


def acc_units(path: Path, med: float) -> None:
    """Refuse a median |f| far from 1 g, named by the unit it looks like."""
    if med < 3.0:
        raise ImuFileError(path, f"accelerometer magnitude is {med:.2f} on median; a worn "
                           "sensor reads about 9.81 m/s²",
                           "the values look like g; armtrack expects m/s²")
    if med > 40.0:
        raise ImuFileError(path, f"accelerometer magnitude is {med:.0f} on median; a worn "
                           "sensor reads about 9.81 m/s²", "are the values in m/s²?")


def _blocks(x: np.ndarray):
    """x's rows BLOCK_ROWS at a time (views)."""
    return (x[a:a + BLOCK_ROWS] for a in range(0, x.shape[0], BLOCK_ROWS))
