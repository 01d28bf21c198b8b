"""trajectory-METHOD.csv and kinematics-METHOD.csv read without pandas (compare starts without
importing it): the files armtrack writes, the trajectory streamed by session/numeric_text (a
60-minute one is never held as text), the kinematics parsed by the csv module, to the values
session/tables.py's pandas readers give. Anything those readers would refuse, or read in a
way this one does not copy (quoted cells, NA spellings, stray spaces, infinities), is handed
to them, so a bad file gets their one-line error word for word."""

from __future__ import annotations

import csv
import io
import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from armtrack_cli.core.errors import DataError
from armtrack_cli.core.limits import MAX_TEXT_BYTES
from armtrack_cli.session.files import regular_file
from armtrack_cli.session.numeric_text import Irregular, Layout, file_chunks, file_rows, row_blocks

TRAJECTORY_NEEDS = ("t", "wrist_x", "wrist_y", "wrist_z")
KINEMATICS_NEEDS = ("measure", "segment", "value", "sd", "unit")
_INT = re.compile(r"[+-]?\d{1,18}")
_FLOAT = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")
MAX_POSITION_M = 100.0  # as session/tables.py: farther from the board is not a measurement


class _Irregular(Exception):
    """The file is not the plain form: the pandas reader decides."""


class NotPlain(Exception):
    """trajectory_blocks met what the plain reader does not take: read it with
    trajectory_columns (which hands it to the pandas reader)."""


def _text(path: Path, hint: str, *, quotes: bool = False) -> str:
    regular_file(path, DataError, "a CSV table", hint=hint, max_bytes=MAX_TEXT_BYTES)
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError):
        raise _Irregular from None
    if (not quotes and '"' in text) or "\r" in text:
        raise _Irregular
    return text


def trajectory_columns(path: Path) -> dict[str, np.ndarray]:
    """trajectory-METHOD.csv as column -> (N,) float64, empty cells NaN: the values of
    tables.read_trajectory (which checks and reads every file this one does not take)."""
    path = Path(path)
    try:
        return _plain_trajectory(path)
    except _Irregular:
        from armtrack_cli.session.tables import read_trajectory

        df = read_trajectory(path)
        return {str(c): df[c].to_numpy(dtype=float) for c in df.columns}


def trajectory_blocks(path: Path, keep) -> Iterator[dict[str, np.ndarray]]:
    """The columns of trajectory-METHOD.csv that ``keep`` (a column name -> bool) takes, block
    by block (a chunk of numeric_text's at a time), with the checks trajectory_columns makes
    on every column: the same values (issue 15: a 60-minute table's 30 columns were 26 MB
    read whole). Raises NotPlain, possibly after some blocks, where trajectory_columns would
    hand the file to the pandas reader."""
    path = Path(path)
    try:
        names = _plain_header(path, TRAJECTORY_NEEDS, "run `armtrack fuse SESSION --method M` first")
        pos = [k for k, n in enumerate(names) if n.split("_")[0] in ("wrist", "elbow", "shoulder")
               and n.rsplit("_", 1)[-1] in ("x", "y", "z") and "_v" not in n]
        kept = [k for k, n in enumerate(names) if keep(n)]
        layout = Layout(len(names), ",", tuple(names))
        last = -np.inf
        for rows in row_blocks(file_chunks(path, 1), layout, path, DataError, by_row=False,
                               groups=(tuple(range(len(names))),)):
            values = rows.groups[0]
            t = values[:, names.index("t")]
            if (np.isinf(values).any() or np.isnan(t).any() or (np.diff(np.r_[last, t]) <= 0).any()
                    or (np.abs(np.nan_to_num(values[:, pos])) > MAX_POSITION_M).any()):
                raise _Irregular
            last = t[-1]
            yield {names[k]: np.ascontiguousarray(values[:, k]) for k in kept}
    except (_Irregular, Irregular):
        raise NotPlain from None


def plain_columns(path: Path, needs: tuple[str, ...], hint: str) -> dict[str, np.ndarray] | None:
    """A CSV table armtrack wrote, as column -> (N,) float64 (empty cells NaN), streamed by
    session/numeric_text, when it is in the plain form (a header naming ``needs``, plain
    numbers, nothing infinite); None for any other file, for a pandas reader to read or refuse
    with its one-line error (tables.read_patch_detections)."""
    try:
        return _plain_columns(Path(path), needs, hint)
    except _Irregular:
        return None


