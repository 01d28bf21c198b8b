"""numba's BLAS and LAPACK found without importing the scipy.linalg package (issue 15).

numba calls BLAS and LAPACK through scipy's Cython modules scipy.linalg.cython_blas and
scipy.linalg.cython_lapack. When its registries of compiled functions first load in a process
(the first kernel it runs or loads from its cache), numba.np.arraymath checks for BLAS with
``import scipy.linalg.cython_blas``, and that import runs the package first: all of
scipy.linalg, whose array-API layer copies numpy's namespace and so imports numpy.f2py
(0.13-0.3 s of fuse's and detect's kernel set-up, ~130 modules none of which they use, and
~11 MB of fuse's peak memory on long-10).

``preload()`` finds the two extension modules as the import system would (its own path
finder, in scipy's linalg folder) and loads them under their own names into sys.modules,
without their package's ``__init__``: numba's import, and its run-time look-up of each
routine's address, find them there. Nothing else changes: a later ``import scipy.linalg``
runs the package as usual, and its Cython modules link against these same two (``from
scipy.linalg import cython_blas`` finds them too; only the package's attribute
``scipy.linalg.cython_blas`` is then not set). Where scipy.linalg is already imported, or a
module is not where scipy keeps it, it does nothing and numba imports the package as before.
Callers: fuse/kernel_setup.py and pipeline/detect.py, before their first kernel.
"""

from __future__ import annotations

import importlib.machinery
import importlib.util
import os
import sys

MODULES = ("cython_blas", "cython_lapack")


def preload() -> list[str]:
    """Load MODULES of scipy/linalg/ into sys.modules (once a process); the names loaded."""
    if "scipy.linalg" in sys.modules:
        return []
    try:
        import scipy  # numba imports it at its own import: nothing more to pay
    except ImportError:
        return []
    folders = [os.path.join(p, "linalg") for p in scipy.__path__]
    loaded = []
    for name in MODULES:
        full = f"scipy.linalg.{name}"
        if full in sys.modules:
            continue
        spec = importlib.machinery.PathFinder.find_spec(full, folders)  # the import system's
        if spec is None or spec.loader is None:  #                         own search
            return loaded
        module = importlib.util.module_from_spec(spec)
        sys.modules[full] = module
        try:
            spec.loader.exec_module(module)
        except Exception:  # noqa: BLE001 (numba then imports the package itself)
            del sys.modules[full]
            return loaded
        loaded.append(full)
    return loaded
