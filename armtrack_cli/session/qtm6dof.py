"""Qualisys Track Manager 6DOF TSV exports: rigid bodies, position and rotation.

Header as the 3D export (``KEY<TAB>value``: ``NO_OF_BODIES``, ``BODY_NAMES``, ``FREQUENCY``,
``DATA_INCLUDED 6D``), then the table, with or without a ``Frame Time …`` row and
frame/time columns; per body, in BODY_NAMES order, 16 columns: X Y Z (mm), Roll Pitch Yaw
(deg), Residual, Rot[0]…Rot[8] (or only the first 6: the rotation then from the angles).
Rot is the body's rotation in the lab frame (body -> lab). QTM stores it column by column
(Rot[0]=R11, Rot[1]=R21, Rot[2]=R31, …); the order is checked
against the Euler angles under QTM's default definition (R = Rx(roll)·Ry(pitch)·Rz(yaw)),
and taken row by row instead if only that agrees. Untracked frames (empty, NaN or all-zero
position) are gaps. Positions in metres after reading.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from armtrack_cli.core.errors import GroundTruthError
from armtrack_cli.core.streams import MarkerTrajectories
from armtrack_cli.session.qualisys import MM, _header
from armtrack_cli.session.text_table import parse_table, read_text_lines

PER_BODY = 16  # X Y Z Roll Pitch Yaw Residual Rot[0..8]
EULER_ONLY = 6  # X Y Z Roll Pitch Yaw (an export without the matrix)


def is_6dof(keys: dict[str, list[str]]) -> bool:
    return "NO_OF_BODIES" in keys or "BODY_NAMES" in keys or \
        keys.get("DATA_INCLUDED", [""])[0].upper() == "6D"


def euler_qtm(roll_deg, pitch_deg, yaw_deg) -> np.ndarray:
    """(N, 3, 3) R = Rx(roll) Ry(pitch) Rz(yaw): QTM's default ("Qualisys standard")."""
    a, b, c = (np.deg2rad(np.asarray(v, dtype=float)) for v in (roll_deg, pitch_deg, yaw_deg))
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    one, zero = np.ones_like(a), np.zeros_like(a)
    Rx = np.stack([one, zero, zero, zero, ca, -sa, zero, sa, ca], -1).reshape(-1, 3, 3)
    Ry = np.stack([cb, zero, sb, zero, one, zero, -sb, zero, cb], -1).reshape(-1, 3, 3)
    Rz = np.stack([cc, -sc, zero, sc, cc, zero, zero, zero, one], -1).reshape(-1, 3, 3)
    return Rx @ Ry @ Rz


def _rotations(rot9: np.ndarray, euler: np.ndarray) -> tuple[np.ndarray, str]:
    """(N, 3, 3) from Rot[0..8] (N, 9): column-major unless only row-major fits the Euler."""
    col = np.swapaxes(rot9.reshape(-1, 3, 3), 1, 2)  # Rot[k] = R[k % 3, k // 3]
    ok = np.isfinite(rot9).all(axis=1) & np.isfinite(euler).all(axis=1)
    if not ok.any():
        return col, ""
    ref = euler_qtm(*euler[ok].T)
    err_col = np.abs(col[ok] - ref).max()
    err_row = np.abs(np.swapaxes(col[ok], 1, 2) - ref).max()
    if err_col > 0.02 and err_row < 0.02:
        return np.swapaxes(col, 1, 2), "Rot[0..8] read row by row (they match Roll/Pitch/Yaw so)"
    if err_col > 0.02:
        return col, "Roll/Pitch/Yaw are not QTM's default Euler definition: Rot[0..8] used"
    return col, ""


def read_qtm_6dof(path: str | Path) -> MarkerTrajectories:
    """Rigid bodies as MarkerTrajectories: names = BODY_NAMES, xyz = origins (m, lab frame),
    rotations = (N, B, 3, 3) body -> lab; NaN in gaps."""
    path = Path(path)
    lines = read_text_lines(path, GroundTruthError, "a Qualisys 6DOF TSV export")
    keys, at = _header(path, lines)
    names = tuple(keys.get("BODY_NAMES", []))
    if not names:
        raise GroundTruthError(path, "is a 6DOF export without BODY_NAMES",
                               "export it again from QTM (File > Export > TSV, 6D)")
    try:
        freq = float((keys.get("FREQUENCY") or [""])[0])
    except ValueError:
        freq = float("nan")
    if not np.isfinite(freq) or freq <= 0:
        raise GroundTruthError(path, "FREQUENCY is not a frame rate")
    if at >= len(lines):
        raise GroundTruthError(path, "has a header but no data (truncated export?)")
    b = len(names)
    has_row = lines[at].split("\t")[0].strip().lower() == "frame"
    if not has_row:
        n = len(lines[at].rstrip("\t\r\n").split("\t"))
        lines = lines[:at] + ["\t".join(f"c{k}" for k in range(n))] + lines[at:]
    tab = parse_table(path, lines, at, "\t", GroundTruthError)
    cols = [h.strip().lower() for h in tab.header]
    time_col = cols.index("time") if "time" in cols else None
    frame_col = cols.index("frame") if "frame" in cols else None
    per = next((k for k in (PER_BODY, EULER_ONLY) if tab.data.shape[1] - k * b in (0, 1, 2)), None)
    if per is None:
        raise GroundTruthError(path, f"is a 6DOF (rigid body) export with {tab.data.shape[1]} "
                               f"columns, which does not fit {b} bodies (BODY_NAMES) x "
                               f"{PER_BODY} (X Y Z Roll Pitch Yaw Residual Rot[0..8]) or x "
                               f"{EULER_ONLY} (X Y Z Roll Pitch Yaw)", "is BODY_NAMES complete?")
    first = tab.data.shape[1] - per * b
    if not has_row:
        frame_col, time_col = (0 if first >= 1 else None), (1 if first == 2 else None)
    block = tab.data[:, first:].reshape(-1, b, per)
    if per == EULER_ONLY:  # no Rot[] columns: the rotation from the angles, QTM's default
        rot9 = np.swapaxes(euler_qtm(*np.moveaxis(block[..., 3:6], -1, 0).reshape(3, -1)),
                           1, 2).reshape(-1, b, 9)
        block = np.concatenate([block, np.full(block.shape[:2] + (1,), np.nan), rot9], axis=2)
    xyz = block[..., 0:3] * MM
    gap = ~np.isfinite(xyz).all(axis=2) | np.all(block[..., 0:3] == 0, axis=2)
    xyz[gap] = np.nan
    rot = np.full(xyz.shape[:2] + (3, 3), np.nan)
    notes = []
    for k in range(b):
        R, note = _rotations(block[:, k, 7:16], block[:, k, 3:6])
        rot[:, k] = R
        if note:
            notes.append(f"{names[k]}: {note}")
    rot[gap] = np.nan
    if time_col is not None:
        t = tab.data[:, time_col] - tab.data[0, time_col]
    elif frame_col is not None:
        t = (tab.data[:, frame_col] - tab.data[0, frame_col]) / freq
    else:
        t = np.arange(xyz.shape[0]) / freq
    if not np.isfinite(t).all() or (np.diff(t) <= 0).any():
        raise GroundTruthError(path, "frame times are empty or do not increase")
    return MarkerTrajectories(str(path), t, names, xyz, freq, tuple(notes + list(tab.notes)),
                              rotations=rot)
