"""The IMU read a chunk at a time for a windowed fuse (issue 15, session/imu_stream.py): the
chunks of an MT Manager export, concatenated, are read_imu's arrays byte for byte, its rate
the same float, whether the chunks come from lines in memory or from the file; a file damaged
late gives read_imu's error word for word, and a fuse that meets it leaves no spill behind."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from armtrack_cli.core.counted_median import CountedMedian
from armtrack_cli.core.errors import ImuFileError
from armtrack_cli.pipeline.fuse_imu import SpilledImu
from armtrack_cli.session import numeric_text, text_head
from armtrack_cli.session.imu import read_imu
from armtrack_cli.session.imu_stream import imu_chunks

SAMPLE_IMU = Path(__file__).resolve().parents[1] / "sample_sessions" / "circle-01" / "imu.txt"
HEADER = 8  # circle-01's imu.txt: 8 comment lines, the column header, then 2150 rows
LATE = 2000  # a data row in one of the last chunks at the small chunk sizes below


@pytest.fixture(params=["lines", "file"])
def small_chunks(request, monkeypatch):
    """Chunks of 300 lines from the lines in memory, or of 16 kB of text streamed from the
    file (its head shrunk below the file's size): either way, several chunks a file."""
    if request.param == "lines":
        monkeypatch.setattr(numeric_text, "CHUNK_LINES", 300)
    else:
        monkeypatch.setattr(text_head, "HEAD_BYTES", 4096)
        monkeypatch.setattr(numeric_text, "CHUNK_BYTES", 16384)
    return request.param


def _lines() -> list[str]:
    return SAMPLE_IMU.read_text().splitlines()


def _write(tmp_path: Path, lines: list[str], name: str = "imu.txt") -> Path:
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


def _cells(lines: list[str], row: int) -> list[str]:
    return lines[HEADER + 1 + row].split("\t")


def _set(lines: list[str], row: int, col: int, value: str) -> list[str]:
    cells = _cells(lines, row)
    cells[col] = value
    lines[HEADER + 1 + row] = "\t".join(cells)
    return lines


def _same_arrays(path: Path, **kw) -> int:
    whole = read_imu(path, **kw)
    stream = imu_chunks(path, **kw)
    chunks = list(stream)
    for name in ("t", "quat", "acc", "gyr"):
        got = np.concatenate([getattr(c, name) for c in chunks])
        want = getattr(whole, name)
        assert got.shape == want.shape and got.tobytes() == want.tobytes(), name
    assert stream.rate_hz == whole.rate_hz
    assert stream.orientation_source == whole.orientation_source
    return len(chunks)


def test_circle01_imu_in_one_chunk_is_read_imu():
    assert _same_arrays(SAMPLE_IMU) == 1


def test_multi_chunk_export_is_read_imu(small_chunks):
    assert _same_arrays(SAMPLE_IMU) >= 5


def test_variants_are_read_imu(tmp_path, small_chunks):
    """NED, no SampleTimeFine (PacketCounter at the header's rate), no PacketCounter, FreeAcc
    in place of Acc, Euler angles in place of quaternions: each the same arrays."""
    lines = _lines()
    ned = lines[:HEADER] + ["// Coordinate system: NED", "// Update Rate: 100.0Hz"] + lines[HEADER:]
    ned = [ln for ln in ned if ln != "// Coordinate system: ENU"]
    assert _same_arrays(_write(tmp_path, ned, "ned.txt")) >= 5

    def drop(col: int, text: list[str]) -> list[str]:
        return text[:HEADER] + ["\t".join(c for k, c in enumerate(ln.split("\t")) if k != col)
                                for ln in text[HEADER:]]

    assert _same_arrays(_write(tmp_path, drop(1, lines), "nostf.txt"), rate_hz=100.0) >= 5
    assert _same_arrays(_write(tmp_path, drop(0, lines), "nocounter.txt")) >= 5
    free = lines[:HEADER] + [lines[HEADER].replace("Acc_", "FreeAcc_")] + lines[HEADER + 1:]
    assert _same_arrays(_write(tmp_path, free, "free.txt")) >= 5
    euler = lines[:HEADER] + [lines[HEADER].replace("Quat_q0\tQuat_q1\tQuat_q2\tQuat_q3",
                                                    "Roll\tPitch\tYaw")]
    for k, ln in enumerate(lines[HEADER + 1:]):
        cells = ln.split("\t")[:8]
        euler.append("\t".join(cells + [f"{(k % 90) * 0.5:.2f}", "-10.5", f"{k * 0.1:.1f}"]))
    assert _same_arrays(_write(tmp_path, euler, "euler.txt")) >= 5


# damage late in the file (and one early where a later one must still win, as in read_imu)
DAMAGE = {
    "not a number": lambda ln: _set(ln, LATE, 4, "9.8x"),
    "ragged row": lambda ln: _set(ln, LATE, 4, "9.8\t1.0"),
    "counter repeats": lambda ln: _set(ln, LATE, 0, _cells(ln, LATE - 1)[0]),
    "counter back": lambda ln: _set(ln, LATE, 0, "00005"),
    "counter not whole, a repeat before it": lambda ln: _set(
        _set(ln, 100, 0, _cells(ln, 99)[0]), LATE, 0, "1.5"),
    "counter across a chunk's edge": lambda ln: _set(ln, 300, 0, _cells(ln, 299)[0]),
    "stf back": lambda ln: _set(ln, LATE, 1, "1234567"),
    "stf not a tick": lambda ln: _set(ln, LATE, 1, "-5"),
    "stf missing in one row": lambda ln: _set(ln, LATE, 1, ""),
    "stf missing but the first chunk": lambda ln: [
        _set(ln, r, 1, "") for r in range(400, 2150)][-1],
    "orientation norm": lambda ln: _set(ln, LATE, 8, "0.5"),
    "gyro beyond 35 rad/s": lambda ln: _set(ln, LATE, 6, "40.0"),
    "acc beyond 16 g": lambda ln: _set(ln, LATE, 3, "-200.0"),
    "acc in g": lambda ln: ln[:HEADER + 1] + [
        "\t".join(c if k not in (2, 3, 4) else f"{float(c) / 9.81:.6f}"
                  for k, c in enumerate(row.split("\t"))) for row in ln[HEADER + 1:]],
    "clock spans days": lambda ln: _set(ln, LATE, 1, "4294967000"),
    "no orientation after a bad counter": lambda ln: [
        _set(ln, r, 8, "") for r in range(2150)][-1] and _set(ln, LATE, 0, "2.5"),
    "orientation empty in every row": lambda ln: [_set(ln, r, 8, "") for r in range(2150)][-1],
    "accelerometer empty in every row": lambda ln: [
        _set(ln, r, 2, "") for r in range(2150)][-1],
    "update rate unlike the clock": lambda ln: ln[:1] + ["// Update Rate: 60.0Hz"] + ln[1:],
}


def _same_refusal(tmp_path, path) -> None:
    """The stream refuses the file with read_imu's message word for word, and a spill fed
    by it leaves nothing in the work folder."""
    with pytest.raises(ImuFileError) as whole:
        read_imu(path)
    with pytest.raises(ImuFileError) as streamed:
        list(imu_chunks(path))
    assert str(streamed.value) == str(whole.value)
    out = tmp_path / "work"
    with pytest.raises(ImuFileError):
        SpilledImu(out, imu_chunks(path))
    assert list(out.iterdir()) == []  # the spill removed: nothing written


@pytest.mark.parametrize("damage", sorted(DAMAGE))
def test_damage_late_gives_read_imus_message(tmp_path, small_chunks, damage):
    _same_refusal(tmp_path, _write(tmp_path, DAMAGE[damage](_lines())))


def test_no_rate_and_all_stf_empty(tmp_path, small_chunks):
    """SampleTimeFine empty in every row and no Update Rate: read_imu's refusal, and with
    [imu] rate_hz, PacketCounter times at that rate."""
    lines = _lines()
    for r in range(2150):
        _set(lines, r, 1, "")
    path = _write(tmp_path, lines)
    with pytest.raises(ImuFileError) as whole:
        read_imu(path)
    with pytest.raises(ImuFileError) as streamed:
        list(imu_chunks(path))
    assert str(streamed.value) == str(whole.value)
    assert _same_arrays(path, rate_hz=100.0) >= 5


def test_no_orientation_is_read_whole(tmp_path):
    """Without orientation columns (VQF estimates it over the whole recording) the stream is
    read_imu's recording cut into chunks."""
    lines = _lines()
    cut = lines[:HEADER] + ["\t".join(ln.split("\t")[:8]) for ln in lines[HEADER:]]
    path = _write(tmp_path, cut)
    assert imu_chunks(path).orientation_source.startswith("estimated")
    _same_arrays(path)


# the generic CSV (session/imu_csv.py): circle-01's recording written as one, at full precision
def _csv_lines() -> list[str]:
    s = read_imu(SAMPLE_IMU)
    rows = np.column_stack([s.t + 12.5, s.acc, s.gyr, s.quat])
    return ["# circle-01's IMU as a generic CSV", "t,ax,ay,az,gx,gy,gz,qw,qx,qy,qz"] + [
        ",".join(repr(float(v)) for v in r) for r in rows]


def _csv_set(lines: list[str], row: int, col: int, value: str) -> list[str]:
    cells = lines[2 + row].split(",")
    cells[col] = value
    lines[2 + row] = ",".join(cells)
    return lines


def test_csv_multi_chunk_is_read_imu(tmp_path, small_chunks):
    lines = _csv_lines()
    lines.insert(1000, "# a comment among the rows")
    assert _same_arrays(_write(tmp_path, lines, "imu.csv")) >= 5


CSV_DAMAGE = {
    "not a number": lambda ln: _csv_set(ln, LATE, 3, "9.8x"),
    "times missing in two rows": lambda ln: _csv_set(_csv_set(ln, 500, 0, ""), LATE, 0, "nan"),
    "time repeats across a chunk's edge": lambda ln: _csv_set(ln, 300, 0, ln[2 + 299].split(",")[0]),
    "time goes back, a quaternion off before it": lambda ln: _csv_set(
        _csv_set(ln, 100, 7, "0.5"), LATE, 0, "1.0"),
    "quaternion norm": lambda ln: _csv_set(ln, LATE, 7, "0.5"),
    "gyro in degrees": lambda ln: _csv_set(ln, LATE, 4, "120.0"),
}


@pytest.mark.parametrize("damage", sorted(CSV_DAMAGE))
def test_csv_damage_late_gives_read_imus_message(tmp_path, small_chunks, damage):
    _same_refusal(tmp_path, _write(tmp_path, CSV_DAMAGE[damage](_csv_lines()), "imu.csv"))


@pytest.mark.parametrize("n", [1, 2, 7, 1000, 1001])
def test_counted_median_is_np_median(n):
    """The clock's median step from counts of its values, against np.median of them all:
    a handful of distinct steps (as a clock's) and continuous values, added in chunks."""
    rng = np.random.default_rng(15)
    for values in (0.01 + rng.integers(-3, 4, n) * 1e-15, rng.normal(0.01, 1e-4, n)):
        m = CountedMedian()
        for part in np.array_split(values, 4):
            m.add(part)
        assert m.median() == np.median(values)
    m = CountedMedian()
    m.add(np.array([0.01, np.nan, 0.02]))
    assert np.isnan(m.median()) and np.isnan(np.median([0.01, np.nan, 0.02]))


def test_truncated_last_line_alone_in_its_chunk(tmp_path, small_chunks):
    """A last line cut short and without its line break is a chunk of its own when streamed
    from the file, with no row once dropped: the samples are still read_imu's."""
    lines = _lines()
    path = tmp_path / "imu.txt"
    path.write_text("\n".join(lines) + "\n" + lines[-1][:20])
    assert _same_arrays(path) >= 5
    csv = _csv_lines()
    path = tmp_path / "imu.csv"
    path.write_text("\n".join(csv) + "\n" + csv[-1][:10])
    assert _same_arrays(path) >= 5


DATA = Path(__file__).resolve().parent / "data"
CORPUS = sorted([*DATA.glob("xsens/*.txt"), *DATA.glob("bad/imu-*/*"), *DATA.glob("bad/csv-*/*"),
                 *DATA.glob("bad/dot-*/*")])


def _outcome(read):
    try:
        return "read", read()
    except Exception as e:  # noqa: BLE001  (any error: the same type and message expected)
        return type(e).__name__, str(e)


@pytest.mark.parametrize("path", CORPUS, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_corpus_streams_as_read_imu(path, small_chunks):
    """Every IMU file of the test data (real MT Manager exports of several generations and
    delimiters, NaN cells, matrix orientation; the bad-input corpus): the stream reads what
    read_imu reads, or refuses it with its error."""
    whole = _outcome(lambda: read_imu(path, rate_hz=100.0))
    streamed = _outcome(lambda: list(imu_chunks(path, rate_hz=100.0)))
    assert streamed[0] == whole[0]
    if whole[0] != "read":
        assert streamed[1] == whole[1]
    elif whole[1].quat is not None:
        _same_arrays(path, rate_hz=100.0)
