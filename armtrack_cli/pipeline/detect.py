"""`armtrack detect`: the wrist patch (CamShift) or every palm-marker candidate, per frame."""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from armtrack_cli.core.errors import ConfigError
from armtrack_cli.detect.palm_blobs import CENTROIDS, PalmBlobDetector, PalmBlobSettings
from armtrack_cli.detect.patch_tracker import PatchSettings, PatchTracker
from armtrack_cli.pipeline.common import out_dir, resolve_recipe
from armtrack_cli.session.config import load_session, require
from armtrack_cli.session.outputs import output_set, write_table
from armtrack_cli.session.recipe import section
from armtrack_cli.session.video import iter_frames_ahead, probe_video


def detect(path: str | Path, *, out: str | Path | None = None, recipe: str | None = None,
           sets: tuple[str, ...] = (), on_frame=None) -> dict[str, Any]:
    session = load_session(path)
    require(session, "camera", "video")
    doc, where = resolve_recipe(recipe, sets)
    video = probe_video(session.camera.video)
    start = time.perf_counter()
    if session.palm is not None:
        settings = section(doc, "detect.palm", PalmBlobSettings, where)
        if settings.centroid not in CENTROIDS:
            raise ConfigError(where, f"[detect.palm] centroid = {settings.centroid!r} is not "
                              "one of " + ", ".join(CENTROIDS))
        setup = time.perf_counter()  # the compiled kernel's one-time set-up: kernel_setup_s
        det = PalmBlobDetector(session.palm.colour.low, session.palm.colour.high, settings)
        det.warm()
        setup = time.perf_counter() - setup
        start += setup
        found = []  # (frame, t, (k, 4) blobs): one array a frame, no Python object a blob
        for i, t, img in iter_frames_ahead(video, i420=True):
            if len(b := det.detect(img)):
                found.append((i, t, b))
            if on_frame:
                on_frame(i + 1)
        table = _blob_table(found)
        summary = {"blobs": len(table), "frames_with_6_or_more": sum(
            len(b) >= 6 for _, _, b in found),
                   "frames_searched_whole": det.full_searches, "kernel_setup_s": round(setup, 3)}
    else:
        if session.camera.patch is None:
            raise ConfigError(session.toml_path, "[camera] patch is missing, which detect needs",
                              "add patch = { hsv_low = [H, S, V], hsv_high = [H, S, V] }")
        settings = section(doc, "detect.patch", PatchSettings, where)
        tracker = PatchTracker(session.camera.patch.low, session.camera.patch.high, settings,
                               fps=video.fps)
        for i, _, img in iter_frames_ahead(video, i420=True):
            tracker.step(i, img)
            if on_frame:
                on_frame(i + 1)
        d = tracker.detections(video.fps)
        table = pd.DataFrame({"frame": np.arange(d.shape[0]), "t": video.t[:d.shape[0]],
                              "u": d[:, 0], "v": d[:, 1], "ok": d[:, 5].astype(int),
                              "width": d[:, 2], "height": d[:, 3], "angle": d[:, 4]})
        ok = d[:, 5] == 1
        lost = np.flatnonzero(np.diff(np.r_[0, (~ok).astype(int), 0]) != 0).reshape(-1, 2)
        summary = {"ok_frames": int(ok.sum()), "lost_spans": len(lost),
                   "longest_loss_s": round(float((lost[:, 1] - lost[:, 0]).max() / video.fps), 3)
                   if len(lost) else 0.0}
    elapsed = time.perf_counter() - start
    dest = out_dir(session, out)
    with output_set():
        write_table(dest / "detections.csv", table, command="detect",
                    settings={"recipe": where, **dataclasses.asdict(settings)})
    return {"detections": str(dest / "detections.csv"), "frames": video.n_frames,
            "seconds": round(elapsed, 3), "frames_per_s": round(video.n_frames / elapsed, 1),
            "kind": "palm" if session.palm is not None else "patch", **summary}


def _blob_table(found: list[tuple[int, float, np.ndarray]]) -> pd.DataFrame:
    """detections.csv's rows (frame, t, blob, u, v, area, score) from each frame's blobs."""
    n = np.array([len(b) for _, _, b in found], dtype=np.int64)
    b = np.concatenate([b for _, _, b in found]) if found else np.zeros((0, 4))
    return pd.DataFrame({
        "frame": np.repeat(np.array([i for i, _, _ in found], dtype=np.int64), n),
        "t": np.repeat(np.array([t for _, t, _ in found], dtype=float), n),
        "blob": np.arange(len(b)) - np.repeat(np.cumsum(n) - n, n),
        "u": b[:, 0], "v": b[:, 1], "area": b[:, 2].astype(np.int64), "score": b[:, 3]})
