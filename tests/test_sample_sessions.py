"""The bundled sample sessions are exactly what their recorded command makes, and readable."""

from __future__ import annotations

import shlex

import pytest

from .conftest import REPO, run_cli

SAMPLES = REPO / "sample_sessions"
NAMES = sorted(p.name for p in SAMPLES.iterdir() if p.is_dir())


def test_there_are_the_three_promised_sessions_under_20_mb():
    assert NAMES == ["circle-01", "reach-01", "wrist-rom-01"]
    size = sum(p.stat().st_size for p in SAMPLES.rglob("*") if p.is_file())
    assert size < 20e6


@pytest.mark.parametrize("name", NAMES)
def test_sample_is_what_its_recorded_command_makes(tmp_path, name):
    first = (SAMPLES / name / "session.toml").read_text().splitlines()[0]
    assert first.startswith("# simulated by: armtrack simulate ")
    args = shlex.split(first.removeprefix("# simulated by: armtrack "))
    args[1] = str(tmp_path / name)
    r = run_cli(*args)
    assert r.exit_code == 0, r.stderr
    made = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*") if p.is_file())
    for rel in made:
        assert (tmp_path / rel).read_bytes() == (SAMPLES / rel).read_bytes(), \
            f"{rel} differs: run `make samples` after changing the simulator"


@pytest.mark.parametrize("name", NAMES)
def test_info_reads_every_sample(name):
    r = run_cli("info", SAMPLES / name, "--json")
    assert r.exit_code == 0, r.stderr
