"""Where numba keeps armtrack's compiled kernels: one folder per version of their sources.

numba's own cache (``cache=True``) checks a kernel against the time stamp of the file that
defines it, not of the files whose kernels it calls: after a change to filters/splitmix.py
alone, fuse/pf_kernel.py's cached machine code would still draw with the old generator and
give numbers its source no longer gives. So armtrack points numba at a folder named by the
bytes of every module that defines a kernel (NUMBA_CACHE_DIR, unless the user set it): any
change to any of them starts a fresh cache (one compile, about 100 s), and checkouts with the
same kernels share one. Set at the package's import, before numba's; reading 16 small files
costs well under a millisecond and imports nothing.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1]
KERNEL_MODULES = (  # every module that imports numba (tests/test_kernel_cache.py keeps it so)
    "detect/camshift_kernel.py", "detect/palm_blob_i420.py", "detect/palm_blob_kernel.py",
    "detect/palm_blob_skin.py", "detect/patch_acquire_kernel.py", "detect/patch_kernel.py",
    "detect/yuv_pixel.py", "filters/fast_exp.py", "filters/splitmix.py",
    "fuse/association_kernel.py", "fuse/gaussian_kernel.py", "fuse/imu_error.py",
    "fuse/palm_kernel.py", "fuse/pf_kernel.py", "fuse/pf_resample_kernel.py",
    "fuse/smoother_kernel.py")


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
            os.environ["NUMBA_CACHE_DIR"] = str(cache_dir())
        except OSError:  # a kernel file unreadable: numba's own per-file cache, as before
            pass
