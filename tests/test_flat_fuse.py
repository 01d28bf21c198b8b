"""fuse a window at a time (issue 15, pipeline/fuse_windows.py): a session of one window runs
the whole-session path it always ran; with windows shrunk so that the 20 s sample session
is three, the windowed trajectory stays near the whole-session one; the IMU and detections
kept on disk read back exactly; a failure in a later window leaves nothing behind."""

from __future__ import annotations

import importlib
import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from armtrack_cli import pipeline
from armtrack_cli.core import windows as windows_mod
from armtrack_cli.core.errors import DataError
from armtrack_cli.core.streams import ImuSamples
from armtrack_cli.pipeline import fuse_span, fuse_windows
from armtrack_cli.pipeline.fuse_imu import ArrayImu, SpilledImu, chunks_of
from armtrack_cli.pipeline.fuse_summary import combined

from .conftest import REPO, detected_sample

fuse_stage = importlib.import_module("armtrack_cli.pipeline.fuse")
SHORT = (6.0, 3.0)  # inner span and margin, s: circle-01 (20 s) becomes three windows
POS_TOL_M = 0.005  # |windowed − whole| wrist and elbow: measured 0.0015 m at most here
#                   (3 s margins; at the default 20 s, 0.0002 m on the 10- and 60-minute
#                   bench sessions: docs/fusion.md "Long sessions")


@pytest.fixture(scope="module")
def detected(tmp_path_factory):
    return detected_sample(tmp_path_factory)


def _short_windows(monkeypatch) -> None:
    monkeypatch.setattr(windows_mod.windows, "__defaults__", SHORT)
    monkeypatch.setattr(windows_mod, "WINDOW_S", SHORT[0])
    monkeypatch.setattr(windows_mod, "MARGIN_S", SHORT[1])
    monkeypatch.setattr(fuse_span, "WINDOW_S", SHORT[0])
    monkeypatch.setattr(fuse_span, "MARGIN_S", SHORT[1])


def _work(detected: Path, tmp_path: Path, name: str) -> Path:
    out = tmp_path / name
    shutil.copytree(detected / "armtrack", out)
    return out


def test_a_one_window_session_runs_the_whole_session_path(detected, tmp_path, monkeypatch):
    def refuse(*a, **k):
        raise AssertionError("a one-window session ran windowed")

    monkeypatch.setattr(fuse_windows, "fuse_windowed", refuse)
    out = _work(detected, tmp_path, "one")
    summary = pipeline.fuse(detected, out=out)
    assert "windows" not in summary
    assert not list(out.glob(".spill-*"))


def test_windows_give_the_whole_sessions_trajectory_within_tolerance(detected, tmp_path,
                                                                     monkeypatch):
    whole_out = _work(detected, tmp_path, "whole")
    whole = pipeline.fuse(detected, out=whole_out)
    _short_windows(monkeypatch)
    win_out = _work(detected, tmp_path, "win")
    win = pipeline.fuse(detected, out=win_out)
    assert win["windows"] == {"count": 3, "window_s": SHORT[0], "margin_s": SHORT[1]}
    a = pd.read_csv(whole_out / "trajectory-arm-smoother.csv")
    b = pd.read_csv(win_out / "trajectory-arm-smoother.csv")
    assert list(a.columns) == list(b.columns) and len(a) == len(b)
    assert np.array_equal(a["t"], b["t"])
    for c in ("wrist_x", "wrist_y", "wrist_z", "elbow_x", "elbow_y", "elbow_z"):
        assert np.isfinite(a[c]).tolist() == np.isfinite(b[c]).tolist()
        assert np.nanmax(np.abs(a[c] - b[c])) < POS_TOL_M, c
    assert win["frames"] == whole["frames"]
    assert win["detections_used"] == whole["detections_used"]
    meta = json.loads((win_out / "trajectory-arm-smoother.meta.json").read_text())
    assert meta["settings"]["windows"]["count"] == 3
    k = pd.read_csv(win_out / "kinematics-arm-smoother.csv")
    assert len(k) == len(pd.read_csv(whole_out / "kinematics-arm-smoother.csv"))
    assert not list(win_out.glob(".spill-*"))  # the spills removed


