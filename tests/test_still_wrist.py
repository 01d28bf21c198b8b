"""Page 1 does not list a still wrist's path measures as key measures (ux13: a palm session's
forearm held still gave 0.010 ± 0.002 m/s peak speed and nine "movements", the estimate's noise)."""

from __future__ import annotations

from armtrack_cli.report import summary

from .test_ux13_report import kin, report

PATHS = [("wrist_mean_speed", 0.003, 0.0003), ("movement_units", 0.0, 0.0), ("segments", 9.0, float("nan"))]


def test_a_peak_within_two_sd_of_still_lists_no_path_measures():
    r = report(kind="palm", kinematics=kin([("wrist_peak_speed", 0.01031, 0.001874), *PATHS]))
    text = " | ".join(summary.key_lines(r))
    assert "no clear movement" in text and "0.010 m/s" in text
    assert "movement units" not in text and "separate movements" not in text


def test_a_clear_movement_lists_them():
    r = report(kinematics=kin([("wrist_peak_speed", 0.214, 0.026), *PATHS]))
    text = " | ".join(summary.key_lines(r))
    assert "no clear movement" not in text
    assert "movement units" in text and "separate movements found: 9" in text
    slow = report(kinematics=kin([("wrist_peak_speed", 0.05, float("nan")), *PATHS]))
    assert summary.barely_moved(slow) is None  # 5 cm/s, no SD: moved
