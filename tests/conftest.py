"""Shared fixtures: paths, a CLI runner, and small session folders built in tmp dirs."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from armtrack_cli.cli import main

TESTS = Path(__file__).resolve().parent
DATA = TESTS / "data"
REPO = TESTS.parent


def run_cli(*args: str):
    """Invoke `armtrack ARGS` in-process; returns click's Result (stdout, stderr, exit_code)."""
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


@pytest.fixture
def cli():
    return run_cli


def write_session(folder: Path, toml: str, files: dict[str, bytes | str] | None = None) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "session.toml").write_text(toml)
    for name, content in (files or {}).items():
        p = folder / name
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(content if isinstance(content, bytes) else content.encode())
    return folder


def detected_sample(tmp_path_factory, name: str = "circle-01") -> Path:
    """A copy of a bundled sample session (without its armtrack/ outputs), calibrated and
    detected, in a fresh tmp folder: for module fixtures of tests that fuse it."""
    import shutil

    from armtrack_cli import pipeline

    folder = tmp_path_factory.mktemp("detected") / name
    shutil.copytree(REPO / "sample_sessions" / name, folder,
                    ignore=shutil.ignore_patterns("armtrack"))
    pipeline.run(folder, through="detect")
    return folder