def test_a_failure_in_the_second_window_leaves_nothing(detected, tmp_path, monkeypatch):
    _short_windows(monkeypatch)
    real = fuse_windows._Run._window

    def window(self, i, w):
        if i == 1:  # the method diverging in the second window, as fuse refuses it
            raise DataError(self.src.dest / self.name, "diverged in window 2")
        return real(self, i, w)

    monkeypatch.setattr(fuse_windows._Run, "_window", window)
    out = _work(detected, tmp_path, "fail")
    before = sorted(p.name for p in out.iterdir())
    with pytest.raises(DataError, match="window 2"):
        pipeline.fuse(detected, out=out)
    assert sorted(p.name for p in out.iterdir()) == before  # no trajectory, no spill


def _recording(n: int, seed: int = 3) -> ImuSamples:
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.005, 0.015, n))
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    acc, gyr = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    acc[rng.choice(n, 40, replace=False)] = np.nan  # unusable rows, dropped by both
    q[rng.choice(n, 40, replace=False), 2] = np.nan
    return ImuSamples("imu.csv", "csv", t, acc, gyr, None, q, 100.0)


@pytest.mark.parametrize("chunk", [1, 777, 1024, 5000])
def test_the_spilled_imu_reads_back_the_whole_readers_rows_exactly(tmp_path, chunk):
    imu = _recording(5000)
    whole = ArrayImu(imu)
    spilled = SpilledImu(tmp_path, chunks_of(imu, rows=chunk), rate_hz=100.0,
                         orientation_source="file", path="imu.csv")
    try:
        assert (spilled.t_first, spilled.t_last) == (whole.t_first, whole.t_last)
        rng = np.random.default_rng(chunk)
        spans = [(-1.0, 1e9), (imu.t[0], imu.t[0]), (imu.t[-1], imu.t[-1] + 1), (5.0, 4.0)]
        spans += [tuple(np.sort(rng.uniform(-1, imu.t[-1] + 1, 2))) for _ in range(30)]
        spans += [(imu.t[i], imu.t[j]) for i, j in rng.integers(0, 5000, (20, 2))]
        for lo, hi in spans:
            a, b = whole.rows(lo, hi), spilled.rows(lo, hi)
            for name in ("t", "quat", "acc", "gyr"):
                x, y = getattr(a, name), getattr(b, name)
                assert x.shape == y.shape and x.tobytes() == y.tobytes(), (lo, hi, name)
    finally:
        spilled.close()
    assert not list(tmp_path.iterdir())


def test_a_reader_failing_midway_leaves_no_spill(tmp_path):
    def chunks():
        yield from chunks_of(_recording(3000), rows=1000)
        raise DataError(Path("imu.txt"), "line 2001: damaged")

    with pytest.raises(DataError, match="imu.txt.*line 2001"):
        SpilledImu(tmp_path, chunks(), rate_hz=100.0, orientation_source="file", path="imu.txt")
    assert not list(tmp_path.iterdir())


def test_window_summaries_combine_as_documented():
    parts = [({"gated_frames": 2, "smoother_iterations_run": 4, "orientation_error_rms_deg": 1.0,
               "accel_bias_m_s2": [0.1, 0.2, 0.3], "shoulder_mean_m": [0.1, 0.2, 0.3],
               "upper_arm_change_m": [0.30, 0.31], "orientation_error_model": "gyro"}, 100),
             ({"gated_frames": 3, "smoother_iterations_run": 3, "orientation_error_rms_deg": 2.0,
               "accel_bias_m_s2": [0.4, 0.5, 0.6], "shoulder_mean_m": [0.4, 0.5, 0.6],
               "upper_arm_change_m": [0.29, 0.305], "orientation_error_model": "gyro"}, 300)]
    out = combined(parts)
    assert out["gated_frames"] == 5 and out["smoother_iterations_run"] == 4
    assert out["orientation_error_rms_deg"] == round(np.sqrt((100 * 1 + 300 * 4) / 400), 3)
    assert out["accel_bias_m_s2"] == [0.4, 0.5, 0.6]  # the session's last frame's
    assert out["shoulder_mean_m"] == [0.325, 0.425, 0.525]
    assert out["upper_arm_change_m"] == [0.29, 0.31]
    assert out["orientation_error_model"] == "gyro"


