"""A folder of sessions is a batch: one session's failure is reported, the others complete."""

from __future__ import annotations

import json
import shutil

import pytest

from .conftest import REPO, run_cli

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def cohort(tmp_path_factory):
    """Three copies of the circle sample and one whose imu.txt is corrupt."""
    root = tmp_path_factory.mktemp("cohort")
    for name in ("a-good", "b-good", "c-broken", "d-good"):
        shutil.copytree(REPO / "sample_sessions" / "circle-01", root / name)
    imu = root / "c-broken" / "imu.txt"
    lines = imu.read_text().splitlines()
    imu.write_text("\n".join(lines[:40] + ["1\t2\tthree\x00\x00garbage"] + lines[40:]) + "\n")
    return root


def test_every_stage_goes_on_past_the_broken_session(cohort):
    for stage in ("calibrate", "detect"):
        r = run_cli(stage, cohort)
        assert r.exit_code == 0, r.stderr
        assert r.stdout.strip().endswith("4 sessions: 4 done, 0 failed")
    r = run_cli("fuse", cohort, "--method", "ekf")
    assert r.exit_code == 1
    errors = r.stderr.strip().splitlines()
    assert len(errors) == 1 and errors[0].startswith("error: ")
    assert f"{cohort / 'c-broken' / 'imu.txt'}: " in errors[0]
    assert r.stdout.strip().splitlines()[-1] == "4 sessions: 3 done, 1 failed"
    for name in ("a-good", "b-good", "d-good"):
        assert (cohort / name / "armtrack" / "trajectory-ekf.csv").is_file()
        assert (cohort / name / "armtrack" / "kinematics-ekf.csv").is_file()
    assert not list((cohort / "c-broken" / "armtrack").glob("trajectory-*"))


def test_json_lists_each_session_outcome(cohort):
    r = run_cli("compare", cohort, "--json")
    assert r.exit_code == 1
    doc = json.loads(r.stdout)
    status = {o["session"].rsplit("/", 1)[-1]: o["status"] for o in doc["sessions"]}
    assert status == {"a-good": "done", "b-good": "done", "c-broken": "failed", "d-good": "done"}
    failed = next(o for o in doc["sessions"] if o["status"] == "failed")
    assert "c-broken" in failed["error"]
    assert doc["summary"] == "4 sessions: 3 done, 1 failed"
