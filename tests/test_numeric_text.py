"""The one streaming numeric-table reader (session/numeric_text.py) held to the readers it
replaced (tests/reference_tables.py, verbatim from before it): the same arrays (NaN where NaN),
file lines, notes and error messages on every text table the tests and the sample sessions
have, read whole or streamed in small chunks; and its own rules (empty cell = NaN, a bad cell
named by line and column) on hand-made tables."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from armtrack_cli.core.errors import ArmtrackError, DataError
from armtrack_cli.session import (
    imu_csv,
    numeric_text,
    plain_tables,
    qtm6dof,
    qualisys,
    text_head,
    text_table,
    vicon,
    video,
    xsens,
)
from armtrack_cli.session.groundtruth import read_markers
from armtrack_cli.session.imu import read_imu

from . import reference_tables as ref
from .conftest import REPO

CORPUS = sorted(p for d in ("sample_sessions", "tests/data", "tests/hostile")
                for p in (REPO / d).rglob("*") if p.suffix in (".txt", ".tsv", ".csv")
                and p.name.startswith(("imu", "qualisys", "MT", "video_timestamps")))
SAMPLES = REPO / "sample_sessions"


def _old_parse_table(*args, groups=None, **kwargs):
    """The table as it was read before: every column, whatever groups the reader asks for."""
    tab = ref.parse_table(*args, **kwargs)
    return text_table.TextTable(tab.header, tab.data, tab.line_of, tab.notes)


def _old_parse_rows(path, lines, first, header, delimiter, error, *, skip_prefixes=(),
                    groups=None):
    """qualisys' header-less table as it was read before: a made-up header line in front."""
    tab = ref.parse_table(path, ["\t".join(header)] + list(lines[first:]), 0, delimiter, error,
                          skip_prefixes=skip_prefixes)
    return text_table.TextTable(tab.header, tab.data, tab.line_of + first - 1, tab.notes)


def _use_old_readers(mp) -> None:
    for mod in (xsens, imu_csv, qualisys, vicon, qtm6dof, video):
        mp.setattr(mod, "parse_table", _old_parse_table)
    mp.setattr(qualisys, "parse_rows", _old_parse_rows)
    mp.setattr(qualisys, "read_text_head", text_table.read_text_lines)


def _read(path: Path):
    """What the session's reader makes of the file (or its one-line error)."""
    try:
        if path.name.startswith("video_timestamps"):
            return video.read_timestamps(path, 10**6)
        if path.name.startswith("qualisys"):
            return read_markers(path)
        return read_imu(path, complete=False)
    except ArmtrackError as exc:
        return f"error: {exc}"


def _same(a, b) -> None:
    if isinstance(a, str) or isinstance(b, str):
        assert a == b
    elif isinstance(a, np.ndarray):
        np.testing.assert_array_equal(a, b)  # NaN where NaN
    elif dataclasses.is_dataclass(a):
        for f in dataclasses.fields(a):
            _same(getattr(a, f.name), getattr(b, f.name))
    else:
        assert a == b


def test_the_corpus_is_there():
    assert len(CORPUS) >= 30 and any(p.suffix == ".tsv" for p in CORPUS)


@pytest.mark.parametrize("path", CORPUS, ids=lambda p: str(p.relative_to(REPO)))
def test_every_table_reads_as_before(path, monkeypatch):
    new = _read(path)
    with monkeypatch.context() as mp:
        _use_old_readers(mp)
        old = _read(path)
    _same(new, old)


def _edited(tmp_path: Path, source: Path, edit) -> Path:
    lines = source.read_text().splitlines()
    edit(lines)
    out = tmp_path / source.name
    out.write_text("\n".join(lines) + "\n")
    return out


def _cell(row: int, col: int, token: str):
    def edit(lines):
        cells = lines[row].split("\t")
        cells[col] = token
        lines[row] = "\t".join(cells)
    return edit