def test_the_gate_fuse_asks_first(detected, monkeypatch):
    from armtrack_cli.session.config import load_session

    session = load_session(detected)
    assert not fuse_stage._longer_than_a_window(session)  # 20 s: one window
    _short_windows(monkeypatch)
    assert fuse_stage._longer_than_a_window(session)
    assert len(windows_mod.windows(0.0, 600.0, 300.0, 20.0)) == 2  # the 10-minute bench


@pytest.mark.filterwarnings("ignore:.*clock offset")  # 2 s of detections in the first span
def test_a_window_without_a_detection_leaves_its_rows_empty(detected, tmp_path, monkeypatch):
    _short_windows(monkeypatch)
    out = _work(detected, tmp_path, "gap")
    det = pd.read_csv(out / "detections.csv")
    gap = (det["t"] >= 2.0) & (det["t"] < 16.0)  # no detection in window 2 (it reads 3-15 s)
    det.loc[gap, "ok"] = 0
    det.to_csv(out / "detections.csv", index=False, float_format="%.6f")
    summary = pipeline.fuse(detected, out=out)
    tab = pd.read_csv(out / "trajectory-arm-smoother.csv")
    # window 2's rows and window 3's before 16 s, but those window 1 ran over (to 9 s)
    empty = (tab["t"] > 9.0 + 1e-6) & (tab["t"] < 16.0)
    assert tab.loc[empty, "wrist_x"].isna().all()
    assert np.isfinite(tab.loc[~empty, "wrist_x"]).all()
    assert summary["frames"] == int((~empty).sum())


def _imu_cut(detected: Path, folder: Path, lo_s: float, hi_s: float) -> Path:
    """A copy of the detected session without the IMU's samples from lo_s to hi_s s of its
    recording (its own clock, from its first sample)."""
    shutil.copytree(detected, folder, ignore=shutil.ignore_patterns("armtrack"))
    lines = (folder / "imu.txt").read_text().splitlines(keepends=True)
    t0 = int(next(line for line in lines if line[:1].isdigit()).split("\t")[1])  # 10 kHz
    keep = [line for line in lines if not line[:1].isdigit()
            or not lo_s * 1e4 <= int(line.split("\t")[1]) - t0 < hi_s * 1e4]
    (folder / "imu.txt").write_text("".join(keep))
    return folder


def _imu_switched_on_late(detected: Path, tmp_path: Path, late_s: float) -> Path:
    """A copy of the detected session whose IMU export starts ``late_s`` s into its recording
    (its clock starts at its first sample, so the declared offset grows by late_s)."""
    folder = _imu_cut(detected, tmp_path / "late-imu", 0.0, late_s)
    toml = (folder / "session.toml").read_text()
    assert "imu_offset_s = -1\n" in toml
    (folder / "session.toml").write_text(
        toml.replace("imu_offset_s = -1\n", f"imu_offset_s = {late_s - 1:g}\n"))
    return folder


