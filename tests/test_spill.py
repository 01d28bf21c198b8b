"""session/spill.py: columns appended a block at a time read back exactly, by any row range,
and nothing left on disk once closed (also after a failure)."""

from __future__ import annotations

import numpy as np
import pytest

from armtrack_cli.session.spill import Spill


def test_blocks_read_back_exactly_by_any_range(tmp_path):
    rng = np.random.default_rng(7)
    t, p, k = np.cumsum(rng.random(1000)), rng.normal(size=(1000, 3)), rng.integers(0, 9, 1000)
    p[rng.random(1000) < 0.1] = np.nan  # missing stays missing
    with Spill(tmp_path) as sp:
        for lo, hi in [(0, 0), (0, 1), (1, 400), (400, 400), (400, 1000)]:
            sp.append({"t": t[lo:hi], "p": p[lo:hi], "k": k[lo:hi]})
        assert len(sp) == 1000
        for lo, hi in [(0, 1000), (0, 1), (399, 401), (990, 2000), (500, 500), (700, 600)]:
            got = sp.read(lo, hi)
            want = slice(lo, max(lo, min(hi, 1000)))
            assert got["t"].tobytes() == t[want].tobytes()
            assert got["p"].tobytes() == p[want].tobytes() and got["p"].shape[1:] == (3,)
            assert got["k"].dtype == k.dtype and (got["k"] == k[want]).all()
        assert set(sp.read(5, 9, names=("t",))) == {"t"}
        folder = sp.path
        assert folder.parent == tmp_path and folder.name.startswith(".spill-")
    assert not folder.exists()


def test_a_failure_leaves_nothing_and_blocks_must_match(tmp_path):
    with pytest.raises(RuntimeError), Spill(tmp_path) as sp:
        sp.append({"t": np.zeros(3)})
        with pytest.raises(ValueError):
            sp.append({"t": np.zeros(3), "u": np.zeros(3)})
        with pytest.raises(ValueError):
            sp.append({"t": np.zeros((3, 2))})
        raise RuntimeError("the method diverged")
    assert not list(tmp_path.iterdir())
