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


def _long_export(tmp_path, monkeypatch, edit=None):
    """circle-01's IMU export, read as a long file would be (session/text_head.py: a head
    of 4 kB, the body from the file), after ``edit`` of its lines."""
    from armtrack_cli.session import text_head

    lines = (SAMPLES / "circle-01" / "imu.txt").read_text().splitlines()
    if edit:
        edit(lines)
    path = tmp_path / "imu.txt"
    path.write_text("\n".join(lines) + "\n")
    monkeypatch.setattr(text_head, "HEAD_BYTES", 4096)
    return path


def test_a_long_export_reads_as_a_short_one(tmp_path, monkeypatch):
    """The head and the file's body read by numpy give the IMU read whole, line by line."""
    from armtrack_cli.session.imu import read_imu

    whole = read_imu(SAMPLES / "circle-01" / "imu.txt")
    long = read_imu(_long_export(tmp_path, monkeypatch))
    for name in ("t", "acc", "gyr", "quat"):
        np.testing.assert_array_equal(getattr(long, name), getattr(whole, name))


@pytest.mark.parametrize("edit, message", [
    (lambda ls: ls.__setitem__(900, ls[900].replace("\t", "\tx", 1)), r"line 901, column"),
    (lambda ls: ls.insert(700, ""), None),  # a blank line: read row by row, the same rows
])
def test_a_long_export_names_its_bad_line(tmp_path, monkeypatch, edit, message):
    from armtrack_cli.session.imu import read_imu

    path = _long_export(tmp_path, monkeypatch, edit)
    if message is None:
        assert read_imu(path).n == read_imu(SAMPLES / "circle-01" / "imu.txt").n
    else:
        with pytest.raises(DataError, match=message):
            read_imu(path)
