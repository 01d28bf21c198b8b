"""Every malformed input in tests/data/bad/ gives one clear line, exit 1, and writes nothing."""

from __future__ import annotations

import shutil
import sys

import pytest

from .conftest import DATA, run_cli

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

BAD = DATA / "bad"
CASES = tomllib.loads((BAD / "cases.toml").read_text())


def test_the_corpus_is_large_and_complete():
    assert len(CASES) >= 40
    assert {p.name for p in BAD.iterdir() if p.is_dir()} == set(CASES)


@pytest.mark.parametrize("name", sorted(CASES))
@pytest.mark.filterwarnings("error::RuntimeWarning")  # numpy's, printed before the error line
def test_bad_input_gives_one_clear_line(tmp_path, name):
    case = CASES[name]
    folder = tmp_path / name
    shutil.copytree(BAD / name, folder)
    before = sorted(p.relative_to(folder) for p in folder.rglob("*"))
    out = tmp_path / "out"
    result = run_cli("info", folder, "--out", out)
    assert result.exit_code == 1, result.stdout
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    line = lines[0]
    assert line.startswith("error: ") and "Traceback" not in result.output
    assert "internal error" not in line
    named = line[len("error: "):].split(": ", 1)[0]
    assert named.endswith(case["file"]), line
    assert case["expect"] in line, line
    assert sorted(p.relative_to(folder) for p in folder.rglob("*")) == before
    assert not out.exists()


def test_palm_blobs_with_a_damaged_row_name_the_file(tmp_path):
    """A palm detections.csv whose row is text, or whose frame is not whole: one DataError
    naming the file (it used to be an internal TypeError)."""
    from armtrack_cli.core.errors import DataError
    from armtrack_cli.session.palm_io import read_palm_blobs

    head = "frame,t,blob,u,v,area\n0,0.0,0,10.5,20.5,30\n"
    for bad, why in (("garbage,x,,,,\n", "not a number"), ("1.5,0.03,0,1,1,1\n", "whole frame")):
        p = tmp_path / "detections.csv"
        p.write_text(head + bad)
        with pytest.raises(DataError, match=why) as e:
            read_palm_blobs(p, n_frames=5)
        assert "detections.csv" in str(e.value)
