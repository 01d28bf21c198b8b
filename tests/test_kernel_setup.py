"""fuse/kernel_setup.py loads the arm smoother's passes with the argument types the smoother
itself gives them (fuse/smoother_blocks.py), so that the timed run loads nothing more: each
pass's numba types from load_kernels against those from smooth_blocked on a small model."""

from __future__ import annotations

import numpy as np
from numba import typeof

from armtrack_cli.fuse import kernel_setup, smoother_blocks, smoother_kernel
from tests.test_smoother_blocks import _blocked, _random_problem


def _recording(monkeypatch, module, seen):
    for name in ("filter_block", "rts_block"):
        f = getattr(module, name)

        def record(*args, f=f, name=name):
            seen.setdefault(name, set()).add(tuple(typeof(a) for a in args))
            return f(*args)

        monkeypatch.setattr(module, name, record)


def test_arm_smoother_passes_load_with_the_smoothers_types(monkeypatch):
    loaded, run = {}, {}
    _recording(monkeypatch, smoother_kernel, loaded)  # load_kernels imports them from here
    _recording(monkeypatch, smoother_blocks, run)
    kernel_setup._load_smoother_passes()
    x0, P0, arrays = _random_problem(np.random.default_rng(5), n=40)
    _blocked(x0, P0, arrays, 0.3, 0.2, 9.0, block=16)
    assert set(loaded) == set(run) == {"filter_block", "rts_block"}
    for name in run:
        assert len(loaded[name]) == 1 and loaded[name] == run[name], name


def test_branch_repairs_path_kernel_loads_with_the_repairs_types(monkeypatch):
    """affine_path (fuse/path_kernel.py) as load_kernels loads it and as window_path runs it:
    one set of numba types (a second would be loaded inside the timed run)."""
    from armtrack_cli.fuse import branch_repair, path_kernel

    seen, phase = {}, ["load"]

    def record(*args, f=path_kernel.affine_path):
        seen.setdefault(phase[0], set()).add(tuple(typeof(a) for a in args))
        return f(*args)

    monkeypatch.setattr(path_kernel, "affine_path", record)
    monkeypatch.setattr(branch_repair, "affine_path", record)
    kernel_setup._load_smoother_passes()
    phase[0] = "run"
    rng = np.random.default_rng(3)
    F = np.tile(np.eye(15), (30, 1, 1)) + 0.01 * rng.normal(size=(30, 15, 15))
    branch_repair.window_path(lambda lo, hi: (F[lo:hi], rng.normal(size=(hi - lo, 15))),
                              0, 30, rng.normal(size=15), block=8)
    assert len(seen["load"]) == 1 and seen["load"] == seen["run"]


_BLAS_CHILD = """
import sys
import numpy as np
from armtrack_cli.fuse.kernel_setup import load_kernels
from armtrack_cli.fuse.methods import run_gaussian
from armtrack_cli.fuse.settings import FuseSettings
from tests.test_fuse_filters import _camera_problem

load_kernels("ekf")  # numba's registries, and the EKF kernel, whose products call BLAS
first = "scipy.linalg" in sys.modules
inp, x0, P0, proj, _ = _camera_problem()
s = FuseSettings(method="ekf")
a = run_gaussian(inp, x0, P0, proj, s, "ekf", compiled=True)
during = "scipy.linalg" in sys.modules
b = run_gaussian(inp, x0, P0, proj, s, "ekf", compiled=False)
import scipy.linalg
from scipy.linalg import cython_blas
same = cython_blas is sys.modules["scipy.linalg.cython_blas"]
solved = scipy.linalg.solve(np.array([[4.0, 1.0], [1.0, 3.0]]), np.array([1.0, 2.0]))
print(first, during, same, float(np.max(np.abs(a.mean - b.mean)) / np.abs(b.mean).max()),
      float(np.max(np.abs(a.cov - b.cov)) / np.abs(b.cov).max()), *solved.tolist())
"""


def test_kernels_load_without_the_scipy_linalg_package():
    """core/numba_blas.py: in a fresh process, load_kernels leaves the scipy.linalg package
    unimported (numba's BLAS check imports it otherwise), the compiled EKF, whose matrix
    products go through the preloaded cython_blas, still equals the numpy reference (1e-12),
    and scipy.linalg imported afterwards links to the same module and solves correctly."""
    import subprocess
    import sys

    from tests.conftest import REPO

    out = subprocess.run([sys.executable, "-c", _BLAS_CHILD], capture_output=True, text=True,
                         cwd=REPO, check=True).stdout.split()
    first, during, same = out[:3]
    mean_err, cov_err, x, y = map(float, out[3:])
    assert (first, during, same) == ("False", "False", "True")
    assert mean_err < 1e-12 and cov_err < 1e-12
    np.testing.assert_allclose([x, y], [1.0 / 11.0, 7.0 / 11.0], rtol=1e-14)
