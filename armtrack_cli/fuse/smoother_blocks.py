"""The linearised smoother's pass (fuse/smoother_kernel.py) with memory flat in the session's
length: a checkpointed Rauch–Tung–Striebel smoother.

The plain pass keeps every frame's filtered covariance (n × d × d: 32 MB for a 10-minute session
at d = 15, and the model's F and Q as much again each) for the backward pass. Here the model is
built a block of frames at a time (``model``), the forward filter keeps only the state entering
each block (a checkpoint), and the backward pass, block by block from the last, runs the
filter again over the block from its checkpoint and smooths it from the next block's first
smoothed state. The second forward run repeats the first's arithmetic exactly, so the result
equals the plain pass (tests/test_smoother_blocks.py); it costs one more forward filter.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from armtrack_cli.fuse.smoother_kernel import filter_block, rts_block

BLOCK = 1024  # frames per block: ~2 MB of covariances at d = 15

# model(lo, hi) -> (F, b, Q, Hc, zc, use_c, Hk, zk, use_k) for frames lo … hi − 1 (row j is
# frame lo + j; F[j], b[j], Q[j] the step into it; row 0 of the session's first block unused);
# or those and ``real`` (rows,) bool when the model inserts rows of its own after a frame (the
# rest update's zero-velocity rows, fuse/rest.py): a block's first row is always its first
# frame's, and only the real rows are the frames
Model = Callable[[int, int], tuple]


def smooth_blocked(x0: np.ndarray, P0: np.ndarray, model: Model, n: int, *, rc: float,
                   rk: float, gate: float,
                   keep: Callable[[int, int, np.ndarray, np.ndarray], None],
                   block: int = BLOCK) -> np.ndarray:
    """Smooth frames 0 … n − 1 from the prior (x0, P0); ``keep(lo, hi, xs, Ps)`` receives
    the smoothed means (hi − lo, d) and covariances (hi − lo, d, d) of frames lo … hi − 1,
    from the last block back to the first (the arrays are reused: copy what is kept).
    Returns gated (n,) bool: the camera pairs the χ² gate kept out."""
    d = x0.size
    starts = list(range(0, n, block))
    check_x = np.empty((len(starts), d))
    check_P = np.empty((len(starts), d, d))
    buf = _Rows(d)
    gated = np.zeros(n, bool)
    x, P = np.asarray(x0, float), np.asarray(P0, float)
    for i, lo in enumerate(starts):  # forward: the checkpoints and the gate's decisions
        hi = min(lo + block, n)
        check_x[i], check_P[i] = x, P
        m, real = _split(model(lo, hi))
        xf, Pf, g = buf.take(m[0].shape[0])
        x, P = _filter(x, P, m, rc, rk, gate, lo == 0, m[0].shape[0], xf, Pf, g)
        gated[lo:hi] = g[:m[0].shape[0]] if real is None else g[:real.size][real]
    xs_next, Ps_next = np.zeros(d), np.zeros((d, d))
    for i in range(len(starts) - 1, -1, -1):  # backward, a block at a time
        lo = starts[i]
        hi = min(lo + block, n)
        m, real = _split(model(lo, min(hi + 1, n)))  # and the step into the next frame
        rows = _rows_of(real, hi - lo, m[0].shape[0], hi == n)
        xf, Pf, g = buf.take(m[0].shape[0])
        _filter(check_x[i], check_P[i], m, rc, rk, gate, lo == 0, rows, xf, Pf, g)
        F, b, Q = m[:3]
        rts_block(xf, Pf, rows, F, b, Q, xs_next, Ps_next, hi == n)
        if real is None:
            keep(lo, hi, xf[:rows], Pf[:rows])
        else:
            keep(lo, hi, xf[:rows][real[:rows]], Pf[:rows][real[:rows]])
        xs_next, Ps_next = xf[0].copy(), Pf[0].copy()
    return gated


def _split(m: tuple) -> tuple[tuple, np.ndarray | None]:
    """A model's arrays, and its ``real`` rows (None: every row a frame)."""
    return (m[:9], m[9]) if len(m) == 10 else (m, None)


def _rows_of(real: np.ndarray | None, frames: int, rows: int, last: bool) -> int:
    """The rows of a block's ``frames`` frames in a model of ``rows`` rows that also holds
    the next frame's (unless ``last``): all but that frame's rows."""
    if real is None:
        return frames
    return rows if last else int(np.flatnonzero(real)[frames])


class _Rows:
    """The filter's per-row buffers, grown to the largest block seen."""

    def __init__(self, d: int):
        self.d, self.cap = d, 0

    def take(self, rows: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if rows > self.cap:
            self.cap = max(rows, BLOCK)
            self.xf, self.Pf = np.empty((self.cap, self.d)), np.empty((self.cap, self.d, self.d))
            self.g = np.zeros(self.cap, bool)
        return self.xf, self.Pf, self.g


def _filter(x, P, m, rc, rk, gate, first, rows, xf, Pf, gated):
    F, b, Q, Hc, zc, use_c, Hk, zk, use_k = m
    return filter_block(x, P, F, b, Q, Hc, zc, use_c, rc, Hk, zk, use_k, rk, gate, first, rows,
                        xf, Pf, gated)
