"""cohort.csv's data-quality columns are the report's: duration_s is the span the measures
were taken over, recorded_s the trajectory's; a palm session's frames are the video's and its
detected_pct the share with three blobs or more (ux13's findings)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from armtrack_cli.pipeline import batch
from armtrack_cli.session.outputs import write_rows
from armtrack_cli.session.workfolder import WorkFolder


def _kinematics(path, t0, t1):
    write_rows(path, [{"measure": "wrist_peak_speed", "segment": "session", "value": "0.2",
                       "sd": 0.01, "unit": "m/s", "t_start": t0, "t_end": t1}], command="fuse")


def test_duration_is_the_measured_span_and_recorded_the_whole(tmp_path):
    t = np.arange(600) / 30.0
    x = np.where(t < 3.0, np.nan, 0.1)  # no wrist for the first 3 s
    (tmp_path / "trajectory-pf.csv").write_text(
        "t,wrist_x\n" + "".join(f"{a:.6f},{'' if np.isnan(b) else b}\n" for a, b in zip(t, x)))
    _kinematics(tmp_path / "kinematics-pf.csv", 3.0, float(t[-1]))
    (tmp_path / "detections.csv").write_text(
        "frame,t,u,v,ok\n" + "".join(f"{i},{i / 30:.6f},1,1,{int(i >= 90)}\n" for i in range(600)))
    row = batch._quality(WorkFolder(tmp_path), "pf", SimpleNamespace(kind="arm", camera=None))
    assert row["duration_s"] == pytest.approx(17.0, abs=1e-6)  # 3.0 … 19.967 s, one frame more
    assert row["recorded_s"] == pytest.approx(20.0, abs=1e-6)
    assert row["frames"] == 600 and row["detected_pct"] == pytest.approx(85.0)


def test_a_palm_sessions_frames_are_the_videos(tmp_path, monkeypatch):
    monkeypatch.setattr(batch, "video_frames", lambda session: 100)
    rows = [f"{i},{i / 30:.6f},{b},1,1,10,0.9\n" for i in range(50) for b in range(3)]
    (tmp_path / "detections.csv").write_text("frame,t,blob,u,v,area,score\n" + "".join(rows))
    row = batch._quality(WorkFolder(tmp_path), "ukf-palm", SimpleNamespace(kind="palm"))
    assert row["frames"] == 100 and row["detected_pct"] == pytest.approx(50.0)  # not 50, 100 %
    assert np.isnan(row["duration_s"]) and np.isnan(row["recorded_s"])  # not fused: missing


def test_the_columns_come_in_the_documented_order():
    first = batch.COHORT_FIRST
    assert first.index("duration_s") + 1 == first.index("recorded_s")
