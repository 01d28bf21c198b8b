"""armtrack installed from its wheel (not the checkout) works from any folder.

A regular, non-editable install into a fresh venv, with the locked versions; then, from a
folder outside the checkout, calibrate -> detect -> fuse with a bundled recipe found by name
-> compare on a copied sample session.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import venv

import pytest

from .conftest import REPO

pytestmark = pytest.mark.slow


def _run(cmd, cwd, env=None):
    r = subprocess.run([str(c) for c in cmd], cwd=cwd, env=env, capture_output=True, text=True)
    assert r.returncode == 0, f"{cmd}: {r.stdout}\n{r.stderr}"
    return r


def test_wheel_in_a_fresh_venv_runs_a_session_from_another_folder(tmp_path):
    src, wheels = tmp_path / "src", tmp_path / "wheels"  # built from a copy: no build/ left here
    shutil.copytree(REPO / "armtrack_cli", src / "armtrack_cli",
                    ignore=shutil.ignore_patterns("__pycache__"))
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(REPO / name, src / name)
    _run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "--no-build-isolation",
          "-w", wheels, src], cwd=tmp_path)
    (wheel,) = wheels.glob("armtrack-*.whl")
    env_dir = tmp_path / "venv"
    venv.create(env_dir, with_pip=True)
    py = env_dir / "bin" / "python"
    _run([py, "-m", "pip", "install", "--quiet", "-c", REPO / "requirements.lock", wheel],
         cwd=tmp_path)
    work = tmp_path / "elsewhere"
    shutil.copytree(REPO / "sample_sessions" / "circle-01", work / "circle-01")
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "ARMTRACK_RECIPES")}
    where = _run([py, "-c", "import armtrack_cli; print(armtrack_cli.__file__)"], work, env)
    assert str(env_dir) in where.stdout and str(REPO) not in where.stdout
    armtrack = env_dir / "bin" / "armtrack"
    for args in (["calibrate"], ["detect"], ["fuse", "--recipe", "tao2008-pf-constraint"],
                 ["compare"]):
        _run([armtrack, args[0], "circle-01", *args[1:]], work, env)
    out = work / "circle-01" / "armtrack"
    assert {"camera.yaml", "detections.csv", "trajectory-pf-constraint.csv",
            "errors.csv"} <= {p.name for p in out.iterdir()}
    meta = (out / "trajectory-pf-constraint.meta.json").read_text()
    assert '"smoother": "none"' in meta  # the tao2008 recipe's setting, not the default's