@pytest.mark.filterwarnings("ignore:.*clock offset")  # the first span: a few s of detections
def test_an_imu_switched_on_after_the_first_span_still_fuses(detected, tmp_path, monkeypatch):
    # the IMU's recording starts at 11 s on the session clock: the offset's first span (one
    # window and its margins, 6 s here) from the video's first detection (0 s) held none of
    # its samples and fuse refused "no detection falls inside the IMU recording"; the whole
    # session's path fuses it from its first detection inside the IMU's span (11 s)
    session = _imu_switched_on_late(detected, tmp_path, 12.0)
    whole_out = _work(detected, tmp_path, "late-whole")
    monkeypatch.setattr(fuse_stage, "_longer_than_a_window", lambda s: False)
    whole = pipeline.fuse(session, out=whole_out)
    monkeypatch.undo()
    short = (3.0, 1.5)  # frames 11-20 s: three windows
    monkeypatch.setattr(windows_mod.windows, "__defaults__", short)
    for mod in (windows_mod, fuse_span):
        monkeypatch.setattr(mod, "WINDOW_S", short[0])
        monkeypatch.setattr(mod, "MARGIN_S", short[1])
    win_out = _work(detected, tmp_path, "late-win")
    win = pipeline.fuse(session, out=win_out)
    assert win["windows"]["count"] == 3
    assert win["frames"] == whole["frames"]
    a = pd.read_csv(whole_out / "trajectory-arm-smoother.csv")
    b = pd.read_csv(win_out / "trajectory-arm-smoother.csv")
    assert np.array_equal(a["t"], b["t"])
    assert np.isfinite(a["wrist_x"]).tolist() == np.isfinite(b["wrist_x"]).tolist()
    assert a.loc[a["t"] < 10.9, "wrist_x"].isna().all()  # before the IMU: empty in both
    assert np.nanmax(np.abs(a["wrist_x"] - b["wrist_x"])) < POS_TOL_M


def test_a_false_detection_where_a_window_starts_is_gated_as_whole(detected, tmp_path,
                                                                   monkeypatch):
    # one false detection (the bottom-right corner: its ray passes ~50 cm outside the arm's
    # reach) at 3.0 s, the first frame window 2 reads (inner 6-12 s, margins 3 s): window 2
    # was initialised from it and _initial_state refused the whole session ("[arm] cannot
    # explain the first detection"); a whole-session run gates it and fuses every frame
    whole_out = _work(detected, tmp_path, "false-whole")
    det = pd.read_csv(whole_out / "detections.csv")
    k = int(np.flatnonzero(np.isclose(det["t"], 3.0, atol=1e-4))[0])
    det.loc[k, ["u", "v"]] = [630.0, 470.0]
    det.to_csv(whole_out / "detections.csv", index=False, float_format="%.6f")
    win_out = _work(detected, tmp_path, "false-win")
    shutil.copy(whole_out / "detections.csv", win_out / "detections.csv")
    whole = pipeline.fuse(detected, out=whole_out)
    assert whole["detections_gated"] >= 1  # the whole run: gated
    _short_windows(monkeypatch)
    win = pipeline.fuse(detected, out=win_out)
    assert win["windows"]["count"] == 3 and win["frames"] == whole["frames"]
    a = pd.read_csv(whole_out / "trajectory-arm-smoother.csv")
    b = pd.read_csv(win_out / "trajectory-arm-smoother.csv")
    for c in ("wrist_x", "wrist_y", "wrist_z"):
        assert np.isfinite(b[c]).all()
        assert np.max(np.abs(a[c] - b[c])) < POS_TOL_M, c


def test_a_patch_lost_across_a_seam_is_predicted_through_as_whole(detected, tmp_path,
                                                                 monkeypatch):
    # no detection from 2.0 to 7.0 s: window 2 (inner 6-12 s, read from 3 s) starts at 7 s.
    # Its rows 6-7 s were left empty, though window 1 ran over them (to 9 s) as the whole
    # run does; a 1 s hole, longer than the measures bridge (0.5 s), made every path measure
    # of the session "not computable" where the whole run gives them all
    whole_out = _work(detected, tmp_path, "seam-whole")
    det = pd.read_csv(whole_out / "detections.csv")
    det.loc[(det["t"] >= 2.0) & (det["t"] < 7.0), "ok"] = 0
    det.to_csv(whole_out / "detections.csv", index=False, float_format="%.6f")
    win_out = _work(detected, tmp_path, "seam-win")
    shutil.copy(whole_out / "detections.csv", win_out / "detections.csv")
    whole = pipeline.fuse(detected, out=whole_out)
    _short_windows(monkeypatch)
    win = pipeline.fuse(detected, out=win_out)
    assert win["frames"] == whole["frames"]
    a = pd.read_csv(whole_out / "trajectory-arm-smoother.csv")
    b = pd.read_csv(win_out / "trajectory-arm-smoother.csv")
    for c in ("wrist_x", "wrist_y", "wrist_z", "elbow_x", "elbow_y", "elbow_z"):
        assert np.isfinite(b[c]).all(), c
        assert np.max(np.abs(a[c] - b[c])) < POS_TOL_M, c  # measured 3.7 mm
    ka = pd.read_csv(whole_out / "kinematics-arm-smoother.csv")
    kb = pd.read_csv(win_out / "kinematics-arm-smoother.csv")
    assert len(kb) == len(ka)
    assert not kb["value"].astype(str).str.contains("gap in the wrist").any()


