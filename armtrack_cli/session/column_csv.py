"""A table of numeric columns written as CSV block by block (issue 15): the bytes
outputs.write_table writes for the same columns as a DataFrame (integers as integers, floats
with float_format, NaN as an empty cell), without a DataFrame or the table's whole text in
memory (a 60-minute detections.csv, 108,000 rows, took ~30 MB more through pandas); and, with
write_column_blocks, without the whole table either: a long session's rows written as a stage
makes them, a window at a time."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from armtrack_cli.session.outputs import atomic_write, column_lines, write_provenance


def write_columns(path: str | Path, columns: dict[str, np.ndarray], *, command: str,
                  settings: dict[str, Any] | None = None, float_format: str = "%.6f") -> Path:
    """CSV of ``columns`` (name -> (N,) integer or float array, all the same length) plus its
    provenance sidecar, as write_table(pd.DataFrame(columns), …) writes them."""
    return write_column_blocks(path, [columns], command=command, settings=settings,
                               float_format=float_format)


def write_column_blocks(path: str | Path, blocks: Iterable[dict[str, np.ndarray]], *,
                        command: str, settings: dict[str, Any] | Callable[[], dict] | None = None,
                        float_format: str = "%.6f") -> Path:
    """CSV of the rows of ``blocks`` one after another (each: name -> (N_i,) integer or float
    array, the same names in the same order and the same kinds in every block; a block is
    formatted and written before the next is asked for), plus its provenance sidecar:
    the bytes write_columns writes for the blocks joined. ``settings`` may be a function,
    called once every block is written (a stage's summary known only then). Atomic, as every
    output: a failure while the blocks are made leaves nothing (outputs.atomic_write)."""
    def write(p: Path) -> None:
        with open(p, "w", encoding="utf-8", newline="") as f:
            f.writelines(_lines(iter(blocks), float_format))

    out = atomic_write(path, write)
    write_provenance(path, command, settings() if callable(settings) else settings)
    return out


def _lines(blocks: Iterator[dict[str, np.ndarray]], float_format: str) -> Iterator[str]:
    """The header from the first block, then every block's rows."""
    first = next(blocks, None)
    if first is None:
        raise ValueError("write_column_blocks needs one block at least")  # an internal misuse
    names, formats = _layout(first, float_format)
    block, header = first, True
    while block is not None:
        cols = [np.asarray(c) for c in block.values()]
        if list(block) != names or _layout(block, float_format)[1] != formats:
            raise ValueError("every block of write_column_blocks needs the first's columns")
        lines = column_lines(names, cols, formats)
        if not header:
            next(lines)  # the header once, from the first block
        yield from lines
        block, header = next(blocks, None), False


def _layout(columns: dict[str, np.ndarray], float_format: str) -> tuple[list[str], list[str]]:
    """The names and % formats of a block's columns, checked: plainly named integer or float
    columns of one length."""
    names = list(columns)
    cols = [np.asarray(c) for c in columns.values()]
    kinds = [c.dtype.kind for c in cols]
    if not names or any(k not in "iuf" for k in kinds) or len({len(c) for c in cols}) > 1 \
            or any(set(n) & set(',"\n\r') for n in names):
        raise ValueError("write_columns takes plainly named integer and float columns of one "
                         "length")  # an internal misuse, never the user's data
    return names, ["%d" if k in "iu" else float_format for k in kinds]
