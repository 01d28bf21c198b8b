"""Each compiled kernel's one-time set-up in a process (numba's start and its cache, about half
a second; a compile, once per install), run on a two-frame problem before the filter is timed,
so that fuse's frames_per_s is the filter's and kernel_setup_s the set-up's (issue 15)."""

from __future__ import annotations

import numpy as np

from armtrack_cli.core.numba_blas import preload
from armtrack_cli.filters import gaussian
from armtrack_cli.fuse.methods import guard_args
from armtrack_cli.fuse.settings import FuseSettings


def load_kernels(method: str) -> None:
    """Load ``method``'s compiled kernel (numba's set-up and its cache, about half a second
    once per process; a compile, once per install) by running it on a two-frame problem, so
    that a caller timing ``run`` times the filter only."""
    if method not in ("ekf", "ukf", "inertial", "pf", "pf-constraint", "arm-smoother"):
        return
    preload()  # numba's BLAS without the scipy.linalg package (core/numba_blas.py)
    if method == "arm-smoother":
        _load_smoother_passes()
        method = "pf-constraint"  # its first pass
    from armtrack_cli.fuse import gaussian_kernel, pf_kernel

    z, d3, q = np.zeros((2, 2)), np.zeros((2, 3)), np.zeros(2)
    cam = np.r_[np.eye(3).ravel(), 0.0, 0.0, 10.0, 1.0, 1.0, 0.0, 0.0]  # 10 m in front
    dist, x0 = np.zeros(5), np.zeros(6)
    if method in ("ekf", "ukf", "inertial"):
        sp = gaussian.SigmaPoints(6)
        gaussian_kernel.run(x0, 1e-4 * np.eye(6), z, q, d3, d3, 0.0, cam, dist, 1.0,
                            gaussian_kernel.METHODS[method], sp.Wm, sp.Wc, 1.0, 13.8, 10,
                            np.zeros(6))
    else:
        pf_kernel.load_passes()  # before run: run then calls the passes' own code
        pf_kernel.run(np.zeros((10, 6)), np.zeros(2, np.uint64), z, q, d3, d3, d3,
                      d3, cam, dist, np.zeros(6), 1.0, 1.0, 0.3, method == "pf-constraint", 0,
                      1.0, guard_args(FuseSettings(particles=10), d3, np.zeros(3)), d3, 0.0,
                      np.empty((2, 21)))


def _load_smoother_passes() -> None:
    """Load the passes the arm smoother runs (fuse/smoother_blocks.py: filter_block and
    rts_block; the wrong-root repair's affine_path; not smooth, which only arm_refine's
    "auto" arm runs, before this) on a two-frame problem with the argument types
    smooth_blocked (branch_repair.window_path) gives them: other types would
    load another specialisation, and the timed run would load theirs again (about 30 ms).
    Their callees are not loaded first as pf_kernel.load_passes does for the particle filter's:
    on a 1,024-frame block of long-10 that made filter_block 2 % faster and rts_block 2 %
    slower (3.45 -> 3.38 and 7.52 -> 7.66 ms, medians of 20 fresh processes each, alternated,
    load 1), and the two passes' CPU time in a long-10 fuse the same."""
    from armtrack_cli.fuse.path_kernel import affine_path
    from armtrack_cli.fuse.smoother_kernel import filter_block, rts_block

    d, n = 12, 2
    e = np.tile(np.eye(d), (n, 1, 1))
    xf, Pf = np.zeros((n, d)), e.copy()
    filter_block(np.zeros(d), np.eye(d), e, np.zeros((n, d)), e, np.zeros((n, 2, d)),
                 np.zeros((n, 2)), np.ones(n, bool), 1.0, np.zeros((n, d)), np.zeros(n),
                 np.ones(n, bool), 1.0, 13.8, True, n, xf, Pf, np.zeros(n, bool))
    rts_block(xf, Pf, n, e, np.zeros((n, d)), e, np.zeros(d), np.eye(d), True)
    affine_path(e, np.zeros((n, d)), np.zeros(d), np.zeros((n + 1, 3)), 1)  # branch_repair
