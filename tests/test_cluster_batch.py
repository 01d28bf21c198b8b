"""`armtrack run FOLDER --scheduler ADDRESS` on a dask.distributed LocalCluster of 2 workers
made here: 8 short simulated sessions, one broken; cohort.csv; a rerun after a half-done run
skips the finished sessions."""

from __future__ import annotations

import pandas as pd
import pytest

from armtrack_cli import pipeline

from .conftest import run_cli

distributed = pytest.importorskip("dask.distributed")

N_SESSIONS = 8


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    root = tmp_path_factory.mktemp("clinic")
    for k in range(N_SESSIONS):
        pipeline.simulate(root / f"p{k:02d}", pipeline.ArmSimSettings(
            task="circle", duration_s=2.5, seed=k, fps=20.0))
    imu = root / "p03" / "imu.txt"  # a corrupt upload
    lines = imu.read_text().splitlines()
    imu.write_text("\n".join(lines[:40] + ["1\t2\tthree\t"] + lines[40:]) + "\n")
    return root


@pytest.fixture(scope="module")
def scheduler():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as cluster:
        yield cluster.scheduler_address


def test_half_done_run_then_the_whole_folder_on_two_dask_workers(folder, scheduler):
    # a run that stopped half-way: the first four sessions finished
    first = [folder / f"p{k:02d}" for k in (0, 1, 2, 4)]
    r = run_cli("run", *first, "--method", "ekf", "--through", "compare", "--seed", "1")
    assert r.exit_code == 0, r.stderr
    r = run_cli("run", folder, "--method", "ekf", "--through", "compare", "--seed", "1",
                "--scheduler", scheduler)
    assert r.exit_code == 1
    errors = [ln for ln in r.stderr.strip().splitlines() if not ln.startswith("warning: ")]
    assert len(errors) == 1 and errors[0].startswith(f"error: {folder / 'p03' / 'imu.txt'}: ")
    assert r.stdout.strip().splitlines()[-1] == f"{N_SESSIONS} sessions: 7 done, 1 failed"
    for k in (0, 1, 2, 4):  # finished before: skipped
        assert f"{folder / f'p{k:02d}'}: up to date (0 stages ran)" in r.stdout
    for k in (5, 6, 7):
        assert f"{folder / f'p{k:02d}'}: done (4 stages ran)" in r.stdout
        assert (folder / f"p{k:02d}" / "armtrack" / "errors.csv").is_file()
    cohort = pd.read_csv(folder / "cohort.csv")
    assert list(cohort["session"]) == [str(folder / f"p{k:02d}") for k in range(N_SESSIONS)]
    good = cohort[cohort["status"] != "failed"]
    assert (good["subject"] == "SIM").all() and (good["task"] == "circle").all()
    assert (good["method"] == "ekf").all() and good["wrist_rmse_cm"].between(0, 20).all()
    assert good["detected_pct"].gt(50).all() and good["elbow_flexion_rom"].notna().all()
    bad = cohort[cohort["status"] == "failed"]
    assert len(bad) == 1 and "imu.txt" in bad["error"].iloc[0]


def test_workers_without_dask_is_one_clear_line(folder, monkeypatch):
    """--workers N > 1 needs Dask; without it, one line saying how to get it. (The local
    cluster path is dask's LocalCluster around the same task as the scheduler path above.)"""
    import builtins

    real = builtins.__import__

    def no_dask(name, *a, **k):
        if name.startswith("dask"):
            raise ImportError(name)
        return real(name, *a, **k)

    monkeypatch.setattr(builtins, "__import__", no_dask)
    r = run_cli("run", folder / "p00", "--workers", "2", "--method", "ekf")
    assert r.exit_code == 1 and r.stderr.strip().count("\n") == 0
    assert "needs Dask, which is not installed; pip install 'armtrack[cluster]'" in r.stderr
