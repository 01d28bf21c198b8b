"""Hostile inputs across every command (tests/hostile/cases.py): each gives exit code 1, one
line `error: FILE: …` naming the file to blame, and leaves every file as it was: no output
written, none changed, no temp file left."""

from __future__ import annotations

import hashlib
import shutil
import stat

import pytest

from armtrack_cli import pipeline

from .conftest import REPO, run_cli
from .hostile.cases import ARM_CASES, USAGE_CASES

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def worked(tmp_path_factory):
    """circle-01 with its work folder filled: calibrate, detect, fuse ekf, compare."""
    folder = tmp_path_factory.mktemp("hostile") / "circle-01"
    shutil.copytree(REPO / "sample_sessions" / "circle-01", folder)
    r = pipeline.run(folder, methods=("ekf",))
    assert set(r["stages"].values()) == {"ran"}
    return folder


def _snapshot(folder):
    out = {}
    for p in sorted(folder.rglob("*")):
        mode = p.lstat().st_mode
        rel = str(p.relative_to(folder))
        if stat.S_ISREG(mode):
            out[rel] = hashlib.sha256(p.read_bytes()).hexdigest()
        else:
            out[rel] = stat.S_IFMT(mode)
    return out


def test_the_corpus_is_large():
    assert len(ARM_CASES) >= 100
    assert len({c[0] for c in ARM_CASES}) == len(ARM_CASES)


@pytest.mark.parametrize("name,args,mutate,file,phrase", ARM_CASES, ids=[c[0] for c in ARM_CASES])
def test_hostile_input_gives_one_clear_line(tmp_path, worked, name, args, mutate, file, phrase):
    folder = tmp_path / "s"
    shutil.copytree(worked, folder, symlinks=True)
    mutate(folder)
    before = _snapshot(folder)
    r = run_cli(*[a.replace("{S}", str(folder)) for a in args])
    assert r.exit_code == 1, (r.exit_code, r.stdout, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    line = lines[0]
    assert line.startswith("error: ") and "internal error" not in line, line
    named = line[len("error: "):].split(": ", 1)[0]
    assert named.endswith(file), line
    assert phrase in line, line
    assert _snapshot(folder) == before


@pytest.mark.parametrize("args,option", USAGE_CASES, ids=[" ".join(c[0][:1] + c[0][2:]) for c in USAGE_CASES])
def test_wrong_usage_names_the_option(tmp_path, worked, args, option):
    before = _snapshot(worked)
    r = run_cli(*[a.replace("{S}", str(worked)) for a in args])
    assert r.exit_code == 2 and option in r.stderr and "Traceback" not in r.stderr, r.stderr
    assert _snapshot(worked) == before
