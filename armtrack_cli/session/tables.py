"""armtrack's own CSV outputs read back: detections.csv and trajectory-METHOD.csv."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from armtrack_cli.core.errors import DataError
from armtrack_cli.core.limits import MAX_PIXEL_MARGIN, MAX_TEXT_BYTES
from armtrack_cli.session.files import regular_file

if TYPE_CHECKING:
    import pandas as pd


def read_csv_table(path: Path, required: tuple[str, ...], hint: str) -> pd.DataFrame:
    import pandas as pd  # here: compare reads its tables without it (session/plain_tables.py)

    regular_file(path, DataError, "a CSV table", hint=hint, max_bytes=MAX_TEXT_BYTES)
    try:
        df = pd.read_csv(path)
    except (ValueError, pd.errors.ParserError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise DataError(path, f"is not a readable CSV ({first})") from None
    missing = [c for c in required if c not in df.columns]
    if missing:
        raise DataError(path, f"lacks column(s) {', '.join(missing)}", hint)
    return df


def numeric(path: Path, df: pd.DataFrame, cols, *, missing_ok: bool = True) -> np.ndarray:
    """Columns as float64; a text cell, or an empty one where none may be, names its row."""
    out = np.empty((len(df), len(cols)))
    for k, c in enumerate(cols):
        col = df[c]
        if col.dtype.kind in "fiu":  # parsed as numbers whole: no text cell to look for
            v = col.to_numpy(dtype=float)
            text = np.zeros(len(v), bool)
        else:
            import pandas as pd

            v = pd.to_numeric(col, errors="coerce").to_numpy(dtype=float)
            text = np.isnan(v) & col.notna().to_numpy() & ~col.astype(str).str.strip().str.lower(
            ).isin(["nan", ""]).to_numpy()
        if text.any():
            r = int(np.flatnonzero(text)[0])
            raise DataError(path, f"row {r + 1}: {c} = {df[c].iloc[r]!r} is not a number",
                            "the file was edited by hand; rerun the stage that wrote it")
        if not missing_ok and np.isnan(v).any():
            r = int(np.flatnonzero(np.isnan(v))[0])
            raise DataError(path, f"row {r + 1}: {c} is empty", "rerun the stage that wrote it")
        if np.isinf(v).any():
            r = int(np.flatnonzero(np.isinf(v))[0])
            raise DataError(path, f"row {r + 1}: {c} is not finite ({v[r]})",
                            "rerun the stage that wrote it")
        out[:, k] = v
    return out


def increasing_times(path: Path, t: np.ndarray, what: str = "t") -> None:
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        r = int(bad[0]) + 1
        raise DataError(path, f"row {r + 1}: {what} = {t[r]:g} s does not increase "
                        f"(the row before says {t[r - 1]:g} s)", "rerun the stage that wrote it")


def read_patch_detections(path: Path, *, width: int, height: int,
                          n_frames: int) -> tuple[np.ndarray, np.ndarray]:
    """(t (K,), uv (K, 2) with NaN where ok = 0), checked against the camera's image size and
    the video's frame count: one row per frame, in order, times increasing, pixels inside the
    image (up to a margin of limits.MAX_PIXEL_MARGIN of its size). The file as detect writes
    it is read without pandas (session/plain_tables.py); any other, by pandas, which names
    what is wrong with it."""
    from armtrack_cli.session.plain_tables import plain_columns

    need, hint = ("frame", "t", "u", "v", "ok"), \
        "run `armtrack detect SESSION` first (wrist-patch sessions)"
    cols = plain_columns(path, need, hint)
    if cols is not None and not any(np.isnan(cols[c]).any() for c in ("frame", "t", "ok")):
        frame, t, ok, uv = cols["frame"], cols["t"], cols["ok"], np.c_[cols["u"], cols["v"]]
    else:  # empty frame, t or ok cells: pandas' reader names the row
        df = read_csv_table(path, need, hint)
        frame, t, ok = numeric(path, df, ("frame", "t", "ok"), missing_ok=False).T
        uv = numeric(path, df, ("u", "v"))
    del cols
    n = len(t)
    if n != n_frames or not np.array_equal(frame, np.arange(n)):
        raise DataError(path, f"has {n} rows for frames {frame[0]:g}…{frame[-1]:g} but the "
                        f"video has {n_frames} frames (0…{n_frames - 1})" if n else
                        "has no rows", "rerun `armtrack detect` on this session")
    increasing_times(path, t)
    if not np.isin(ok, (0, 1)).all():
        r = int(np.flatnonzero(~np.isin(ok, (0, 1)))[0])
        raise DataError(path, f"row {r + 1}: ok = {ok[r]:g}, must be 1 (found) or 0 (not)")
    seen = ok == 1
    if np.isnan(uv[seen]).any():
        r = int(np.flatnonzero(seen & np.isnan(uv).any(axis=1))[0])
        raise DataError(path, f"row {r + 1}: ok = 1 but u or v is empty", "rerun `armtrack detect`")
    m = MAX_PIXEL_MARGIN
    out = seen & ((uv[:, 0] < -m * width) | (uv[:, 0] > (1 + m) * width)
                  | (uv[:, 1] < -m * height) | (uv[:, 1] > (1 + m) * height))
    if out.any():
        r = int(np.flatnonzero(out)[0])
        raise DataError(path, f"row {r + 1}: pixel ({uv[r, 0]:g}, {uv[r, 1]:g}) is far outside "
                        f"the {width}x{height} image", "rerun `armtrack detect`")
    uv[~seen] = np.nan
    return t, uv


MAX_POSITION_M = 100.0  # a joint farther than this from the board is not a measurement


def read_trajectory(path: Path) -> pd.DataFrame:
    """trajectory-METHOD.csv, every column numeric (empty = missing), times increasing,
    positions within MAX_POSITION_M of W's origin."""
    df = read_csv_table(path, ("t", "wrist_x", "wrist_y", "wrist_z"),
                        "run `armtrack fuse SESSION --method M` first")
    if df.empty:
        raise DataError(path, "has no rows", "rerun `armtrack fuse`")
    values = numeric(path, df, list(df.columns))
    t = values[:, df.columns.get_loc("t")]
    if np.isnan(t).any():
        r = int(np.flatnonzero(np.isnan(t))[0])
        raise DataError(path, f"row {r + 1}: t is empty", "rerun `armtrack fuse`")
    increasing_times(path, t)
    pos = [k for k, c in enumerate(df.columns) if c.split("_")[0] in ("wrist", "elbow", "shoulder")
           and c.rsplit("_", 1)[-1] in ("x", "y", "z") and "_v" not in c]
    far = np.abs(np.nan_to_num(values[:, pos])) > MAX_POSITION_M
    if far.any():
        r, k = np.argwhere(far)[0]
        raise DataError(path, f"row {r + 1}: {df.columns[pos[k]]} = {values[r, pos[k]]:g} m, "
                        f"beyond {MAX_POSITION_M:g} m of the board", "rerun `armtrack fuse`")
    import pandas as pd

    return pd.DataFrame(values, columns=df.columns)


