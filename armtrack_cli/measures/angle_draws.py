"""The angle measures of many posterior draws at once (table.py's uncertainty): each angle's
series for a block of draws (c, N) in one pass through angles.py, then the range of motion
of every draw (angles.rom_rows), NaN where a draw's measure is not computable. The same
arithmetic as table.angle_values on one draw at a time (tests/test_measure_draws.py holds
them to it): without it, a 10-minute session's 40 draws were 40 passes of a dozen small
calls per angle."""

from __future__ import annotations

import numpy as np

from armtrack_cli.measures import angles
from armtrack_cli.measures.base import Settings

WRIST = ("wrist_flexion", "wrist_deviation", "wrist_pronation")


def angle_series_rows(wrist: np.ndarray | None, elbow: np.ndarray | None,
                      shoulder: np.ndarray | None, wrist_angles: np.ndarray | None, side: str,
                      s: Settings) -> dict[str, np.ndarray]:
    """table.angle_series of c draws (the IMU's pronation aside: it has no posterior): positions
    (c, N, 3) m, the shoulder (3,) or (N, 3), wrist angles (c, N, 3) deg -> name -> (c, N)."""
    out: dict[str, np.ndarray] = {}
    if elbow is not None and shoulder is not None:
        sh = np.broadcast_to(shoulder, elbow.shape)
        out["elbow_flexion"] = angles.elbow_flexion_deg(sh, elbow, wrist)
        out["shoulder_elevation"], out["shoulder_plane"] = angles.shoulder_angles_deg(
            sh, elbow, side, s)
    if wrist_angles is not None:
        for k, name in enumerate(WRIST):
            out[name] = wrist_angles[..., k]
    return out


def angle_draws(inp, ew: np.ndarray | None, ea: np.ndarray | None, s: Settings
                ) -> dict[tuple[str, str], np.ndarray]:
    """{(ANGLE_rom…, "session"): (c,)} of c draws: the wrist's error ew (c, N, 3) m moves the
    wrist and the elbow alike (the elbow is the wrist moved by a known vector), ea (c, N, 3)
    deg the wrist angles; None: that input as estimated in every draw. ``inp``: table.Inputs."""
    c = (ew if ew is not None else ea).shape[0]

    def moved(x, e):
        if x is None:
            return None
        return np.broadcast_to(x, (c, *x.shape)) if e is None else x[None] + e

    series = angle_series_rows(moved(inp.wrist, ew), moved(inp.elbow, ew), inp.shoulder,
                               moved(inp.wrist_angles, ea), inp.side, s)
    out = {}
    for name, x in series.items():
        for k, v in angles.rom_rows(x).items():
            out[(f"{name}_{k}", "session")] = v
    return out
