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
