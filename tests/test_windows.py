"""core/windows.py: the inner spans tile the session (each instant in exactly one window),
each window reads its inner span and its margins, a short session is one window."""

from __future__ import annotations

import numpy as np
import pytest

from armtrack_cli.core.windows import windows


@pytest.mark.parametrize("span", [0.0, 10.0, 340.0, 340.5, 600.0, 3599.97, 3750.0, 3760.0])
def test_inner_spans_tile_the_session(span):
    t = np.arange(0.0, span + 1e-9, 1 / 30) + 12.5  # frame times from 12.5 s
    ws = windows(float(t[0]), float(t[-1]), 300.0, 20.0)
    owner = np.stack([w.inner(t) for w in ws])
    assert (owner.sum(axis=0) == 1).all()  # every frame in exactly one window
    if span <= 340.0:
        assert len(ws) == 1 and ws[0].read(t) == slice(0, t.size)
        return
    assert len(ws) == round(span / 300)
    for w in ws:
        own = t[w.inner(t)]
        read = t[w.read(t)]
        assert own.size and 150 <= own[-1] - own[0] + 1 / 30 <= 450.1  # never a sliver
        assert read[0] == pytest.approx(max(t[0], own[0] - 20), abs=1.5 / 30)  # the margins read
        assert read[-1] == pytest.approx(min(t[-1], own[-1] + 20), abs=1.5 / 30)


def test_windows_off_and_bad_spans():
    assert len(windows(0.0, 3600.0, 0.0, 20.0)) == 1  # length 0: one window, run whole
    with pytest.raises(ValueError):
        windows(5.0, 1.0)
    with pytest.raises(ValueError):
        windows(0.0, float("nan"))
