"""What fuse writes beside a trajectory says both what was asked and what happened: the
recipe's settings as the recipe file has them, and the run's own counts under names of
their own (a summary key must not overwrite a setting of the same name)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

from armtrack_cli import pipeline

ROOT = Path(__file__).resolve().parents[1]


def test_the_smoothers_cap_and_its_iterations_run_both_written(tmp_path):
    folder = tmp_path / "circle-01"
    shutil.copytree(ROOT / "sample_sessions" / "circle-01", folder,
                    ignore=shutil.ignore_patterns("armtrack"))
    pipeline.run(folder, through="fuse")
    recipe = tomllib.loads((ROOT / "recipes" / "default.toml").read_text())["fuse"]
    meta = json.loads((folder / "armtrack" / "trajectory-arm-smoother.meta.json").read_text())
    settings = meta["settings"]
    assert settings["smoother_iterations"] == recipe["smoother_iterations"] == 10
    assert settings["branch_repair"] is recipe["branch_repair"] is True
    assert 2 <= settings["smoother_iterations_run"] < recipe["smoother_iterations"]
    assert isinstance(settings["start_runs_moved"], int) and settings["start_runs_moved"] >= 0
