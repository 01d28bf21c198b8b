"""write_table's all-float short cut (session/outputs._float_csv) writes what pandas' to_csv
writes: the same text for NaN (empty), ±inf, −0, tiny and huge values, and empty tables; and
write_table, which streams the text to the file a block of rows at a time, writes the file
pandas would, on either path and across block boundaries."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from armtrack_cli.session import outputs
from armtrack_cli.session.outputs import _all_float, _float_csv, write_table


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
        assert "".join(_float_csv(t, fmt)) == t.to_csv(index=False, float_format=fmt, lineterminator="\n")


def test_other_tables_take_pandas():
    assert not _all_float(pd.DataFrame({"a": [1.0], "b": ["x"]}))
    assert not _all_float(pd.DataFrame({"a": [1]}))
    assert not _all_float(pd.DataFrame({"a,b": [1.0]}))


@pytest.mark.parametrize("mixed", [False, True])
def test_write_table_streams_the_same_file(tmp_path, monkeypatch, mixed):
    monkeypatch.setattr(outputs, "CSV_BLOCK", 7)  # 50 rows: several blocks and a partial one
    rng = np.random.default_rng(3)
    a = rng.standard_normal((50, 3))
    a[rng.random(a.shape) < 0.2] = np.nan
    t = pd.DataFrame(a, columns=["t", "x", "y"])
    if mixed:  # pandas' own path (a text column)
        t["name"] = [f"r{i}" for i in range(50)]
    write_table(tmp_path / "t.csv", t, command="test")
    assert (tmp_path / "t.csv").read_bytes() == t.to_csv(
        index=False, float_format="%.6f", lineterminator="\n").encode()
    assert (tmp_path / "t.meta.json").exists()