EDITS = {
    "as it is": lambda ls: None,
    "an empty cell": _cell(700, 3, ""),
    "empty cells in a column": lambda ls: [_cell(r, 4, "")(ls) for r in range(300, 340)],
    "an NA cell": _cell(900, 2, "NA"),
    "a blank line": lambda ls: ls.insert(500, ""),
    "a trailing tab": lambda ls: ls.__setitem__(800, ls[800] + "\t"),
    "a truncated last line": lambda ls: ls.__setitem__(-1, ls[-1].split("\t", 3)[0]),
    "a text cell": _cell(1200, 5, "x"),
    "a short row": lambda ls: ls.__setitem__(1000, ls[1000].rsplit("\t", 1)[0]),
    "CR LF line ends": lambda ls: ls.__setitem__(slice(None), [ln + "\r" for ln in ls]),
}


@pytest.mark.parametrize("edit", EDITS, ids=list(EDITS))
@pytest.mark.parametrize("name", ["circle-01/imu.txt", "circle-01/qualisys.tsv"])
def test_a_long_file_streamed_in_chunks_reads_as_the_whole_did(tmp_path, monkeypatch, name,
                                                               edit):
    """Read as a long file is (a 4 kB head, the body streamed in 16 kB chunks) against the
    old readers reading the whole file: every edit lands in a chunk of its own."""
    path = _edited(tmp_path, SAMPLES / name, EDITS[edit])
    with monkeypatch.context() as mp:
        _use_old_readers(mp)
        old = _read(path)
    monkeypatch.setattr(text_head, "HEAD_BYTES", 4096)
    monkeypatch.setattr(numeric_text, "CHUNK_BYTES", 16384)
    _same(_read(path), old)


def test_the_old_long_file_reader_is_matched(tmp_path, monkeypatch):
    """text_head's old loadtxt over a long export's whole body gives the same numbers."""
    path = SAMPLES / "circle-01" / "imu.txt"
    lines = path.read_text().splitlines()
    at = next(i for i, ln in enumerate(lines) if ln.startswith("PacketCounter"))
    data, line_of = ref.numbers_after(path, at, "\t", len(lines[at].split("\t")))
    monkeypatch.setattr(numeric_text, "CHUNK_BYTES", 8192)
    layout = numeric_text.Layout(data.shape[1], "\t", tuple(lines[at].split("\t")))
    rows = numeric_text.file_rows(path, at + 1, layout, DataError)
    np.testing.assert_array_equal(rows.data, data)
    np.testing.assert_array_equal(rows.line_of, line_of)


TRAJ = ("t,wrist_x,wrist_y,wrist_z,elbow_x,elbow_y,elbow_z,wrist_x_sd,ess\n"
        "0.000000,0.100000,0.200000,0.050000,,,,0.010000,480.000000\n"
        "0.033333,0.101234,0.199876,0.050321,0.300000,0.100000,0.020000,,470.5\n"
        "0.066667,0.102468,0.199752,0.050642,0.301000,0.101000,0.021000,0.011000,1e2\n")


def _long_trajectory(rows: int = 3000) -> str:
    rng = np.random.default_rng(4)
    x = rng.normal(0.0, 0.3, (rows, 8))
    x[rng.random((rows, 8)) < 0.05] = np.nan  # gaps: empty cells
    lines = [",".join([f"{k / 30:.6f}"] + ["" if np.isnan(v) else f"{v:.6f}" for v in r])
             for k, r in enumerate(x)]
    return TRAJ.splitlines()[0] + "\n" + "\n".join(lines) + "\n"


@pytest.mark.parametrize("text", [
    TRAJ, _long_trajectory(), TRAJ.replace("0.102468", "abc"), TRAJ.replace("0.102468", "inf"),
    TRAJ.replace("0.066667", "0.010000"), TRAJ.replace("0.033333,", "", 1), TRAJ + "\n",
    TRAJ.replace("0.102468", '"0.102468"'), TRAJ.splitlines()[0] + "\n",
    TRAJ.replace("0.102468", "NA"), TRAJ.replace("\n", "\n\n", 2),
], ids=["plain", "long", "text", "inf", "back", "short", "blank-end", "quoted", "no-rows", "NA",
        "blank-line"])
