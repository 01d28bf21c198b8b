"""C3D motion-capture files (Qualisys, Vicon, Motion Analysis…), read with the ``c3d`` package.

Why ``c3d`` (py-c3d, MIT) rather than ezc3d: it is pure Python on numpy (a wheel that installs
anywhere without compiling), it reads and writes, and it handles the processor types (Intel,
DEC, SGI/MIPS) and integer/float storage of files from every lab; ezc3d is a fine C++ library
but its wheels are platform builds and it pulls in more than armtrack needs.

Markers by POINT:LABELS (trailing blanks dropped); units from POINT:UNITS (mm, cm, m; the
c3d reader already applies POINT:SCALE to integer files); a residual < 0 marks a gap (C3D
standard), and so do all-zero coordinates, as QTM's TSV; rate and first frame from the header.
The stream clock starts at 0 at the first frame stored: t = (frame − first_frame) / rate.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from armtrack_cli.core.errors import GroundTruthError
from armtrack_cli.core.streams import MarkerTrajectories
from armtrack_cli.session.outputs import atomic_write

UNITS_TO_M = {"mm": 1e-3, "cm": 1e-2, "m": 1.0, "dm": 0.1}


def is_c3d(path: Path) -> bool:
    """C3D files start with the parameter-block pointer and the 0x50 key byte."""
    try:
        with open(path, "rb") as f:
            head = f.read(2)
    except OSError:
        return False
    return len(head) == 2 and head[1] == 0x50 and 1 <= head[0] <= 127


def _labels(reader, path: Path) -> tuple[str, ...]:
    labels = tuple(s.strip() for s in reader.point_labels)[: reader.point_used]
    if len(labels) < reader.point_used:  # some writers leave LABELS short
        labels += tuple(f"M{k + 1:03d}" for k in range(len(labels), reader.point_used))
    if len(set(labels)) != len(labels):
        dup = next(n for n in labels if labels.count(n) > 1)
        raise GroundTruthError(path, f"POINT:LABELS names the marker {dup!r} twice")
    return labels


def _scale_to_m(reader, path: Path) -> tuple[float, str]:
    try:
        units = reader.get("POINT:UNITS").string_value.strip().lower()
    except (AttributeError, KeyError):
        return 1e-3, "POINT:UNITS absent: millimetres assumed (the C3D default)"
    if units not in UNITS_TO_M:
        raise GroundTruthError(path, f"POINT:UNITS is {units!r}, not a length unit armtrack knows",
                               f"expected one of {', '.join(UNITS_TO_M)}")
    return UNITS_TO_M[units], ""


def read_c3d(path: str | Path) -> MarkerTrajectories:
    """Markers of a C3D file as (N, M, 3) metres in the capture system's frame, NaN in gaps."""
    import c3d

    path = Path(path)
    try:
        with open(path, "rb") as f, warnings.catch_warnings():
            warnings.filterwarnings("ignore", message="No analog data")  # markers only: fine
            reader = c3d.Reader(f)
            labels = _labels(reader, path)
            scale, note = _scale_to_m(reader, path)
            rate, first = float(reader.point_rate), int(reader.first_frame)
            frames = [(i, p[:, :4].copy()) for i, p, _ in reader.read_frames(copy=True)]
    except GroundTruthError:
        raise
    except FileNotFoundError:
        raise GroundTruthError(path, "not found", "check [groundtruth] file") from None
    except Exception as exc:  # the c3d package raises several types on damaged files
        raise GroundTruthError(path, f"is not a readable C3D file ({type(exc).__name__}: {exc})"
                               ) from None
    if not frames or not labels:
        raise GroundTruthError(path, "holds no marker frames" if labels else "holds no markers")
    if not np.isfinite(rate) or rate <= 0:
        raise GroundTruthError(path, f"states a point rate of {rate}, not a frame rate")
    idx = np.array([i for i, _ in frames], dtype=float)
    pts = np.stack([p for _, p in frames]).astype(float)  # (N, M, 4): x, y, z, residual
    xyz = pts[..., :3] * scale
    gap = (pts[..., 3] < 0) | np.all(pts[..., :3] == 0, axis=2) | ~np.isfinite(pts[..., :3]).all(2)
    xyz[gap] = np.nan
    notes = [f"first frame {first}, POINT:RATE {rate:g} Hz"] + ([note] if note else [])
    return MarkerTrajectories(str(path), (idx - idx[0]) / rate, labels, xyz, rate, tuple(notes))


def write_c3d(path: str | Path, xyz_m: np.ndarray, names: list[str], rate_hz: float, *,
              units: str = "mm", first_frame: int = 1) -> Path:
    """A float C3D of markers (N, M, 3) in metres (NaN = gap, written with residual −1)."""
    import c3d

    scale = 1.0 / UNITS_TO_M[units]

    def write(tmp: Path) -> None:
        w = c3d.Writer(point_rate=float(rate_hz), analog_rate=0.0, point_scale=-1.0,
                       point_units=units.ljust(4))
        w.set_point_labels(list(names))
        w.set_start_frame(first_frame)
        for i in range(xyz_m.shape[0]):
            p = np.zeros((xyz_m.shape[1], 5), dtype=np.float32)
            ok = np.isfinite(xyz_m[i]).all(axis=1)
            p[ok, :3] = xyz_m[i, ok] * scale
            p[~ok, 3] = -1.0
            w.add_frames([(p, np.zeros((0, 0), dtype=np.float32))])
        with open(tmp, "wb") as f, warnings.catch_warnings():
            warnings.filterwarnings("ignore", message="No analog data")
            w.write(f)

    return atomic_write(path, write)
