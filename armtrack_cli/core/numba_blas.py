"""numba's BLAS and LAPACK found without importing the scipy.linalg package (issue 15).

numba calls BLAS and LAPACK through scipy's Cython modules scipy.linalg.cython_blas and
scipy.linalg.cython_lapack. When its registries of compiled functions first load in a process
(the first kernel it runs or loads from its cache), numba.np.arraymath checks for BLAS with
``import scipy.linalg.cython_blas``, and that import runs the package first: all of
scipy.linalg, whose array-API layer copies numpy's namespace and so imports numpy.f2py
(0.13-0.24 s of fuse's and detect's kernel set-up, and ~130 modules, none of which they use).

``preload()`` loads the two extension modules from their files under their own names into
sys.modules, as the import system would, but without their package's ``__init__``: numba's
import, and its run-time look-up of each routine's address, find them there. Nothing else
changes: a later ``import scipy.linalg`` runs the package as usual, and its Cython modules
link against these same two (``from scipy.linalg import cython_blas`` finds them too; only
the package's attribute ``scipy.linalg.cython_blas`` is then not set). Where scipy.linalg is
already imported, or a file is not where scipy keeps it, it does nothing and numba imports
the package as before. Callers: fuse/kernel_setup.py and pipeline/detect.py, before their
first kernel.
"""

from __future__ import annotations

import importlib.machinery
import importlib.util
import sys
from pathlib import Path

MODULES = ("cython_blas", "cython_lapack")


def preload() -> list[str]:
    """Load MODULES from scipy/linalg/ into sys.modules (once a process); the names loaded."""
    if "scipy.linalg" in sys.modules:
        return []
    try:
        import scipy  # numba imports it at its own import: nothing more to pay
    except ImportError:
        return []
    folder = Path(scipy.__file__).parent / "linalg"
    loaded = []
    for name in MODULES:
        full = f"scipy.linalg.{name}"
        if full in sys.modules:
            continue
        path = next((folder / (name + suffix) for suffix in importlib.machinery.EXTENSION_SUFFIXES
                     if (folder / (name + suffix)).is_file()), None)
        if path is None:
            return loaded
        spec = importlib.util.spec_from_file_location(full, path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[full] = module
        try:
            spec.loader.exec_module(module)
        except Exception:  # noqa: BLE001 (numba then imports the package itself)
            del sys.modules[full]
            return loaded
        loaded.append(full)
    return loaded
