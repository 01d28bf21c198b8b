"""ux12: valid exports the readers refused or misread, and damaged ones that ended in an
internal error; each test checked to fail before its fix. The reference for each valid
variant is the bundled file as armtrack reads it."""

from __future__ import annotations

import numpy as np
import pytest

from armtrack_cli.core.errors import GroundTruthError
from armtrack_cli.session.qualisys import read_qualisys

from .conftest import REPO

QTM = REPO / "sample_sessions" / "circle-01" / "qualisys.tsv"


def _table_at(lines: list[str]) -> int:
    return next(i for i, ln in enumerate(lines) if ln.startswith("Frame\t"))


def _same_markers(a, b) -> None:
    assert a.names == b.names
    np.testing.assert_array_equal(a.t, b.t)
    np.testing.assert_array_equal(a.xyz, b.xyz)  # NaN gaps in the same places


def test_qtm_names_row_without_frame_and_time_columns(tmp_path):
    """QTM with 'Include frame/time' off writes `R_SHO X …` as the table's first row."""
    lines = QTM.read_text().splitlines()
    at = _table_at(lines)
    cut = lines[:at] + ["\t".join(ln.split("\t")[2:]) for ln in lines[at:]]
    p = tmp_path / "q.tsv"
    p.write_text("\n".join(cut) + "\n")
    _same_markers(read_qualisys(p), read_qualisys(QTM))


def test_qtm_names_row_of_the_wrong_width_is_one_clear_error(tmp_path):
    lines = QTM.read_text().splitlines()
    at = _table_at(lines)
    lines = lines[:at] + [lines[at] + "\tType"] + [ln + "\t" for ln in lines[at + 1:]]
    p = tmp_path / "q.tsv"
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(GroundTruthError, match="does not fit 3 markers"):
        read_qualisys(p)  # was: ValueError (cannot reshape), an internal error


def _generic_csv_rows() -> tuple[list[str], list[list[str]]]:
    rng = np.random.default_rng(12)
    n = 300
    t = np.arange(n) * 0.01
    acc = np.array([0.0, 0.2, 9.81]) + 0.05 * rng.standard_normal((n, 3))
    gyr = 0.1 * rng.standard_normal((n, 3))
    q = np.array([0.99, 0.05, 0.02, 0.1]) + 0.01 * rng.standard_normal((n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    names = ["t", "ax", "ay", "az", "gx", "gy", "gz", "qw", "qx", "qy", "qz"]
    rows = [[f"{v:.6f}" for v in r] for r in np.column_stack([t, acc, gyr, q])]
    return names, rows


def _write(p, names, rows):
    p.write_text("\n".join([",".join(names)] + [",".join(r) for r in rows]) + "\n")
    return p


@pytest.mark.parametrize("variant", ["index-and-temperature", "reordered", "quoted-header"])
def test_generic_csv_by_column_name(tmp_path, variant):
    """The generic CSV is read by its column names: an extra index or temperature column,
    another column order, or R's write.csv quoting the names read as the plain file does
    (each was 'not an IMU format armtrack reads')."""
    from armtrack_cli.session.imu import read_imu

    names, rows = _generic_csv_rows()
    ref = read_imu(_write(tmp_path / "plain.csv", names, rows))
    if variant == "index-and-temperature":
        names = ["idx"] + names + ["temp_c"]
        rows = [[str(i)] + r + ["25.0"] for i, r in enumerate(rows)]
    elif variant == "reordered":
        order = [7, 8, 9, 10, 0, 4, 5, 6, 1, 2, 3]
        names, rows = [names[k] for k in order], [[r[k] for k in order] for r in rows]
    else:
        names = [f'"{n}"' for n in names]
    got = read_imu(_write(tmp_path / "imu.csv", names, rows))
    assert got.fmt == ref.fmt == "csv"
    for field in ("t", "acc", "gyr", "quat"):
        np.testing.assert_array_equal(getattr(got, field), getattr(ref, field))
    assert got.rate_hz == ref.rate_hz


VIDEO = REPO / "sample_sessions" / "circle-01" / "video.mp4"


def _video_with_times(tmp_path, text: str):
    import shutil

    from armtrack_cli.session.video import probe_video

    shutil.copy(VIDEO, tmp_path / "video.mp4")
    (tmp_path / "video_timestamps.csv").write_text(text)
    return lambda: probe_video(tmp_path / "video.mp4")


TIMES = [(i, i / 30 + 1e-4 * (i % 3)) for i in range(600)]


@pytest.mark.parametrize("times, phrase", [
    ([(i, t * 1000) for i, t in TIMES], "is it in ms"),
    ([(i, t + 1.7e9) for i, t in TIMES], "epoch or device clock"),
])
def test_video_timestamps_off_the_session_clock_are_refused(tmp_path, times, phrase):
    """Times in ms passed as a 5.5-hour video at 0.03 fps (fuse: an internal error, a
    broadcast ValueError); epoch times as a session starting 54 years late (fuse: 'no
    detection falls inside the IMU recording', blaming detections.csv)."""
    from armtrack_cli.core.errors import VideoError

    probe = _video_with_times(tmp_path, "frame,t\n" + "".join(f"{i},{t:.6f}\n"
                                                              for i, t in times))
    with pytest.raises(VideoError, match=phrase) as e:
        probe()
    assert "video_timestamps.csv" in str(e.value)


@pytest.mark.parametrize("text", [
    "# written by the camera driver\nframe,t\n" + "".join(f"{i},{t:.6f}\n" for i, t in TIMES),
    "frame\tt\n" + "".join(f"{i}\t{t:.6f}\n" for i, t in TIMES),
])
def test_video_timestamps_with_a_comment_or_tabs(tmp_path, text):
    v = _video_with_times(tmp_path, text)()
    np.testing.assert_array_equal(v.t, np.round([t for _, t in TIMES], 6))
    assert v.timestamps_from == "video_timestamps.csv"