def test_a_trajectory_reads_as_before(tmp_path, monkeypatch, text):
    """The plain path takes the files the old one took, with the same numbers, and hands the
    others (Irregular) to the pandas reader as the old one did."""
    p = tmp_path / "trajectory-x.csv"
    p.write_text(text)
    monkeypatch.setattr(numeric_text, "CHUNK_BYTES", 4096)
    try:
        old = ref.plain_trajectory(p)
    except ref.Irregular:
        with pytest.raises(plain_tables._Irregular):
            plain_tables._plain_trajectory(p)
        return
    new = plain_tables._plain_trajectory(p)
    assert list(new) == list(old)
    for c in old:
        np.testing.assert_array_equal(new[c], old[c])


def _rows(tmp_path, text: str, n: int = 3, delimiter="\t"):
    p = tmp_path / "t.tsv"
    p.write_text(text)
    layout = numeric_text.Layout(n, delimiter, tuple("abcdefgh"[:n]))
    return numeric_text.file_rows(p, 0, layout, DataError)


@pytest.mark.parametrize("reserve", [numeric_text.RESERVE_BYTES, 0])  # 0: the rows counted
def test_an_empty_cell_is_nan_and_lines_are_counted_across_chunks(tmp_path, monkeypatch,
                                                                  reserve):
    monkeypatch.setattr(numeric_text, "CHUNK_BYTES", 64)
    monkeypatch.setattr(numeric_text, "RESERVE_BYTES", reserve)
    body = "".join(f"{k}\t{k * 2}\t{'' if k % 7 == 3 else k * 3}\n" for k in range(100))
    got = _rows(tmp_path, body)
    want = np.array([[k, 2 * k, np.nan if k % 7 == 3 else 3 * k] for k in range(100)], float)
    np.testing.assert_array_equal(got.data, want)
    np.testing.assert_array_equal(got.line_of, np.arange(1, 101))


@pytest.mark.parametrize("reserve", [numeric_text.RESERVE_BYTES, 0])
def test_groups_hold_the_tables_columns_and_nothing_else(tmp_path, monkeypatch, reserve):
    """Read in groups, across chunks read by loadtxt and row by row (an NA cell, empty
    cells): each group's own contiguous array is those columns of the whole table, and no
    table is kept."""
    monkeypatch.setattr(numeric_text, "CHUNK_BYTES", 64)
    monkeypatch.setattr(numeric_text, "RESERVE_BYTES", reserve)
    body = "".join(f"{k}\t{'NA' if k == 40 else k * 2}\t{'' if k % 7 == 3 else k * 3}\t"
                   f"{k % 5}\t{-k}\n" for k in range(100))
    p = tmp_path / "t.tsv"
    p.write_text(body)
    layout = numeric_text.Layout(5, "\t", tuple("abcde"))
    whole = numeric_text.file_rows(p, 0, layout, DataError)
    groups = ((4, 0), (2,), (1, 3))
    got = numeric_text.file_rows(p, 0, layout, DataError, groups=groups)
    assert got.data is None and np.isnan(whole.data[40, 1]) and np.isnan(whole.data[3, 2])
    for g, part in zip(groups, got.groups, strict=True):
        np.testing.assert_array_equal(part, whole.data[:, list(g)])
        assert part.flags.c_contiguous
    np.testing.assert_array_equal(got.line_of, whole.line_of)


def test_a_bad_cell_is_named_by_line_and_column(tmp_path, monkeypatch):
    monkeypatch.setattr(numeric_text, "CHUNK_BYTES", 64)
    body = "".join(f"{k}\t{'oops' if k == 57 else k}\t{k}\n" for k in range(100))
    with pytest.raises(DataError, match=r"line 58, column 'b': 'oops' is not a number"):
        _rows(tmp_path, body)
    with pytest.raises(DataError, match=r"line 4 has 2 fields but the header has 3 \(tab"):
        _rows(tmp_path, "1\t2\t3\n" * 3 + "1\t2\n" + "1\t2\t3\n")


def test_a_truncated_last_line_is_dropped_with_a_note(tmp_path):
    got = _rows(tmp_path, "1,2,3\n4,5,6\n7,", delimiter=",")
    np.testing.assert_array_equal(got.data, [[1, 2, 3], [4, 5, 6]])
    assert got.notes == ("last line 3 has 2 of 3 fields (truncated write): dropped",)
