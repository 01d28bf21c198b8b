"""benchmarks/palm.py (the last section of `make bench`) still calls the pipeline as it is: its
set-up and its filter rows run once each on the bundled wrist-rom-01 (`make bench` failed at
its end for a day when pipeline/palm._blob_depths gained an argument the script did not pass,
and docs/benchmarks.md lost its palm section). No time is asserted."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "palm.py"


def _script():
    spec = importlib.util.spec_from_file_location("bench_palm", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_palm_benchmark_runs_its_filter_rows(tmp_path, monkeypatch):
    bench = _script()

    def once(fn, runs=1, clock=None) -> float:  # one run, no timing
        fn()
        return 1.0
    monkeypatch.setattr(bench, "best_of", once)
    monkeypatch.setattr(bench, "best_cpu", once)
    session, video, blobs, rig, cam, palm = bench.setup(tmp_path)
    rows = bench.filter_fps(session, video, blobs, rig, cam, palm)
    assert [r[0].split(",")[1].strip() for r in rows] == ["compiled", "numpy reference"] * 2
    assert all(np.isfinite(r[1:]).all() for r in rows)
