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
