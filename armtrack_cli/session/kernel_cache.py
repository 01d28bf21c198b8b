"""Where numba keeps armtrack's compiled kernels: one folder per version of their sources.

numba's own cache (``cache=True``) checks a kernel against the time stamp of the file that
defines it, not of the files whose kernels it calls: after a change to filters/splitmix.py
alone, fuse/pf_kernel.py's cached machine code would still draw with the old generator and
give numbers its source no longer gives. So armtrack points numba at a folder named by the
bytes of every module that defines a kernel (NUMBA_CACHE_DIR, unless the user set it): any
change to any of them starts a fresh cache (one compile, about 100 s), and checkouts with the
same kernels share one. Set at the package's import, before numba's; reading 16 small files
costs well under a millisecond and imports nothing.

Each version's folder is ~80 MB, so they are not kept for ever: the folder in use has its time
stamp renewed at every import, and when a new version's folder is first made, the other
versions' folders not used for STALE_DAYS are removed (one listing of ~/.cache/armtrack, only
then). A checkout that comes back after that compiles again, once.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import time
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1]
KERNEL_MODULES = (  # every module that imports numba (tests/test_kernel_cache.py keeps it so)
    "detect/camshift_kernel.py", "detect/palm_blob_i420.py", "detect/palm_blob_kernel.py",
    "detect/palm_blob_skin.py", "detect/patch_acquire_kernel.py", "detect/patch_kernel.py",
    "detect/yuv_pixel.py", "filters/fast_exp.py", "filters/splitmix.py",
    "fuse/association_kernel.py", "fuse/gaussian_kernel.py", "fuse/imu_error.py",
    "fuse/palm_kernel.py", "fuse/pf_guard_kernel.py", "fuse/pf_kernel.py",
    "fuse/path_kernel.py", "fuse/pf_resample_kernel.py", "fuse/projection_kernel.py",
    "fuse/smoother_kernel.py")
STALE_DAYS = 30  # a kernel folder not used for this long goes when a new one is made


def kernel_key() -> str:
    """16 hex digits over the kernel modules' names and bytes."""
    h = hashlib.sha256()
    for rel in KERNEL_MODULES:
        h.update(rel.encode())
        h.update((PACKAGE / rel).read_bytes())
    return h.hexdigest()[:16]


def cache_dir() -> Path:
    """$XDG_CACHE_HOME/armtrack/numba-KEY (~/.cache/… without XDG_CACHE_HOME)."""
    root = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(root) / "armtrack" / f"numba-{kernel_key()}"


def configure() -> None:
    """NUMBA_CACHE_DIR = cache_dir(), unless it is set already (by the user, or a bench that
    measures an empty cache)."""
    if "NUMBA_CACHE_DIR" not in os.environ:
        try:
            folder = cache_dir()
        except OSError:  # a kernel file unreadable: numba's own per-file cache, as before
            return
        os.environ["NUMBA_CACHE_DIR"] = str(folder)
        try:
            os.utime(folder)  # in use: renewed at every import
        except FileNotFoundError:  # a new version: numba makes the folder when it compiles
            prune(folder.parent, keep=folder.name)
        except OSError:  # read-only cache, another user's: numba copes or compiles in memory
            pass


def prune(root: Path, keep: str, now: float | None = None) -> list[Path]:
    """Remove root's numba-* folders other than ``keep`` whose time stamp is older than
    STALE_DAYS; returns those removed. Errors (a folder another process is using, no rights)
    leave the folder: pruning is housekeeping, never a reason to fail."""
    limit = (time.time() if now is None else now) - STALE_DAYS * 86400.0
    removed = []
    try:
        entries = list(os.scandir(root))
    except OSError:
        return removed
    for e in entries:
        try:
            if (e.name.startswith("numba-") and e.name != keep and e.is_dir(follow_symlinks=False)
                    and e.stat(follow_symlinks=False).st_mtime < limit):
                shutil.rmtree(e.path)
                removed.append(Path(e.path))
        except OSError:
            continue
    return removed
