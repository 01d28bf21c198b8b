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
    path = regular_file(path, ImuFileError, f"an IMU file ({FORMATS})",
                        hint="check [imu] file in session.toml", max_bytes=MAX_TEXT_BYTES)
    with open(path, "rb") as f:
        head = f.read(8)
    if head == imu_mcap.MAGIC:
        samples = imu_mcap.read_mcap_imu(path, topic=topic, field=field)
    else:
        if head.startswith(b"\x89MCAP"):
            raise ImuFileError(path, "is a damaged MCAP file (bad magic)")
        lines = read_text_head(path, ImuFileError, f"an IMU file ({FORMATS})")
        if xsens.looks_like_dot(lines):
            samples = xsens.read_dot(path, rate_hz=rate_hz, lines=lines)
        elif xsens.looks_like_mt_manager(lines):
            samples = xsens.read_mt_manager(path, rate_hz=rate_hz, lines=lines)
        elif imu_csv.looks_like_generic_csv(lines):
            samples = imu_csv.read_generic_csv(path, lines=lines)
        else:
            first = next((ln for ln in lines if ln.strip()), "")[:60]
            raise ImuFileError(path, f"is not an IMU format armtrack reads (starts {first!r})",
                               f"expected {FORMATS}")
    check_units(samples)
    if complete:
        require_channels(samples)
    check_usable(samples)
    if samples.n < 2:
        raise ImuFileError(path, f"holds {samples.n} sample: too short to use")
    if samples.quat is None and estimate and not np.isnan(samples.gyr).all():
        q = estimate_orientation(samples.gyr, samples.acc, samples.mag, samples.rate_hz)
        source = "estimated (VQF, gyro+acc+mag)" if samples.mag is not None else \
            "estimated (VQF, gyro+acc)"
        samples = dataclasses.replace(samples, quat=q, orientation_source=source)
    return samples


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
    if not acc_absent(s) and not np.isfinite(s.acc).all(axis=1).any():
        raise ImuFileError(path, "has no usable accelerometer sample (every row is empty or NaN)",
                           "export the accelerometer (Acc_X..Z or ax, ay, az)")
    if s.quat is not None and not np.isfinite(s.quat).all(axis=1).any():
        raise ImuFileError(path, "its orientation is empty (NaN) in every row",
                           "export the orientation, or remove its columns to have armtrack "
                           "estimate it from the gyroscope and accelerometer")
    for name, arr, bound, unit in (("accelerometer", s.acc, MAX_ACCEL_M_S2, "m/s² (±16 g)"),
                                   ("gyroscope", s.gyr, MAX_GYRO_RAD_S, "rad/s")):
        for a in range(0, arr.shape[0], BLOCK_ROWS):  # a block at a time: no copy of arr
            big = np.abs(arr[a:a + BLOCK_ROWS]) > bound  # (NaN is not beyond it)
            if not big.any():
                continue
            k, ax = np.argwhere(big)[0] + (a, 0)
            raise ImuFileError(path, f"sample {k} (t = {s.t[k]:.3f} s): {name} {'xyz'[ax]} reads "
                               f"{arr[k, ax]:.4g}, beyond the {bound:g} {unit} a wrist IMU measures",
                               "the row is damaged: delete it (it becomes a gap)")
    if s.n and s.t[-1] - s.t[0] > MAX_SESSION_S:
        raise ImuFileError(path, f"its clock spans {(s.t[-1] - s.t[0]) / 3600:.0f} h, longer "
                           "than any session", "its time column is damaged")


def check_units(s: ImuSamples) -> None:
    """Refuse values no wrist IMU in SI units produces, saying which unit they look like."""
    path = Path(s.path)
    g = max((np.abs(b[np.isfinite(b)]).max(initial=-1.0) for b in _blocks(s.gyr)),
            default=-1.0)  # the largest finite |rate|, a block of rows at a time
    if g > MAX_GYRO_RAD_S:
        raise ImuFileError(path, f"gyroscope reaches {g:.0f}, more than the 35 rad/s "
                           "(2000 °/s) any MEMS gyro measures",
                           "the values look like degrees per second; armtrack expects rad/s")
    rows = np.isfinite(s.acc).all(axis=1)
    if rows.sum() >= 10:
        mag = np.concatenate([np.linalg.norm(b[r], axis=1) for b, r in
                              zip(_blocks(s.acc), _blocks(rows))])
        med = float(np.median(mag))
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
