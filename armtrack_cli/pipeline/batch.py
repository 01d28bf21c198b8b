"""Many sessions at clinic scale: each session is one task (its stages in order, inside the
task), run here one after another, or on Dask (``pip install armtrack[cluster]``): a local
cluster of N worker processes, or a running ``dask.distributed`` scheduler by address.

Stages whose outputs are newer than their inputs are skipped (``pipeline.run`` is make-like),
so a crashed overnight run resumes where it stopped. A session's failure is recorded in its
outcome, never raised. At the end, ``cohort.csv``: one row per session with subject, date,
task, method, data-quality figures and every clinical measure of kinematics-METHOD.csv.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from armtrack_cli.core.errors import ArmtrackError, ConfigError
from armtrack_cli.pipeline.common import out_dir
from armtrack_cli.pipeline.coverage import durations, tracked, video_frames
from armtrack_cli.pipeline.run import run
from armtrack_cli.session.config import Session, load_session
from armtrack_cli.session.outputs import write_table
from armtrack_cli.session.tables import read_csv_table, read_kinematics
from armtrack_cli.session.workfolder import WorkFolder

COHORT_FIRST = ("session", "status", "subject", "recorded", "task", "side", "method", "stages_run",
                "frames", "detected_pct", "duration_s", "recorded_s", "wrist_rmse_cm",
                "elbow_rmse_cm", "error", "warnings")


def _quality(work: WorkFolder, method: str, session: Session) -> dict[str, Any]:
    """Data-quality figures from the session's outputs (NaN where an output is absent): the
    report's (pipeline/coverage.py): frames and % tracked (a palm session's over every video
    frame), the span measured (duration_s) and recorded (recorded_s)."""
    row: dict[str, Any] = {"frames": np.nan, "detected_pct": np.nan,
                           "wrist_rmse_cm": np.nan, "elbow_rmse_cm": np.nan}
    if work.has("detections.csv"):
        pct, n = tracked(work, session.kind,
                         video_frames(session) if session.kind == "palm" else 0)
        row.update(frames=n, detected_pct=round(pct, 3))
    row["duration_s"], row["recorded_s"] = durations(work, method)
    if work.has("errors.csv"):
        e = read_csv_table(work / "errors.csv", ("method", "joint", "axis", "rmse_cm"), "")
        for j in ("wrist", "elbow"):
            r = e[(e["method"] == method) & (e["joint"] == j) & (e["axis"] == "3d")]
            if len(r):
                row[f"{j}_rmse_cm"] = float(r["rmse_cm"].iloc[0])
    return row


def _measures(work: WorkFolder, method: str) -> dict[str, float]:
    """Every clinical measure of kinematics-METHOD.csv over the whole session (segment
    "session"), by name; a measure "not computable" is empty."""
    if not work.has(f"kinematics-{method}.csv"):
        return {}
    k = read_kinematics(work / f"kinematics-{method}.csv")
    k = k[k["segment"] == "session"]
    return dict(zip(k["measure"], pd.to_numeric(k["value"], errors="coerce")))


def run_one(folder: str, out: str | None, options: dict[str, Any]) -> list[dict[str, Any]]:
    """One session's task: every stage, then its cohort rows (one per method). Never raises
    for bad data: the error becomes the row's ``error``."""
    base: dict[str, Any] = {"session": str(folder), "status": "done", "error": "",
                            "warnings": ""}
    try:
        with warnings.catch_warnings(record=True) as caught:  # a worker's warnings come back
            warnings.simplefilter("always")                    # in its row, one line each
            r = run(folder, out=out, **options)
        s = load_session(folder)
        base["warnings"] = " | ".join(" ".join(str(w.message).split()) for w in caught)
    except ArmtrackError as exc:
        return [{**base, "status": "failed", "error": str(exc)}]
    except Exception as exc:  # a bug of ours must not stop the night's run either
        return [{**base, "status": "failed", "error": f"{folder}: internal error "
                 f"({type(exc).__name__}: {exc})"}]
    ran = sum(1 for v in r["stages"].values() if v == "ran")
    meta = {"subject": s.meta.subject, "recorded": s.meta.recorded, "task": s.meta.task,
            "side": s.meta.side, "stages_run": ran,
            "status": "done" if ran else "up to date"}
    work = WorkFolder(out_dir(s, out))
    rows = []
    for m in r["methods"]:
        rows.append({**base, **meta, "method": m, **_quality(work, m, s),
                     **_measures(work, m)})
    return rows or [{**base, **meta}]


def _local(folders, outs, options) -> Iterator[list[dict]]:
    for f, o in zip(folders, outs):
        yield run_one(f, o, options)


def _dask(folders, outs, options, *, workers: int, scheduler: str | None) -> Iterator[list[dict]]:
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError:
        raise ConfigError("--workers" if scheduler is None else "--scheduler",
                          "needs Dask, which is not installed",
                          "pip install 'armtrack[cluster]' (or run with --workers 1)") from None
    cluster = None
    try:
        if scheduler is None:
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                   dashboard_address=":0")
        client = Client(scheduler if scheduler is not None else cluster, timeout="20s")
    except OSError as exc:
        raise ConfigError("--scheduler", f"cannot reach the Dask scheduler {scheduler!r} "
                          f"({exc})", "start it with `dask scheduler` or check the address"
                          ) from None
    try:
        futures = [client.submit(run_one, f, o, options, pure=False) for f, o in zip(folders, outs)]
        for fut in as_completed(futures):
            yield fut.result()
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def run_many(folders: list[str], outs: list[str | None], *, workers: int = 1,
             scheduler: str | None = None, on_done: Callable[[list[dict]], None] | None = None,
             **options) -> list[dict[str, Any]]:
    """Every session through ``pipeline.run(**options)``; the cohort rows in session order."""
    if workers < 1:
        raise ConfigError("--workers", f"= {workers} is not a number of workers", "use 1 or more")
    done: dict[str, list[dict]] = {}
    tasks = _local(folders, outs, options) if workers == 1 and scheduler is None else \
        _dask(folders, outs, options, workers=workers, scheduler=scheduler)
    for rows in tasks:
        done[rows[0]["session"]] = rows
        if on_done is not None:
            on_done(rows)
    return [r for f in folders for r in done[str(f)]]


def write_cohort(path: str | Path, rows: list[dict[str, Any]]) -> Path:
    """cohort.csv: the fixed columns first, then every clinical measure, sorted by name."""
    df = pd.DataFrame(rows)
    rest = sorted(c for c in df.columns if c not in COHORT_FIRST)
    df = df.reindex(columns=[c for c in COHORT_FIRST] + rest)
    for c in ("stages_run", "frames"):  # counts stay integers beside a failed (empty) row
        df[c] = pd.to_numeric(df[c]).round().astype("Int64")
    return write_table(path, df, command="run", settings={"sessions": len(rows)})


def summary(rows: list[dict[str, Any]]) -> tuple[str, int]:
    """'N sessions: a done, b failed' (up-to-date sessions count as done), and b."""
    by: dict[str, str] = {}
    for r in rows:
        by[r["session"]] = "failed" if r["status"] == "failed" else "done"
    failed = sum(v == "failed" for v in by.values())
    return f"{len(by)} sessions: {len(by) - failed} done, {failed} failed", failed