def read_kinematics(path: Path) -> pd.DataFrame:
    """kinematics-METHOD.csv: a value cell is a number or "not computable: why" (kept as
    text); sd, t_start and t_end are numbers (sd empty where there is none)."""
    df = read_csv_table(path, ("measure", "segment", "value", "sd", "unit"),
                        "run `armtrack fuse SESSION --method M` first (an older armtrack's "
                        "kinematics file has no segment and sd columns: rerun fuse)")
    df = df.astype({"measure": str, "segment": str, "unit": str})
    df["value"] = df["value"].astype(str)
    import pandas as pd

    text = ~df["value"].str.startswith("not computable") & pd.to_numeric(
        df["value"], errors="coerce").isna()
    if text.any():
        r = int(np.flatnonzero(text)[0])
        raise DataError(path, f"row {r + 1}: value = {df['value'].iloc[r]!r} is not a number "
                        "(nor 'not computable: why')", "rerun `armtrack fuse`")
    cols = [c for c in ("sd", "t_start", "t_end") if c in df]
    df[cols] = numeric(path, df, cols)
    return df


def read_measures(path: Path) -> pd.DataFrame:
    """measures.csv (compare): estimate and truth cells stay text; errors are numbers."""
    df = read_csv_table(path, ("method", "measure", "segment", "estimate", "truth", "error"),
                        "rerun `armtrack compare SESSION`")
    df = df.astype({"segment": str, "estimate": str, "truth": str})
    cols = [c for c in ("error", "error_pct", "estimate_sd") if c in df]
    df[cols] = numeric(path, df, cols)
    return df
