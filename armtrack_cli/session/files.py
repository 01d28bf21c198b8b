"""Before a reader opens a file: it must be a regular file of a sane size. A FIFO would block
forever, /dev/zero would fill memory, a folder or a link loop would fail obscurely."""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

from armtrack_cli.core.errors import ArmtrackError


def regular_file(path: str | Path, error: type[ArmtrackError], what: str, *,
                 hint: str | None = None, max_bytes: int | None = None) -> Path:
    """``path`` if it is a regular file (links followed) no larger than ``max_bytes``; else
    ``error`` naming it and what it is instead. ``what`` says what was expected."""
    path = Path(path)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        if os.path.islink(path):
            raise error(path, "is a link to nothing", hint) from None
        raise error(path, "not found", hint) from None
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise error(path, "is a loop of symbolic links, not " + what) from None
        raise error(path, f"cannot be read ({exc.strerror})") from None
    if stat.S_ISDIR(st.st_mode):
        raise error(path, f"is a folder, not {what}", hint)
    if not stat.S_ISREG(st.st_mode):
        kind = ("a named pipe (FIFO)" if stat.S_ISFIFO(st.st_mode) else
                "a device" if stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode) else
                "a socket" if stat.S_ISSOCK(st.st_mode) else "not a regular file")
        raise error(path, f"is {kind}, not {what}", "give a regular file")
    if max_bytes is not None and st.st_size > max_bytes:
        raise error(path, f"is {st.st_size / 2**20:.0f} MiB, more than the "
                    f"{max_bytes / 2**20:.0f} MiB armtrack reads for {what}")
    return path


def read_small_text(path: str | Path, error: type[ArmtrackError], what: str, *,
                    hint: str | None = None) -> str:
    """A small UTF-8 text file (session.toml, a recipe, palm.toml) as a string."""
    from armtrack_cli.core.limits import MAX_SMALL_BYTES

    raw = regular_file(path, error, what, hint=hint, max_bytes=MAX_SMALL_BYTES).read_bytes()
    if b"\x00" in raw:
        raise error(path, f"is not a text file (binary), expected {what}")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise error(path, f"is not a text file (not UTF-8), expected {what}") from None


def misnamed_session_toml(folder: str | Path) -> str | None:
    """The name of a file in ``folder`` that was meant as its session.toml (Session.toml,
    session.toml.txt as Windows saves it, session (1).toml), or None: a folder of sessions
    must not skip it in silence."""
    try:
        names = os.listdir(folder)
    except OSError:
        return None
    if "session.toml" in names:
        return None
    near = sorted(n for n in names if n.lower().startswith("session") and ".toml" in n.lower())
    return near[0] if near else None
