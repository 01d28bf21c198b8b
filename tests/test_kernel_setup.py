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
