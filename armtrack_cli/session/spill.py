"""Session-long columns kept on disk instead of in memory (issue 15's flat memory): a stage
appends its per-frame results a window at a time and reads back the rows a later step needs,
a window at a time, exactly as written (raw binary, no text round trip).

The files live in a hidden temp folder inside the stage's output folder (never /tmp, which
may be memory), removed when the spill is closed, also after a failure or an interrupt."""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import numpy as np


class Spill:
    """Named columns, each (N,) or (N, k) of one dtype, appended block by block (every column
    the same number of rows per block) and read back by row range.

        with Spill(folder) as sp:
            for window in …: sp.append({"t": t, "wrist": p})
            rows = sp.read(lo, hi)     # {"t": (hi-lo,), "wrist": (hi-lo, 3)}
    """

    def __init__(self, folder: str | Path) -> None:
        Path(folder).mkdir(parents=True, exist_ok=True)
        self.path = Path(tempfile.mkdtemp(prefix=".spill-", dir=folder))
        self.n = 0
        self._layout: dict[str, tuple[np.dtype, tuple[int, ...]]] = {}

    def __len__(self) -> int:
        return self.n

    def __enter__(self) -> Spill:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        shutil.rmtree(self.path, ignore_errors=True)

    def append(self, block: dict[str, np.ndarray]) -> None:
        """Rows appended to every column; the first block fixes the names, dtypes and shapes."""
        arrays = {k: np.ascontiguousarray(v) for k, v in block.items()}
        rows = {a.shape[0] for a in arrays.values()}
        layout = {k: (a.dtype, a.shape[1:]) for k, a in arrays.items()}
        if len(rows) != 1 or (self._layout and layout != self._layout):
            raise ValueError("a spill's blocks need the same columns, each with the same rows")
        self._layout = self._layout or layout
        for k, a in arrays.items():
            with open(self.path / k, "ab") as f:
                f.write(a.tobytes())
        self.n += rows.pop()

    def read(self, lo: int = 0, hi: int | None = None,
             names: tuple[str, ...] | None = None) -> dict[str, np.ndarray]:
        """Rows [lo, hi) of the columns ``names`` (all by default), as new arrays."""
        hi = self.n if hi is None else min(hi, self.n)
        lo = max(0, min(lo, hi))
        out = {}
        for k in names or tuple(self._layout):
            dtype, shape = self._layout[k]
            per_row = int(np.prod(shape, dtype=int))
            a = np.fromfile(self.path / k, dtype=dtype, count=(hi - lo) * per_row,
                            offset=lo * per_row * dtype.itemsize) if hi > lo else \
                np.empty(0, dtype)
            out[k] = a.reshape((hi - lo, *shape))
        return out
