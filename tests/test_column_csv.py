"""detect's bookkeeping without per-frame objects or a DataFrame (issue 15): write_columns
writes the bytes pandas' write_table writes for the same columns, and the palm blobs' growing
array gives the table the per-frame list gave."""

from __future__ import annotations

import importlib

import numpy as np
import pandas as pd
import pytest

from armtrack_cli.session import outputs
from armtrack_cli.session.column_csv import write_column_blocks, write_columns
from armtrack_cli.session.outputs import output_set, write_table

detect_stage = importlib.import_module("armtrack_cli.pipeline.detect")


def _columns(n: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(3)
    u = rng.normal(300.0, 200.0, n)
    u[rng.random(n) < 0.1] = np.nan  # lost frames: empty cells
    u[:min(n, 4)] = [-0.0, 1e-9, 123456789.123456789, -2.5e-7][:min(n, 4)]
    return {"frame": np.arange(n), "t": np.arange(n) / 30.0, "u": u, "v": -u / 3,
            "ok": np.isfinite(u).astype(int), "angle": rng.uniform(-90, 90, n)}


@pytest.mark.parametrize("n", [0, 1, 5000])
def test_write_columns_writes_write_tables_bytes(tmp_path, monkeypatch, n):
    monkeypatch.setattr(outputs, "CSV_BLOCK", 1000)  # several blocks, one cut mid-table
    cols = _columns(n)
    write_columns(tmp_path / "a.csv", cols, command="detect", settings={"k": 1})
    write_table(tmp_path / "b.csv", pd.DataFrame(cols), command="detect", settings={"k": 1})
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()
    assert (tmp_path / "a.meta.json").read_bytes() == (tmp_path / "b.meta.json").read_bytes()


@pytest.mark.parametrize("cuts", [[0], [1, 1], [0, 2500, 2501, 4999], [1700, 3400]])
def test_blocks_write_the_joined_tables_bytes(tmp_path, monkeypatch, cuts):
    """A table written a window at a time (empty windows and one-row windows among them) is
    byte for byte the table pandas writes whole; the settings, a function, are asked for once
    the rows are written."""
    monkeypatch.setattr(outputs, "CSV_BLOCK", 1000)
    cols, written = _columns(5000), []
    edges = [0, *cuts, 5000]

    def blocks():
        for lo, hi in zip(edges[:-1], edges[1:]):
            written.append(hi)
            yield {k: v[lo:hi] for k, v in cols.items()}

    def settings():
        assert written[-1] == 5000  # every block made before the summary
        return {"k": 1}

    write_column_blocks(tmp_path / "a.csv", blocks(), command="fuse", settings=settings)
    write_table(tmp_path / "b.csv", pd.DataFrame(cols), command="fuse", settings={"k": 1})
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()
    assert (tmp_path / "a.meta.json").read_bytes() == (tmp_path / "b.meta.json").read_bytes()


def test_a_failure_between_blocks_leaves_nothing(tmp_path):
    """The second window failing (a method diverging) after the first was written: neither
    the table nor its sidecar nor a temp file is left, and an earlier table stays as it was."""
    (tmp_path / "a.csv").write_text("old\n")
    cols = _columns(100)

    def blocks():
        yield {k: v[:50] for k, v in cols.items()}
        raise RuntimeError("the second window diverged")

    with pytest.raises(RuntimeError), output_set():
        write_column_blocks(tmp_path / "a.csv", blocks(), command="fuse")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.csv"]
    assert (tmp_path / "a.csv").read_text() == "old\n"


def test_blocks_must_keep_the_first_blocks_columns(tmp_path):
    cols = _columns(10)
    changed = {**{k: v[5:] for k, v in cols.items()}, "ok": cols["ok"][5:] * 1.0}  # int -> float
    for second in ({k: v[5:] for k, v in cols.items() if k != "u"}, changed):
        with pytest.raises(ValueError, match="first's columns"):
            write_column_blocks(tmp_path / "a.csv", [{k: v[:5] for k, v in cols.items()}, second],
                                command="fuse")
    assert not list(tmp_path.iterdir())


def test_palm_blobs_accumulate_to_the_per_frame_tables_rows():
    rng = np.random.default_rng(1)
    found = [(i, i / 30, rng.random((int(rng.integers(1, 9)), 4)) * 100)
             for i in range(0, 20000, 3)]
    acc = detect_stage._Blobs()
    for i, t, b in found:
        acc.add(i, t, b)
    got = acc.table()
    n = np.array([len(b) for _, _, b in found])
    b = np.concatenate([b for _, _, b in found])
    want = {"frame": np.repeat([i for i, _, _ in found], n),
            "t": np.repeat([t for _, t, _ in found], n),
            "blob": np.concatenate([np.arange(k) for k in n]),
            "u": b[:, 0], "v": b[:, 1], "area": b[:, 2].astype(np.int64), "score": b[:, 3]}
    assert list(got) == list(want)
    for k in want:
        np.testing.assert_array_equal(got[k], want[k])
    assert acc.frames_6 == sum(len(b) >= 6 for _, _, b in found)
