"""The linearised smoother's pass (fuse/smoother_kernel.py) with memory flat in the session's
length: a checkpointed Rauch–Tung–Striebel smoother with a bounded store.

The plain pass keeps every frame's filtered covariance (n × d × d: 32 MB for a 10-minute session
at d = 15, and the model's F and Q as much again each) for the backward pass. Here the model is
built a block of frames at a time (``model``), the forward filter keeps the state entering
each block (a checkpoint) and the filtered states of the latest blocks that fit in STORE_MB
(each covariance by its upper triangle: it is symmetric to the bit, _symmetrise), and the
backward pass, block by block from the last, smooths each block from the next block's first
smoothed state: from the store where it holds the block, else after running the filter again
over it from its checkpoint (the same arithmetic as the first run, so the result equals the
plain pass either way: tests/test_smoother_blocks.py). The store holds about 7,700 rows at
d = 15 (a third of a 10-minute session's; a larger one raised fuse's peak, the measures' after
the smoother, by as much): the filter runs again only over the blocks before those, and the
memory stays the store's however long the session.
"""

from __future__ import annotations

import mmap
from collections.abc import Callable

import numpy as np

from armtrack_cli.core import threads
from armtrack_cli.fuse.smoother_kernel import filter_block, rts_block

BLOCK = 1024  # frames per block: ~2 MB of covariances at d = 15
STORE_MB = 8  # the filtered states kept for the backward pass, at most (a third of a
#              10-minute session's: more would raise fuse's peak, measures' at the end)

# model(lo, hi) -> (F, b, Q, Hc, zc, use_c, Hk, zk, use_k) for frames lo … hi − 1 (row j is
# frame lo + j; F[j], b[j], Q[j] the step into it; row 0 of the session's first block unused);
# or those and ``real`` (rows,) bool when the model inserts rows of its own after a frame (the
# rest update's zero-velocity rows, fuse/rest.py): a block's first row is always its first
# frame's, and only the real rows are the frames; model(lo, hi, steps_only=True): (F, b, Q)
# alone (and ``real``), all that the backward pass needs of a block the store kept
Model = Callable[[int, int], tuple]


def smooth_blocked(x0: np.ndarray, P0: np.ndarray, model: Model, n: int, *, rc: float,
                   rk: float, gate: float,
                   keep: Callable[[int, int, np.ndarray, np.ndarray], None],
                   block: int = BLOCK, store_mb: float = STORE_MB) -> np.ndarray:
    """Smooth frames 0 … n − 1 from the prior (x0, P0); ``keep(lo, hi, xs, Ps)`` receives
    the smoothed means (hi − lo, d) and covariances (hi − lo, d, d) of frames lo … hi − 1,
    from the last block back to the first (the arrays are reused: copy what is kept).
    Returns gated (n,) bool: the camera pairs the χ² gate kept out."""
    d = x0.size
    starts = list(range(0, n, block))
    check_x = np.empty((len(starts), d))
    check_P = np.empty((len(starts), d, d))
    bufs, store = (_Rows(d), _Rows(d)), _Store(d, store_mb)
    gated = np.zeros(n, bool)
    x, P = np.asarray(x0, float), np.asarray(P0, float)
    beside = threads.Deferred if threads.spare_core() else threads.now  # else one thread
    # forward: checkpoints, the gate's decisions, the store; each block's filter (a compiled
    # kernel that holds no GIL) here while a second thread builds the next block's model (the
    # kernel never waits for the GIL to start: core/threads.py)
    ahead = threads.Done(model(0, min(block, n)))
    for i, lo in enumerate(starts):
        hi = min(lo + block, n)
        check_x[i], check_P[i] = x, P
        m, real = _split(ahead.result(), 9)
        rows = m[0].shape[0]
        xf, Pf, g = bufs[0].take(rows)
        ahead = beside(model, hi, min(hi + block, n)) if hi < n else None
        x, P = _filter(x, P, m, rc, rk, gate, lo == 0, rows, xf, Pf, g)
        gated[lo:hi] = g[:rows] if real is None else g[:real.size][real]
        store.put(i, xf[:rows], Pf[:rows])
    # backward, a block at a time: its filter (unless stored) and RTS here while a second
    # thread hands the block before to ``keep`` and builds the next one's model (two buffers:
    # ``keep`` reads one while the kernels write the other)
    xs_next, Ps_next, done = np.zeros(d), np.zeros((d, d)), None
    ahead = threads.Done(_backward_model(model, starts, len(starts) - 1, block, n, store))
    for i in range(len(starts) - 1, -1, -1):
        lo = starts[i]
        hi = min(lo + block, n)
        kept, m, real = ahead.result()
        rows = _rows_of(real, hi - lo, m[0].shape[0], hi == n)
        xf, Pf, g = bufs[i % 2].take(m[0].shape[0])
        if kept:
            store.take(i, xf, Pf)
        ahead = beside(_kept_and_ahead, keep, done, model, starts, i - 1, block, n, store)
        _smooth_block(None if kept else (check_x[i], check_P[i]), m, rc, rk, gate, lo == 0,
                      rows, xf, Pf, g, xs_next, Ps_next, hi == n)
        done = (lo, hi, xf, Pf, rows, real)
        xs_next, Ps_next = xf[0].copy(), Pf[0].copy()
    ahead.result()
    if done is not None:
        _keep(keep, *done)
    return gated


