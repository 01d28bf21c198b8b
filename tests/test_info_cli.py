"""`armtrack info` on sessions and files; the CLI reference in docs/ matches --help."""

from __future__ import annotations

import json

import numpy as np

from armtrack_cli.cli import render_reference
from armtrack_cli.session.export.qualisys import format_qtm_tsv
from armtrack_cli.session.export.xsens import format_mt_manager

from .conftest import DATA, REPO, run_cli, write_session


def _session(tmp_path):
    n = 1000
    t = np.arange(n) / 100.0
    keep = np.ones(n, bool)
    keep[[100, 101, 500]] = False
    q = np.tile([1.0, 0, 0, 0], (n, 1))
    imu = format_mt_manager(t[keep], np.tile([0, 0, 9.81], (keep.sum(), 1)),
                            np.zeros((keep.sum(), 3)), q[keep], style="legacy")
    wrist = np.c_[0.4 + 0.1 * np.cos(t), 0.2 + 0.1 * np.sin(t), np.full(n, 0.05)]
    gt = np.stack([np.tile([0.1, 0.45, 0.32], (n, 1)), wrist], 1)
    gt[300:320, 1] = np.nan
    toml = ('[session]\nid = "c1"\ntask = "circle"\n'
            '[arm]\nupper_arm_m = 0.31\nforearm_m = 0.27\nshoulder_m = [0.10, 0.45, 0.32]\n'
            '[imu]\nfile = "imu.txt"\n'
            '[groundtruth]\nfile = "qualisys.tsv"\nmarkers = { shoulder = "SHO", wrist = "WRI" }\n'
            '[sync]\nimu_offset_s = 0.25\ngroundtruth_offset_s = -1.0\n')
    return write_session(tmp_path / "c1", toml, {
        "imu.txt": imu, "qualisys.tsv": format_qtm_tsv(gt, ["SHO", "WRI"], 100.0)})


def test_info_text(tmp_path):
    r = run_cli("info", _session(tmp_path))
    assert r.exit_code == 0, r.stderr
    assert "997 samples at 100 Hz" in r.stdout
    assert "dropped samples 3 in 2 gaps" in r.stdout
    assert "session span 0.250 … 10.240 s" in r.stdout  # stream time + offset
    assert "WRI 2%" in r.stdout
    assert "pf-constraint needs video, intrinsics, board, patch" in r.stdout


def test_info_json_and_out(tmp_path):
    folder = _session(tmp_path)
    r = run_cli("info", folder, "--json", "--out", tmp_path / "o")
    info = json.loads(r.stdout)
    assert info["imu"]["dropped_samples"] == 3 and info["imu"]["span_s"] == [0.25, 10.24]
    assert info["groundtruth"]["span_s"] == [-1.0, 8.99]
    assert info["groundtruth"]["missing_pct"]["WRI"] == 2.0
    assert info["methods"]["compare"] == "ready"
    r = info["groundtruth"]["reach"]
    assert r["reach_m"] == 0.58 and r["beyond_reach_pct"] == 0.0
    assert json.loads((tmp_path / "o" / "info.json").read_text()) == info
    assert not (folder / "armtrack").exists()


def test_info_on_every_real_xsens_export():
    for p in sorted((DATA / "xsens").glob("MT*.txt")):
        r = run_cli("info", p, "--imu-rate", "100", "--json")
        assert r.exit_code == 0, r.stderr
        assert json.loads(r.stdout)["imu"]["orientation"] == "file"


def test_usage_errors_exit_2():
    assert run_cli("info").exit_code == 2
    assert run_cli("nonsense").exit_code == 2


def test_cli_reference_is_in_step_with_the_code():
    assert (REPO / "docs" / "cli.md").read_text() == render_reference(), \
        "docs/cli.md is stale: run `make docs`"
