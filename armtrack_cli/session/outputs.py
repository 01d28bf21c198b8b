"""Atomic writers: a temp file in the target folder, then rename. A failed run leaves nothing.

Tables are CSV with a sidecar ``NAME.meta.json`` holding the armtrack version, the command
and the resolved settings (no wall-clock time, so same inputs give byte-identical outputs).
"""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pandas as pd

from armtrack_cli import __version__
from armtrack_cli.core.errors import OutputError


def atomic_write(path: str | Path, write: Callable[[Path], None]) -> Path:
    """Call ``write(tmp_path)`` then rename tmp_path onto ``path``; clean up on failure."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(path.parent, f"cannot create the output folder ({exc.strerror})") from None
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        write(tmp_path)
        os.chmod(tmp_path, 0o666 & ~_umask())  # mkstemp makes 0600; outputs are shared data
        os.replace(tmp_path, path)
    except BaseException:
        tmp_path.unlink(missing_ok=True)
        raise
    return path


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


def _jsonable(o: Any) -> Any:
    if hasattr(o, "tolist"):
        return o.tolist()
    return str(o)


def write_table(path: str | Path, table: pd.DataFrame, *, command: str,
                settings: dict[str, Any] | None = None, float_format: str = "%.6f") -> Path:
    """CSV (NaN written as empty cells: missing, never zero) plus its provenance sidecar."""
    text = table.to_csv(index=False, float_format=float_format, lineterminator="\n")
    out = write_text(path, text)
    write_json(Path(path).with_suffix(".meta.json"),
               {"armtrack_version": __version__, "command": command, "settings": settings or {}})
    return out



def write_npz(path: str | Path, arrays: dict[str, Any]) -> Path:
    """Compressed numpy archive, written atomically."""
    import numpy as np

    return atomic_write(path, lambda p: np.savez_compressed(p, **arrays))


def staged_folder(final: str | Path, *, force: bool = False):
    """Context manager: a temp folder beside ``final`` renamed onto it when the block succeeds.

    A failed run leaves neither a half-written folder nor the temp folder behind.
    """
    import contextlib
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
