"""Ctrl-C while a compiled (numba) kernel runs is still "interrupted", exit 130: numba raises
the KeyboardInterrupt as the cause of a SystemError ("CPUDispatcher(<function run …>)
returned a result with an exception set"), which the CLI took for a bug of its own (exit 1,
"internal error … please report it"; seen with SIGINT 1.9 s into `armtrack fuse` of a
460 s session, during the arm smoother's kernel)."""

from __future__ import annotations

import pytest

from armtrack_cli import pipeline

from .conftest import run_cli, write_session


def _numba_interrupted(*_a, **_k):
    try:
        raise KeyboardInterrupt
    except KeyboardInterrupt as exc:  # what numba's dispatcher raises over it
        raise SystemError("CPUDispatcher(<function run at 0x7f>) returned a result with an "
                          "exception set") from exc


def test_ctrl_c_inside_a_kernel_is_interrupted_and_130(tmp_path, monkeypatch):
    monkeypatch.setattr(pipeline, "fuse", _numba_interrupted)
    folder = write_session(tmp_path / "s", "[session]\nid = 's'\n")
    r = run_cli("fuse", folder)
    assert r.exit_code == 130, (r.exit_code, r.stderr)
    assert r.stderr.strip().splitlines() == ["error: interrupted"]


@pytest.mark.parametrize("cause", [None, ValueError("inner")])
def test_a_system_error_of_ours_is_still_an_internal_error(tmp_path, monkeypatch, cause):
    def broken(*_a, **_k):
        raise SystemError("something else") from cause

    monkeypatch.setattr(pipeline, "fuse", broken)
    folder = write_session(tmp_path / "s", "[session]\nid = 's'\n")
    r = run_cli("fuse", folder)
    assert r.exit_code == 1
    assert "internal error (SystemError: something else)" in r.stderr
