"""The palm stages' own files read back: palm.toml (calibrate) and the palm blobs of
detections.csv (detect)."""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from armtrack_cli.core.errors import DataError
from armtrack_cli.session.tables import read_csv_table

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


@dataclass(frozen=True)
class PalmModel:
    """palm.toml: markers (M,) names, position_H (M, 3) m, the calibration frame and the
    markers' labelled pixels (M, 2) in it."""

    markers: tuple[str, ...]
    side: str
    position_H: np.ndarray
    frame: int
    pixels: np.ndarray


def read_palm_toml(path: Path) -> PalmModel:
    hint = "run `armtrack calibrate SESSION` first (palm sessions)"
    if not path.is_file():
        raise DataError(path, "not found", hint)
    try:
        doc = tomllib.loads(path.read_text())
        palm, fit = doc["palm"], doc["fit"]
        names = tuple(palm["markers"])
        pos = np.array(palm["position_m"], float).reshape(len(names), 3)
        px = np.array(fit["pixels"], float).reshape(len(names), 2)
        return PalmModel(names, str(palm.get("side", "right")), pos, int(fit["frame"]), px)
    except (tomllib.TOMLDecodeError, KeyError, ValueError, TypeError) as exc:
        raise DataError(path, f"is not a palm model armtrack wrote ({type(exc).__name__}: {exc})",
                        hint) from None


def read_palm_blobs(path: Path, n_frames: int) -> list[np.ndarray]:
    """Per video frame, the (B, 3) blobs of detections.csv (palm sessions): u, v (px) and
    area (px²)."""
    df = read_csv_table(path, ("frame", "t", "blob", "u", "v", "area"),
                        "run `armtrack detect SESSION` first (palm sessions)")
    try:
        f = df["frame"].to_numpy(dtype=float)
        uv = df[["u", "v", "area"]].to_numpy(dtype=float)
    except (TypeError, ValueError):
        raise DataError(path, "has a row whose frame, u, v or area is not a number",
                        "run `armtrack detect SESSION` again") from None
    if not (np.isfinite(f).all() and (f == np.round(f)).all()):
        raise DataError(path, "has a row without a whole frame number",
                        "run `armtrack detect SESSION` again")
    f = f.astype(np.int64)
    if f.size and (f.min() < 0 or f.max() >= n_frames):
        raise DataError(path, f"names frame {int(f.max())} but the video has {n_frames} frames",
                        "run `armtrack detect SESSION` again")
    if not np.isfinite(uv).all():
        raise DataError(path, "has blobs without pixels (u, v)")
    order = np.argsort(f, kind="stable")
    f, uv = f[order], uv[order]
    cuts = np.searchsorted(f, np.arange(n_frames + 1))
    return [uv[cuts[i]:cuts[i + 1]] for i in range(n_frames)]
