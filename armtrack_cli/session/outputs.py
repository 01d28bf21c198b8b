"""Atomic writers: a temp file in the target folder, then rename. A failed run leaves nothing.

Tables are CSV with a sidecar ``NAME.meta.json`` holding the armtrack version, the command
and the resolved settings (no wall-clock time, so same inputs give byte-identical outputs).
"""

from __future__ import annotations

import contextlib
import contextvars
import errno
import json
import os
import re
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from armtrack_cli import __version__
from armtrack_cli.core.errors import OutputError

if TYPE_CHECKING:
    import pandas as pd

_STAGED: contextvars.ContextVar[list | None] = contextvars.ContextVar("staged", default=None)


def atomic_write(path: str | Path, write: Callable[[Path], None]) -> Path:
    """Call ``write(tmp_path)`` then rename tmp_path onto ``path``; clean up on failure.
    Inside ``output_set()`` the rename waits for the whole set."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=path.suffix, dir=path.parent)
        os.close(fd)
    except OSError as exc:
        raise OutputError(path.parent, f"cannot write into the output folder ({exc.strerror})",
                          _hint(exc)) from None
    tmp_path = Path(tmp)
    try:
        write(tmp_path)
        os.chmod(tmp_path, 0o666 & ~_umask())  # mkstemp makes 0600; outputs are shared data
        staged = _STAGED.get()
        if staged is None:
            os.replace(tmp_path, path)
        else:
            staged.append((tmp_path, path))
    except OSError as exc:
        tmp_path.unlink(missing_ok=True)
        raise OutputError(path, f"could not be written ({exc.strerror})", _hint(exc)) from None
    except BaseException:
        tmp_path.unlink(missing_ok=True)
        raise
    return path


def _hint(exc: OSError) -> str | None:
    return {errno.ENOSPC: "free some disk space and run again",
            errno.EACCES: "choose a folder you may write to (--out)",
            errno.EROFS: "choose a folder you may write to (--out)"}.get(exc.errno)


@contextlib.contextmanager
def output_set():
    """A stage's outputs (data, meta, kinematics) appear together or not at all: writes in
    the block are staged beside their targets and renamed into place when it ends; a failure
    or an interrupt anywhere in it removes every staged file and leaves the targets as they
    were."""
    staged: list[tuple[Path, Path]] = []
    token = _STAGED.set(staged)
    try:
        yield
    except BaseException:
        for tmp, _ in staged:
            tmp.unlink(missing_ok=True)
        raise
    finally:
        _STAGED.reset(token)
    for tmp, final in staged:  # renames within one folder: no bytes move, nothing can fill
        os.replace(tmp, final)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_bytes(path: str | Path, data: bytes) -> Path:
    return atomic_write(path, lambda p: p.write_bytes(data))


def write_text(path: str | Path, text: str) -> Path:
    return write_bytes(path, text.encode("utf-8"))


def write_json(path: str | Path, obj: Any) -> Path:
    return write_text(path, json.dumps(obj, indent=2, sort_keys=True, default=_jsonable) + "\n")


def write_provenance(path: str | Path, command: str, settings: dict[str, Any] | None) -> Path:
    """A table's sidecar NAME.meta.json: the armtrack version, the command and the settings
    that made it."""
    return write_json(Path(path).with_suffix(".meta.json"),
                      {"armtrack_version": __version__, "command": command,
                       "settings": settings or {}})


def _jsonable(o: Any) -> Any:
    if hasattr(o, "tolist"):
        return o.tolist()
    return str(o)


def write_table(path: str | Path, table: pd.DataFrame, *, command: str,
                settings: dict[str, Any] | None = None, float_format: str = "%.6f") -> Path:
    """CSV (NaN written as empty cells: missing, never zero) plus its provenance sidecar,
    written to the file a block of rows at a time: the text of a long table is never held
    whole (a 60-minute trajectory's is ~30 MB, its str, join and bytes three times that)."""
    def write(p: Path) -> None:
        with open(p, "w", encoding="utf-8", newline="") as f:
            if _all_float(table):
                f.writelines(_float_csv(table, float_format))
            else:  # pandas writes a chunk of rows at a time to a file
                table.to_csv(f, index=False, float_format=float_format, lineterminator="\n")

    out = atomic_write(path, write)
    write_provenance(path, command, settings)
    return out


def write_rows(path: str | Path, rows: list[dict[str, Any]], *, command: str,
               settings: dict[str, Any] | None = None, float_format: str = "%.6f",
               columns: tuple[str, ...] | list[str] | None = None) -> Path:
    """write_table(pd.DataFrame(rows, columns=columns)) without pandas, byte for byte: each
    column typed as the DataFrame would type it (text, integers, or floats written with
    float_format, NaN as an empty cell), cells quoted by the csv module as pandas quotes
    them. A table it cannot type so (a column mixing text and numbers, a missing key, no
    rows) goes to write_table itself."""
    import csv
    import io
    import math

    names = list(columns) if columns is not None else list(rows[0]) if rows else []
    cols = [[r.get(n) for r in rows] for n in names] if all(set(r) == set(names)
                                                          for r in rows) else None
    kinds = [_kind(c) for c in cols] if cols and rows else None
    if kinds is None or None in kinds:
        import pandas as pd

        return write_table(path, pd.DataFrame(rows, columns=columns), command=command,
                           settings=settings, float_format=float_format)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(names)
    fmt = [(lambda v: "" if math.isnan(v) else float_format % v) if k == "f" else str
           for k in kinds]
    for i in range(len(rows)):
        w.writerow([f(c[i]) for f, c in zip(fmt, cols)])
    out = write_text(path, buf.getvalue())
    write_provenance(path, command, settings)
    return out


def _kind(cells: list) -> str | None:
    """"s" text, "i" integers, "f" numbers with a float among them; None otherwise."""
    import numbers

    if all(isinstance(c, str) for c in cells):
        return "s"
    if any(isinstance(c, bool) or not isinstance(c, numbers.Real) for c in cells):
        return None
    return "i" if all(isinstance(c, numbers.Integral) for c in cells) else "f"


def _all_float(table: pd.DataFrame) -> bool:
    """Every column float64 and every name plain (nothing a CSV would quote)."""
    return (len(table.columns) > 0 and all(str(d) == "float64" for d in table.dtypes)
            and not any(set(str(c)) & set(',"\n\r') for c in table.columns))


def _float_csv(table: pd.DataFrame, float_format: str) -> Iterator[str]:
    """What pandas' to_csv(index=False, float_format=…) writes for an all-float table."""
    cols = [table.iloc[:, j].to_numpy() for j in range(table.shape[1])]
    return column_lines(list(map(str, table.columns)), cols, [float_format] * len(cols))


def column_lines(names: list[str], cols: list, formats: list[str]) -> Iterator[str]:
    """CSV text of equal-length (N,) columns, one % format each: the header, then a block of
    rows at a time (one % per row instead of one per cell; each block's numbers copied out of
    the columns alone: bounded however long the table), NaN as an empty cell (missing)."""
    row = ",".join(formats) + "\n"
    yield ",".join(names) + "\n"
    for lo in range(0, len(cols[0]) if cols else 0, CSV_BLOCK):
        block = [c[lo:lo + CSV_BLOCK].tolist() for c in cols]
        text = "".join(row % r for r in zip(*block))
        yield _NAN_CELL.sub("", text) if "nan" in text else text  # (the search: ~1 % of the
        #                                                           substitution's time)


CSV_BLOCK = 4096  # rows formatted and written at once
_NAN_CELL = re.compile(r"(?<![^,\n])nan(?![^,\n])")  # a whole cell "nan"


def write_npz(path: str | Path, arrays: dict[str, Any]) -> Path:
    """Compressed numpy archive, written atomically."""
    import numpy as np

    return atomic_write(path, lambda p: np.savez_compressed(p, **arrays))


def staged_folder(final: str | Path, *, force: bool = False):
    """Context manager: a temp folder beside ``final`` renamed onto it when the block succeeds.

    A failed run leaves neither a half-written folder nor the temp folder behind.
    """
    import shutil

    final = Path(final)
    if final.exists() and not force:
        raise OutputError(final, "already exists", "choose another OUT or pass --force")

    @contextlib.contextmanager
    def _stage():
        final.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{final.name}.", dir=final.parent))
        os.chmod(tmp, 0o777 & ~_umask())
        try:
            yield tmp
            if final.exists():
                shutil.rmtree(final)
            os.replace(tmp, final)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise

    return _stage()