def test_an_imu_gap_where_a_window_starts_is_held_over_as_whole(detected, tmp_path,
                                                                monkeypatch):
    # the IMU silent from 1.5 to 3.5 s on the session clock (2.5-4.5 s of its own): window 2
    # reads from 3.0 s, its IMU from 2.0 s, both in the gap. Its samples started after its
    # first frames, whose orientation was NaN: fuse failed with an internal error ("min()
    # arg is an empty sequence" in the initial state). The whole run holds the samples
    # either side of the gap over it; the window now reads them too
    session = _imu_cut(detected, tmp_path / "imu-gap", 2.5, 4.5)
    whole_out = _work(detected, tmp_path, "gap-whole")
    monkeypatch.setattr(fuse_stage, "_longer_than_a_window", lambda s: False)
    whole = pipeline.fuse(session, out=whole_out)
    monkeypatch.undo()
    _short_windows(monkeypatch)
    win_out = _work(detected, tmp_path, "gap-win")
    win = pipeline.fuse(session, out=win_out)
    assert win["windows"]["count"] == 3 and win["frames"] == whole["frames"]
    a = pd.read_csv(whole_out / "trajectory-arm-smoother.csv")
    b = pd.read_csv(win_out / "trajectory-arm-smoother.csv")
    assert np.isfinite(a["wrist_x"]).all() and np.isfinite(b["wrist_x"]).all()
    truth = np.load(REPO / "sample_sessions" / "circle-01.truth.npz")
    assert np.allclose(truth["frame_t"], b["t"], atol=1e-4)
    after = b["t"].to_numpy() >= 6.0  # windows 2 and 3's own rows, 2.5 s past the gap
    err = np.linalg.norm(b[["wrist_x", "wrist_y", "wrist_z"]].to_numpy()
                         - truth["frame_wrist"], axis=1)[after]
    assert np.sqrt(np.mean(err**2)) < 0.01  # measured 0.26 cm (the whole run 0.68 cm)


def test_an_imu_gap_where_a_window_ends_is_held_over_as_whole(detected, tmp_path,
                                                              monkeypatch):
    # the IMU silent from 8 to 10 s on the session clock: window 1 (inner 0-6 s) reads frames
    # to 9 s, its last ones in the gap with no sample after them (on a 460 s session with the
    # IMU silent 318-325 s, that alone made fuse refuse it: "arm-smoother diverged: its
    # estimate is not finite from t = 0.000 s"), and window 3 starts in it at 9 s (an
    # internal error, as in the test above)
    session = _imu_cut(detected, tmp_path / "imu-gap-end", 9.0, 11.0)
    _short_windows(monkeypatch)
    out = _work(detected, tmp_path, "gap-end")
    win = pipeline.fuse(session, out=out)
    assert win["windows"]["count"] == 3
    b = pd.read_csv(out / "trajectory-arm-smoother.csv")
    assert np.isfinite(b["wrist_x"]).all()
    truth = np.load(REPO / "sample_sessions" / "circle-01.truth.npz")
    own = b["t"].to_numpy() < 6.0  # window 1's rows, 2 s before the gap
    err = np.linalg.norm(b[["wrist_x", "wrist_y", "wrist_z"]].to_numpy()
                         - truth["frame_wrist"], axis=1)[own]
    assert np.sqrt(np.mean(err**2)) < 0.01
