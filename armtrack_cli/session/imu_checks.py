"""Checks every IMU reader shares: unit quaternions, and the rate and dropped samples of a
stream from its times."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from armtrack_cli.core.errors import ImuFileError
from armtrack_cli.core.streams import time_gaps

NORM_TOLERANCE = 0.05
BLOCK_ROWS = 65_536  # temporaries of this many rows at a time (issue 15)


def unit_quaternions(path: Path, q: np.ndarray, where: Callable[[int], str], what: str,
                     hint: str) -> np.ndarray:
    """q normalised in place (the reader's own array, no copy of a long recording: issue 15)
    and returned, as quat.normalize computes it; an error naming the first row whose norm is
    off by more than 5 % (a mislabelled or scaled column, not round-off). NaN rows stay NaN."""
    norm = np.empty(q.shape[0])
    with np.errstate(over="ignore", invalid="ignore"):
        for a in range(0, q.shape[0], BLOCK_ROWS):  # its squares a block at a time
            norm[a:a + BLOCK_ROWS] = np.linalg.norm(q[a:a + BLOCK_ROWS], axis=1)
    bad = np.isfinite(q).all(axis=1) & ~(np.abs(norm - 1.0) <= NORM_TOLERANCE)
    if bad.any():
        r = int(np.flatnonzero(bad)[0])
        raise ImuFileError(path, f"{where(r)}: {what} has norm {norm[r]:.3f}, not 1", hint)
    return np.divide(q, norm[:, None], out=q)


def rate_and_dropped(t: np.ndarray) -> tuple[float, int]:
    """Nominal rate (1 / median step) and the samples missing in the gaps between times."""
    dt = nominal_step(np.diff(t))
    gaps = time_gaps(t, dt)
    return 1.0 / dt, int(np.sum(np.round(np.diff(t)[gaps] / dt) - 1))


def nominal_step(steps: np.ndarray) -> float:
    """The stream's nominal sample period: its median step (1 s when it has none)."""
    return float(np.median(steps)) if steps.size else 1.0