def _kept_and_ahead(keep, done: tuple | None, model: Model, starts: list[int], i: int,
                    block: int, n: int, store: _Store) -> tuple | None:
    """The backward pass's second thread: the block smoothed last (``done``) to ``keep``, then
    block i's model (_backward_model; None before the first block)."""
    if done is not None:
        _keep(keep, *done)
    return _backward_model(model, starts, i, block, n, store) if i >= 0 else None


def _backward_model(model: Model, starts: list[int], i: int, block: int, n: int,
                    store: _Store) -> tuple:
    """(kept, model arrays, real) of block i for the backward pass: the steps alone when the
    store holds its filtered states, else everything its filter needs; with the step into the
    next frame."""
    lo = starts[i]
    hi = min(lo + block, n)
    kept = i in store.blocks  # else filtered again from the checkpoint
    m, real = _split(model(lo, min(hi + 1, n), steps_only=kept), 3 if kept else 9)
    return kept, m, real


def _smooth_block(start, m, rc, rk, gate, first, rows, xf, Pf, g, xs_next, Ps_next, last):
    """A block's filter from its checkpoint ``start`` = (x, P) (None: xf, Pf hold it already,
    from the store), then its RTS pass from the next block's first smoothed state."""
    if start is not None:
        _filter(*start, m, rc, rk, gate, first, rows, xf, Pf, g)
    F, b, Q = m[:3]
    rts_block(xf, Pf, rows, F, b, Q, xs_next, Ps_next, last)


def _keep(keep, lo: int, hi: int, xf: np.ndarray, Pf: np.ndarray, rows: int,
          real: np.ndarray | None) -> None:
    if real is None:
        keep(lo, hi, xf[:rows], Pf[:rows])
    else:
        keep(lo, hi, xf[:rows][real[:rows]], Pf[:rows][real[:rows]])


class _Store:
    """The filtered states (x, P's upper triangle) of the latest blocks, at most ``mb`` MB: a
    ring of rows in two arrays (pages touched only as rows are written, all returned at once
    when the pass ends); putting a block drops the earliest ones it would overwrite."""

    def __init__(self, d: int, mb: float):
        self.iu = np.triu_indices(d)
        self.cap = int(mb * 2**20 / (8 * (d + self.iu[0].size)))  # rows
        self.x, self.tri = _returned((self.cap, d)), _returned((self.cap, self.iu[0].size))
        self.blocks: dict[int, tuple[int, int]] = {}  # block: (first row, rows), in the order put
        self.head = self.used = 0

    def put(self, i: int, xf: np.ndarray, Pf: np.ndarray) -> None:
        k = xf.shape[0]
        if k > self.cap:
            return
        while self.used + k > self.cap:  # the earliest blocks lie just after the latest
            self.used -= self.blocks.pop(next(iter(self.blocks)))[1]
        rows = (self.head + np.arange(k)) % self.cap
        self.x[rows], self.tri[rows] = xf, Pf[:, self.iu[0], self.iu[1]]
        self.blocks[i] = self.head, k
        self.head, self.used = (self.head + k) % self.cap, self.used + k

    def take(self, i: int, xf: np.ndarray, Pf: np.ndarray) -> None:
        """Block i's states into xf, Pf (the backward pass: nothing is put after)."""
        first, k = self.blocks.pop(i)
        rows = (first + np.arange(k)) % self.cap
        xf[:k] = self.x[rows]
        tri = self.tri[rows]
        Pf[:k, self.iu[0], self.iu[1]] = tri
        Pf[:k, self.iu[1], self.iu[0]] = tri


def _returned(shape: tuple[int, int]) -> np.ndarray:
    """An array in its own anonymous mapping: its pages are the operating system's again when
    it is freed (from malloc's heap, a freed store stayed in the process's memory)."""
    n = shape[0] * shape[1] * 8
    if n == 0:
        return np.empty(shape)
    return np.frombuffer(mmap.mmap(-1, n), dtype=np.float64).reshape(shape)


def _split(m: tuple, size: int) -> tuple[tuple, np.ndarray | None]:
    """A model's ``size`` arrays, and its ``real`` rows (None: every row a frame)."""
    return (m[:size], m[size]) if len(m) == size + 1 else (m, None)


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
