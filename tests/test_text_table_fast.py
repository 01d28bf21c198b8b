"""The C-speed read of plain numeric tables (session/text_table._plain_numbers) against the
row-by-row parse it short-cuts: the same numbers and file lines on the bundled sessions' IMU and
Qualisys exports, and the row-by-row parse (with its messages) for anything else."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from armtrack_cli.core.errors import DataError
from armtrack_cli.session import text_table
from armtrack_cli.session.qualisys import read_qualisys
from armtrack_cli.session.xsens import read_mt_manager

SAMPLES = Path(__file__).resolve().parents[1] / "sample_sessions"


def _both(monkeypatch, read):
    fast = read()
    monkeypatch.setattr(text_table, "_plain_numbers", lambda *a: None)
    return fast, read()


def test_imu_export_reads_the_same_both_ways(monkeypatch):
    path = SAMPLES / "circle-01" / "imu.txt"
    fast, slow = _both(monkeypatch, lambda: read_mt_manager(path))
    for name in ("t", "acc", "gyr", "quat"):
        np.testing.assert_allclose(getattr(fast, name), getattr(slow, name), rtol=1e-15, atol=0)


def test_qualisys_export_reads_the_same_both_ways(monkeypatch):
    path = SAMPLES / "circle-01" / "qualisys.tsv"
    fast, slow = _both(monkeypatch, lambda: read_qualisys(path))
    np.testing.assert_allclose(fast.t, slow.t, rtol=1e-15, atol=0)
    np.testing.assert_allclose(fast.xyz, slow.xyz, rtol=1e-15, atol=0)


@pytest.mark.parametrize("rows, expect", [
    (["1\t2\t3", "4\t\t6"], None),  # an empty cell: missing, read row by row
    (["1\tNA\t3"], None),
    (["1\t2\t3", "4\t5"], None),  # ragged
    (["1\tx\t3"], None),
    (["1\t2\t3", "", "4\tnan\t6"], np.array([[1, 2, 3], [4, np.nan, 6.0]])),
])
def test_only_plain_numbers_take_the_short_cut(rows, expect):
    got = text_table._plain_numbers(["a\tb\tc"] + rows, 0, "\t", 3, ())
    if expect is None:
        assert got is None
    else:
        np.testing.assert_array_equal(got[0], expect)
        assert got[1].tolist() == [2, 4]


def test_a_bad_cell_is_still_named(tmp_path):
    lines = ["a\tb\tc", "1\t2\t3", "4\tx\t6"]
    with pytest.raises(DataError, match="line 3, column 'b': 'x' is not a number"):
        text_table.parse_table(tmp_path / "f.tsv", lines, 0, "\t", DataError)
