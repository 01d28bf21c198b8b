"""`armtrack info` checks the names [groundtruth] gives — markers, mid(…) joint centres, the
landmarks clusters carry from the static trial, the clusters themselves and a 6DOF hand body —
against the files, lists each one compare could not find on a line of its own, and fails
(exit 1, one error line, nothing written) exactly where compare would."""

from __future__ import annotations

import json

import numpy as np
import pytest

from armtrack_cli.core.errors import GroundTruthError
from armtrack_cli.pipeline.groundtruth import read_truth
from armtrack_cli.session.config import load_session

from .conftest import run_cli
from .test_vicon_cast import _vicon_csv

CLUSTERS = [f"RUAR{k}" for k in range(1, 5)] + [f"RLAR{k}" for k in range(1, 5)]
LANDMARKS = ["RGTH", "RLEP", "RMEP", "RSPR", "RSPU"]


def _lab(tmp_path, markers: str, clusters: str):
    """A static trial (clusters + landmarks) and a movement trial (clusters only; a Nexus export
    keeps the unworn landmarks' columns, empty), and a session naming joints from them."""
    rng = np.random.default_rng(3)
    static = rng.uniform(-400, 400, (20, len(CLUSTERS) + len(LANDMARKS), 3))
    static = static[:1].repeat(20, axis=0) + rng.normal(0, 0.1, static.shape)
    (tmp_path / "static.csv").write_bytes(_vicon_csv(CLUSTERS + LANDMARKS, static))
    trial = static[:1].repeat(30, axis=0) + np.linspace(0, 50, 30)[:, None, None]
    trial[:, len(CLUSTERS):] = np.nan
    (tmp_path / "trial.csv").write_bytes(_vicon_csv(CLUSTERS + LANDMARKS, trial))
    (tmp_path / "session.toml").write_text(
        f'[groundtruth]\nfile = "trial.csv"\nstatic = "static.csv"\nmarkers = {{ {markers} }}\n'
        f"clusters = {{ {clusters} }}\n")
    return tmp_path


GOOD_CLUSTERS = ('RGTH = "RUAR", RLEP = "RUAR", RMEP = "RUAR", RSPR = "RLAR", '
                 'RSPU = ["RLAR1", "RLAR2", "RLAR3"]')
GOOD_MARKERS = 'shoulder = "RGTH", elbow = "mid(RLEP, RMEP)", wrist = "mid(RSPR, RSPU)"'


def test_names_that_compare_finds_pass_and_are_described(tmp_path):
    folder = _lab(tmp_path, GOOD_MARKERS, GOOD_CLUSTERS)
    r = run_cli("info", folder, "--json")
    assert r.exit_code == 0, r.stderr
    gt = json.loads(r.stdout)["groundtruth"]
    assert gt["problems"] == [] and gt["named"]["elbow"] == "mid(RLEP, RMEP)"
    assert "static" in gt
    assert run_cli("info", folder).exit_code == 0


def test_each_missing_name_is_one_line_and_info_fails_as_compare_would(tmp_path):
    markers = 'shoulder = "RGTH", elbow = "mid(RLEP, RMEQ)", wrist = "mid(RSPR, RSPU)"'
    clusters = 'RGTH = "RUAX", RLEP = "RUAR", RSPR = "RLAR", RSPU = ["RLAR1", "RLAR2", "RLAR9"]'
    folder = _lab(tmp_path, markers, clusters)
    out = tmp_path / "out"
    r = run_cli("info", folder, "--out", out)
    assert r.exit_code == 1
    missing = [ln.strip() for ln in r.stdout.splitlines() if ln.strip().startswith("missing: ")]
    assert len(missing) == 3, r.stdout  # the description is printed, one line per problem
    assert "static.csv: has 0 markers of the cluster carrying 'RGTH'" in missing[0]
    assert "trial.csv: has no marker 'RMEQ'" in missing[1]
    assert "trial.csv: has no marker 'RLAR9' of the cluster carrying 'RSPU'" in missing[2]
    err = r.stderr.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ") and "static.csv" in err[0]
    assert "(and 2 more, listed above)" in err[0]
    assert not out.exists()  # nothing written
    with pytest.raises(GroundTruthError, match="has 0 markers of the cluster carrying 'RGTH'"):
        read_truth(load_session(folder))  # what compare reads fails on the first too


def test_a_landmark_only_in_the_static_trial_needs_its_cluster(tmp_path):
    folder = _lab(tmp_path, GOOD_MARKERS, GOOD_CLUSTERS.replace('RMEP = "RUAR", ', ""))
    r = run_cli("info", folder, "--json")
    assert r.exit_code == 1
    problems = json.loads(r.stdout)["groundtruth"]["problems"]
    assert len(problems) == 1 and "'RMEP'" in problems[0]
    assert json.loads(r.stdout)["methods"]["compare"].startswith("needs the 1 name(s)")
    assert "it is in the static trial: name its cluster in [groundtruth] clusters" in problems[0]


def test_a_missing_6dof_hand_body_is_listed(tmp_path):
    from .test_groundtruth_formats import format_6dof

    R = np.tile(np.eye(3), (5, 1, 1, 1))
    (tmp_path / "hand.tsv").write_text(format_6dof(["hand"], np.full((5, 1, 3), 0.3), R, 100.0))
    (tmp_path / "session.toml").write_text('[groundtruth]\nfile = "hand.tsv"\n'
                                           'markers = { wrist = "hand" }\nhand = "palm"\n')
    r = run_cli("info", tmp_path, "--json")
    assert r.exit_code == 1
    problems = json.loads(r.stdout)["groundtruth"]["problems"]
    assert len(problems) == 1 and "no rigid body 'palm'" in problems[0]