def _plain_header(path: Path, needs: tuple[str, ...], hint: str) -> list[str]:
    """The column names of a plain table (checked as a file first), else _Irregular."""
    regular_file(path, DataError, "a CSV table", hint=hint, max_bytes=MAX_TEXT_BYTES)
    with open(path, "rb") as f:
        head = f.readline()
    try:
        names = head.decode("utf-8").rstrip("\r\n").split(",")
    except UnicodeDecodeError:
        raise _Irregular from None
    if (len(set(names)) != len(names) or any(n != n.strip() or not n or '"' in n for n in names)
            or not set(needs) <= set(names)):
        raise _Irregular
    return names


def _plain_columns(path: Path, needs: tuple[str, ...], hint: str) -> dict[str, np.ndarray]:
    names = _plain_header(path, needs, hint)
    try:
        values = file_rows(path, 1, Layout(len(names), ",", tuple(names)), DataError,
                           by_row=False).data
    except Irregular:
        raise _Irregular from None
    if np.isinf(values).any():
        raise _Irregular
    cols = {n: np.ascontiguousarray(values[:, k]) for k, n in enumerate(names)}
    del values
    return cols


def _plain_trajectory(path: Path) -> dict[str, np.ndarray]:
    """The columns streamed by session/numeric_text (plain numbers only, empty cells NaN)."""
    cols = _plain_columns(path, TRAJECTORY_NEEDS, "run `armtrack fuse SESSION --method M` first")
    t = cols["t"]
    if np.isnan(t).any() or (np.diff(t) <= 0).any():
        raise _Irregular
    pos = [n for n in cols if n.split("_")[0] in ("wrist", "elbow", "shoulder")
           and n.rsplit("_", 1)[-1] in ("x", "y", "z") and "_v" not in n]
    if any((np.abs(np.nan_to_num(cols[n])) > MAX_POSITION_M).any() for n in pos):
        raise _Irregular
    return cols


def kinematics_rows(path: Path) -> list[dict]:
    """kinematics-METHOD.csv as one dict per row: measure, segment, value, unit as text (a
    value a number or "not computable: why"), sd, t_start, t_end as floats (NaN where empty)
    when present: what tables.read_kinematics gives, row by row."""
    path = Path(path)
    try:
        return _plain_kinematics(path)
    except _Irregular:
        from armtrack_cli.session.tables import read_kinematics

        return read_kinematics(path).to_dict("records")


def _as_text(cells: list[str]) -> list[str]:
    """A column as pandas reads it and then writes it with astype(str): integers and numbers
    re-printed from their value, an empty cell as "nan"."""
    full = [c for c in cells if c]
    if any(c != c.strip() for c in full):
        raise _Irregular
    if full and len(full) == len(cells) and all(_INT.fullmatch(c) for c in full):
        return [str(int(c)) for c in cells]
    if full and all(_FLOAT.fullmatch(c) for c in full):
        return [str(float(c)) if c else "nan" for c in cells]
    if any(c.lower() in ("na", "n/a", "nan", "null", "none", "-nan", "inf", "-inf") for c in full):
        raise _Irregular  # NA spellings pandas reads as missing, infinities: its reader decides
    return [c if c else "nan" for c in cells]


def _plain_kinematics(path: Path) -> list[dict]:
    text = _text(path, "run `armtrack fuse SESSION --method M` first", quotes=True)
    rows = list(csv.reader(io.StringIO(text)))
    if not rows or len(set(rows[0])) != len(rows[0]) or not set(KINEMATICS_NEEDS) <= set(rows[0]):
        raise _Irregular
    names, body = rows[0], rows[1:]
    if not body or any(len(r) != len(names) for r in body):
        raise _Irregular
    cols = {n: [r[k] for r in body] for k, n in enumerate(names)}
    out = {n: _as_text(cols[n]) for n in ("measure", "segment", "value", "unit")}
    if any(not (v.startswith("not computable") or _FLOAT.fullmatch(v)) for v in out["value"]):
        raise _Irregular
    for n in ("sd", "t_start", "t_end"):
        if n in cols:
            if any(c and not _FLOAT.fullmatch(c) for c in cols[n]):
                raise _Irregular
            out[n] = [float(c) if c else float("nan") for c in cols[n]]
    for n in names:
        out.setdefault(n, _as_text(cols[n]))
    return [{n: out[n][i] for n in names} for i in range(len(body))]
