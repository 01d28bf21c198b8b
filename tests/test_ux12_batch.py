"""ux12: several sessions with --out DIR go to DIR/FOLDER_NAME, so two sessions whose folders
share a name (a lab's S01/pre and S02/pre) would share one work folder, the second taking
the first's outputs as its own and reported done. Refused as bad usage, before any work."""

from __future__ import annotations

import shutil

import pytest

from .conftest import REPO, run_cli


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    root = tmp_path_factory.mktemp("lab")
    for subject in ("S01", "S02"):
        shutil.copytree(REPO / "sample_sessions" / "circle-01", root / subject / "pre")
    return root


@pytest.mark.parametrize("command", [["calibrate"], ["fuse"], ["report"],
                                     ["run", "--through", "calibrate"]])
def test_two_sessions_of_one_name_are_refused_before_any_work(lab, command, tmp_path):
    out = tmp_path / "out"
    args = [command[0], lab / "S01" / "pre", lab / "S02" / "pre", "--out", out, *command[1:]]
    r = run_cli(*args)
    assert r.exit_code == 2, r.output
    assert "--out" in r.stderr and "S01/pre" in r.stderr and "S02/pre" in r.stderr
    assert "share the work folder" in r.stderr
    assert not out.exists()
    assert not (lab / "S01" / "pre" / "armtrack").exists()


def test_the_same_session_twice_is_named(lab, tmp_path):
    r = run_cli("calibrate", lab / "S01" / "pre", f"{lab / 'S01' / 'pre'}/", "--out",
                tmp_path / "out")
    assert r.exit_code == 2
    assert "is given twice" in r.stderr


def test_distinct_names_still_go_to_their_own_folders(lab, tmp_path):
    other = tmp_path / "S02-pre"
    shutil.copytree(lab / "S02" / "pre", other)
    out = tmp_path / "out"
    r = run_cli("calibrate", lab / "S01" / "pre", other, "--out", out)
    assert r.exit_code == 0, r.output
    assert (out / "pre" / "camera.yaml").is_file()
    assert (out / "S02-pre" / "camera.yaml").is_file()


@pytest.mark.parametrize("name", ["Session.toml", "session.toml.txt", "session (1).toml"])
def test_a_misnamed_session_toml_in_a_folder_of_sessions_fails_aloud(tmp_path, name):
    """A folder of sessions took only subfolders holding session.toml: one saved as
    Session.toml or session.toml.txt was skipped in silence (exit 0, with one other session
    not even a summary line). Now it is a session that fails, naming the file."""
    lab = tmp_path / "lab"
    for sub in ("a", "b"):
        shutil.copytree(REPO / "sample_sessions" / "reach-01", lab / sub)
    (lab / "b" / "session.toml").rename(lab / "b" / name)
    r = run_cli("calibrate", lab)
    assert r.exit_code == 1
    assert r.stdout.strip().splitlines()[-1] == "2 sessions: 1 done, 1 failed"
    assert f"b/session.toml: not found, but the folder holds '{name}'" in r.stderr
    assert (lab / "a" / "armtrack" / "camera.yaml").is_file()
    assert not (lab / "b" / "armtrack").exists()


def test_other_subfolders_are_still_not_sessions(tmp_path):
    lab = tmp_path / "lab"
    shutil.copytree(REPO / "sample_sessions" / "reach-01", lab / "a")
    (lab / "notes").mkdir()
    (lab / "notes" / "settings.toml").write_text("")
    r = run_cli("calibrate", lab)
    assert r.exit_code == 0, r.output
