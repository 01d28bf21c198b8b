"""compare's chunked readers (issue 15) against the whole readers they stand for, array bytes
for array bytes: a QTM 3D export (the bundled one, read from lines, and a 5-minute one of
several chunks, streamed from the file), the truth's points in W, a trajectory table; a bad
row, a coordinate beyond any volume or a clock going back in a later chunk still raise the
whole reader's error, naming the file and the line."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from armtrack_cli.core.errors import DataError, GroundTruthError
from armtrack_cli.pipeline.groundtruth import read_truth, truth_stream
from armtrack_cli.session.config import load_session
from armtrack_cli.session.numeric_text import CHUNK_BYTES
from armtrack_cli.session.plain_tables import NotPlain, trajectory_blocks, trajectory_columns
from armtrack_cli.session.qualisys import read_qualisys
from armtrack_cli.session.qualisys_stream import qualisys_chunks

from .conftest import REPO

CIRCLE = REPO / "sample_sessions" / "circle-01"
HEAD = ("NO_OF_FRAMES\t{n}\nNO_OF_CAMERAS\t8\nNO_OF_MARKERS\t3\nFREQUENCY\t100\n"
        "DATA_INCLUDED\t3D\nMARKER_NAMES\tR_SHO\tR_ELB\tR_WRI\n"
        "Frame\tTime\tR_SHO X\tR_SHO Y\tR_SHO Z\tR_ELB X\tR_ELB Y\tR_ELB Z\tR_WRI X\tR_WRI Y\t"
        "R_WRI Z\n")


def _long_tsv(path: Path, n: int = 30_000, seed: int = 0) -> list[str]:
    """A 5-minute QTM 3D export (several of numeric_text's chunks) with gaps written as empty
    cells and as zeros; its lines."""
    rng = np.random.default_rng(seed)
    x = 500 + np.cumsum(rng.normal(0, 0.5, (n, 9)), axis=0)
    lines = [f"{i + 1}\t{i / 100:.5f}\t" + "\t".join(f"{v:.3f}" for v in row)
             for i, row in enumerate(x)]
    for i in rng.choice(n, 60, replace=False):  # gaps: empty cells, then zeros
        cells = lines[i].split("\t")
        k = 2 + 3 * int(rng.integers(3))
        cells[k:k + 3] = ["", "", ""] if i % 2 else ["0.000"] * 3
        lines[i] = "\t".join(cells)
    path.write_text(HEAD.format(n=n) + "\n".join(lines) + "\n")
    assert path.stat().st_size > 2 * CHUNK_BYTES
    return lines


def _joined(path):
    names, rate, chunks = qualisys_chunks(path)
    parts = list(chunks)
    return names, rate, np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])


@pytest.mark.parametrize("which", ["circle-01", "long"])
def test_chunks_are_read_qualisys_byte_for_byte(which, tmp_path):
    path = CIRCLE / "qualisys.tsv" if which == "circle-01" else tmp_path / "q.tsv"
    if which == "long":
        _long_tsv(path)
    whole = read_qualisys(path)
    names, rate, t, xyz = _joined(path)
    assert (names, rate) == (whole.names, whole.rate_hz)
    assert t.tobytes() == whole.t.tobytes() and xyz.tobytes() == whole.xyz.tobytes()
    assert np.isnan(xyz).any()


def test_truth_stream_is_read_truth(tmp_path):
    folder = tmp_path / "s"
    shutil.copytree(CIRCLE, folder)
    _long_tsv(folder / "qualisys.tsv")
    session = load_session(folder)
    whole = read_truth(session, offset_s=0.0)
    rate, roles, blocks = truth_stream(session)
    blocks = list(blocks)
    assert (rate, roles) == (whole.rate_hz, tuple(whole.xyz))
    assert np.concatenate([b["t"] for b in blocks]).tobytes() == whole.t.tobytes()
    for r in roles:
        got = np.concatenate([b[r] for b in blocks])
        assert np.array_equal(got, whole.xyz[r], equal_nan=True)


def _broken(tmp_path: Path, at: int, cells) -> Path:
    path = tmp_path / "q.tsv"
    lines = _long_tsv(path)
    parts = lines[at].split("\t")
    parts[:len(cells)] = cells
    lines[at] = "\t".join(parts)
    path.write_text(HEAD.format(n=len(lines)) + "\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("cells", [
    ["17000", "169.99000", "12x.5"],  # not a number
    ["17000", "169.99000", "1e9"],  # beyond any capture volume
    ["17000", "160.00000"],  # the clock goes back
], ids=["not-a-number", "beyond-volume", "clock-back"])
def test_a_bad_row_mid_file_raises_the_whole_readers_error(cells, tmp_path):
    path = _broken(tmp_path, 16_999, cells)  # file line 17,007: in a later chunk
    with pytest.raises(GroundTruthError) as whole:
        read_qualisys(path)
    with pytest.raises(GroundTruthError) as streamed:
        _joined(path)
    assert str(streamed.value) == str(whole.value)
    assert str(path) in str(whole.value) and "line 17007" in str(whole.value)


def _trajectory(path: Path, n: int = 40_000, seed: int = 1) -> None:
    rng = np.random.default_rng(seed)
    cols = {"t": np.arange(n) / 30, **{f"{j}_{a}": rng.normal(0, 0.3, n) for j in
                                       ("wrist", "elbow") for a in "xyz"},
            "wrist_vx": rng.normal(size=n), "wrist_x_sd": rng.uniform(0, 0.01, n)}
    cols["wrist_y"][rng.choice(n, 50, replace=False)] = np.nan
    lines = [",".join(cols)] + [",".join("" if np.isnan(v) else f"{v:.6f}" for v in row)
                                for row in zip(*cols.values())]
    path.write_text("\n".join(lines) + "\n")
    assert path.stat().st_size > 2 * CHUNK_BYTES


def test_trajectory_blocks_are_trajectory_columns(tmp_path):
    path = tmp_path / "trajectory-m.csv"
    _trajectory(path)
    keep = {"t", "wrist_x", "wrist_y", "wrist_z", "wrist_x_sd"}
    whole = trajectory_columns(path)
    blocks = list(trajectory_blocks(path, keep.__contains__))
    assert len(blocks) > 1 and list(blocks[0]) == [k for k in whole if k in keep]
    for k in blocks[0]:
        assert np.concatenate([b[k] for b in blocks]).tobytes() == whole[k].tobytes()


def test_a_trajectory_the_plain_reader_refuses_goes_to_the_whole_reader(tmp_path):
    path = tmp_path / "trajectory-m.csv"
    _trajectory(path)
    lines = path.read_text().splitlines()
    lines[35_000] = lines[35_000].replace(",", ",x", 1)  # a cell that is no number, late
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(NotPlain):
        list(trajectory_blocks(path, {"t"}.__contains__))
    with pytest.raises(DataError) as whole:
        trajectory_columns(path)
    assert path.name in str(whole.value)
