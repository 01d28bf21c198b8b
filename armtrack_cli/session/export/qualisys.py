"""Write Qualisys Track Manager 3-D TSV exports (the simulator's ground truth; tests)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from armtrack_cli.session.outputs import write_text


def format_qtm_tsv(xyz_m: np.ndarray, names: list[str], rate_hz: float, *,
                   frame_time_row: bool = True, gap: str = "", crlf: bool = False,
                   trailing_tab: bool = False) -> str:
    """Text of a QTM 3D export. xyz_m: (N, M, 3) metres in the QTM frame, NaN = gap.

    gap: what a missing marker is written as ("" empty cells, "NaN", or "0.000").
    """
    n, m, _ = xyz_m.shape
    head = [f"NO_OF_FRAMES\t{n}", "NO_OF_CAMERAS\t8", f"NO_OF_MARKERS\t{m}",
            f"FREQUENCY\t{rate_hz:g}", "NO_OF_ANALOG\t0", "ANALOG_FREQUENCY\t0",
            "DESCRIPTION\t--", "TIME_STAMP\t2026-11-20, 10:15:00.000\t0.000",
            "DATA_INCLUDED\t3D", "MARKER_NAMES\t" + "\t".join(names),
            "TRAJECTORY_TYPES\t" + "\t".join(["Measured"] * m)]
    rows = []
    if frame_time_row:
        rows.append("\t".join(["Frame", "Time"] + [f"{nm} {a}" for nm in names for a in "XYZ"]))
    mm = xyz_m * 1000.0
    for i in range(n):
        cells = [str(i + 1), f"{i / rate_hz:.5f}"] if frame_time_row else []
        for k in range(m):
            p = mm[i, k]
            cells += [gap] * 3 if np.isnan(p).any() else [f"{v:.3f}" for v in p]
        rows.append("\t".join(cells) + ("\t" if trailing_tab else ""))
    eol = "\r\n" if crlf else "\n"
    return eol.join(head + rows) + eol


def write_qtm_tsv(path: str | Path, *args, **kwargs) -> Path:
    return write_text(path, format_qtm_tsv(*args, **kwargs))
