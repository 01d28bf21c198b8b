"""`armtrack export`: TUM that evo reads (evo_ape's RMSE = compare's), CSV, and C3D read back
by the C3D reader. evo is a dev-only dependency; the test is skipped without it."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from armtrack_cli import pipeline
from armtrack_cli.session.c3d import read_c3d

from .conftest import run_cli


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    root = tmp_path_factory.mktemp("export")
    pipeline.simulate(root / "s", pipeline.ArmSimSettings(task="circle", duration_s=4.0, seed=7,
                                                          gt_gaps=2))
    pipeline.run(root / "s", through="compare", methods=("ekf",), seed=1)
    return root / "s"


def _evo_ape(tmp_path: Path, ref: Path, est: Path) -> float:
    exe = Path(sys.executable).parent / "evo_ape"
    if not exe.exists() and shutil.which("evo_ape") is None:
        pytest.skip("evo (dev dependency) is not installed")
    env = {**os.environ, "HOME": str(tmp_path), "MPLBACKEND": "Agg"}  # evo keeps settings in ~
    out = subprocess.run([str(exe if exe.exists() else "evo_ape"), "tum", str(ref), str(est),
                          "--no_warnings"], capture_output=True, text=True, env=env, timeout=120)
    assert out.returncode == 0, out.stderr
    return float(re.search(r"rmse\s+([0-9.eE+-]+)", out.stdout).group(1))


@pytest.mark.parametrize("joint", ["wrist", "elbow"])
def test_evo_ape_on_the_tum_export_matches_compare(session, tmp_path, joint):
    r = run_cli("export", session, "--format", "tum")
    assert r.exit_code == 0, r.stderr
    ex = session / "armtrack" / "export"
    rmse_m = _evo_ape(tmp_path, ex / f"ekf-{joint}.truth.tum", ex / f"ekf-{joint}.tum")
    errors = pd.read_csv(session / "armtrack" / "errors.csv")
    row = errors[(errors["joint"] == joint) & (errors["axis"] == "3d")].iloc[0]
    assert abs(rmse_m * 100 - row["rmse_cm"]) < 0.01  # cm
    # the truth file leaves the gaps out, as compare does
    assert len((ex / f"ekf-{joint}.truth.tum").read_text().splitlines()) == row["n"]


def test_tum_columns_and_raw_truth(session):
    run_cli("export", session, "--format", "tum")
    ex = session / "armtrack" / "export"
    est = np.loadtxt(ex / "ekf-wrist.tum")
    traj = pd.read_csv(session / "armtrack" / "trajectory-ekf.csv")
    np.testing.assert_allclose(est[:, 0:4], traj[["t", "wrist_x", "wrist_y", "wrist_z"]], atol=1e-9)
    np.testing.assert_array_equal(est[:, 4:], np.tile([0, 0, 0, 1.0], (len(est), 1)))
    raw = np.loadtxt(ex / "truth-wrist.tum")
    assert np.median(np.diff(raw[:, 0])) == pytest.approx(0.01)  # the capture's own 100 Hz


def test_csv_and_c3d_exports(session):
    assert run_cli("export", session, "--format", "csv").exit_code == 0
    ex = session / "armtrack" / "export"
    df = pd.read_csv(ex / "ekf-wrist.csv")
    assert list(df.columns) == ["t", "x", "y", "z", "qx", "qy", "qz", "qw"]
    r = run_cli("export", session, "--format", "c3d")
    assert r.exit_code == 0, r.stderr
    m = read_c3d(ex / "ekf.c3d")
    traj = pd.read_csv(session / "armtrack" / "trajectory-ekf.csv")
    assert m.names == ("wrist", "elbow") and m.rate_hz == pytest.approx(30.0, rel=1e-4)
    np.testing.assert_allclose(m.xyz[:, 0], traj[["wrist_x", "wrist_y", "wrist_z"]], atol=1e-6)
