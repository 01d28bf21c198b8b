"""write_table's all-float short cut (session/outputs._float_csv) writes what pandas' to_csv
writes: the same text for NaN (empty), ±inf, −0, tiny and huge values, and empty tables."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from armtrack_cli.session.outputs import _all_float, _float_csv


@pytest.mark.parametrize("rows", [0, 1, 500])
def test_the_same_text_as_pandas(rows):
    rng = np.random.default_rng(rows)
    a = rng.standard_normal((rows, 6)) * 10.0 ** rng.integers(-9, 9, (rows, 6))
    if rows:
        a[rng.random(a.shape) < 0.1] = np.nan
        a[0, :4] = [np.inf, -np.inf, -0.0, -1e-9]
    t = pd.DataFrame(a, columns=["t", "wrist_x", "wrist_y", "wrist_z", "ess", "nan"])
    assert _all_float(t)
    for fmt in ("%.6f", "%.3f"):
        assert _float_csv(t, fmt) == t.to_csv(index=False, float_format=fmt, lineterminator="\n")


def test_other_tables_take_pandas():
    assert not _all_float(pd.DataFrame({"a": [1.0], "b": ["x"]}))
    assert not _all_float(pd.DataFrame({"a": [1]}))
    assert not _all_float(pd.DataFrame({"a,b": [1.0]}))
