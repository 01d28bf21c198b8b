"""armtrack's own CSV outputs read back: detections.csv and trajectory-METHOD.csv."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from armtrack_cli.core.errors import DataError


def read_csv_table(path: Path, required: tuple[str, ...], hint: str) -> pd.DataFrame:
    if not path.is_file():
        raise DataError(path, "not found", hint)
    try:
        df = pd.read_csv(path)
    except (ValueError, pd.errors.ParserError) as exc:
        raise DataError(path, f"is not a readable CSV ({exc})") from None
    missing = [c for c in required if c not in df.columns]
    if missing:
        raise DataError(path, f"lacks column(s) {', '.join(missing)}", hint)
    return df


def read_patch_detections(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(t (K,), uv (K, 2) with NaN where ok = 0)."""
    df = read_csv_table(path, ("frame", "t", "u", "v", "ok"),
                        "run `armtrack detect SESSION` first (wrist-patch sessions)")
    uv = df[["u", "v"]].to_numpy(dtype=float)
    uv[df["ok"].to_numpy() != 1] = np.nan
    t = df["t"].to_numpy(dtype=float)
    if (np.diff(t) <= 0).any():
        raise DataError(path, "times do not increase")
    return t, uv


def read_trajectory(path: Path) -> pd.DataFrame:
    return read_csv_table(path, ("t", "wrist_x", "wrist_y", "wrist_z"),
                          "run `armtrack fuse SESSION --method M` first")


def read_kinematics(path: Path) -> pd.DataFrame:
    """kinematics-METHOD.csv: value cells stay text (a number or "not computable: why")."""
    if not path.is_file():
        raise DataError(path, "not found", "run `armtrack fuse SESSION` first")
    try:
        df = pd.read_csv(path, dtype={"value": str, "segment": str}, keep_default_na=False)
    except (ValueError, pd.errors.ParserError) as exc:
        raise DataError(path, f"is not a readable CSV ({exc})") from None
    missing = [c for c in ("measure", "segment", "value", "sd", "unit") if c not in df.columns]
    if missing:
        raise DataError(path, f"lacks column(s) {', '.join(missing)}",
                        "rerun `armtrack fuse SESSION` (an older armtrack wrote it)")
    df["sd"] = pd.to_numeric(df["sd"], errors="coerce")
    return df


def read_measures(path: Path) -> pd.DataFrame:
    """measures.csv (compare): estimate and truth cells stay text; errors are numbers."""
    df = read_csv_table(path, ("method", "measure", "segment", "estimate", "truth", "error"),
                        "rerun `armtrack compare SESSION`")
    df = df.astype({"segment": str, "estimate": str, "truth": str})
    for c in ("error", "error_pct", "estimate_sd"):
        df[c] = pd.to_numeric(df[c], errors="coerce") if c in df else float("nan")
    return df
