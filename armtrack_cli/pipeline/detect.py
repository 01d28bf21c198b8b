"""`armtrack detect`: the wrist patch (CamShift) or every palm-marker candidate, per frame."""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path
from typing import Any

import numpy as np

from armtrack_cli.core.errors import ConfigError
from armtrack_cli.core.numba_blas import preload
from armtrack_cli.detect.palm_blobs import CENTROIDS, PalmBlobDetector, PalmBlobSettings
from armtrack_cli.detect.patch_tracker import PatchSettings, PatchTracker
from armtrack_cli.pipeline.common import out_dir, resolve_recipe
from armtrack_cli.session.column_csv import write_columns
from armtrack_cli.session.config import load_session, require
from armtrack_cli.session.outputs import output_set
from armtrack_cli.session.recipe import section
from armtrack_cli.session.video import iter_frames_ahead, load_decoder, probe_video


def detect(path: str | Path, *, out: str | Path | None = None, recipe: str | None = None,
           sets: tuple[str, ...] = (), on_frame=None) -> dict[str, Any]:
    session = load_session(path)
    require(session, "camera", "video")
    doc, where = resolve_recipe(recipe, sets)
    video = probe_video(session.camera.video)
    start = time.perf_counter()
    load_decoder(video)  # PyAV's import, once per process: decoder_setup_s, apart as the kernel's
    decoder_setup = time.perf_counter() - start
    start += decoder_setup
    if session.palm is not None:
        settings = section(doc, "detect.palm", PalmBlobSettings, where)
        if settings.centroid not in CENTROIDS:
            raise ConfigError(where, f"[detect.palm] centroid = {settings.centroid!r} is not "
                              "one of " + ", ".join(CENTROIDS))
        setup = time.perf_counter()  # the compiled kernel's one-time set-up: kernel_setup_s
        preload()  # numba's BLAS without the scipy.linalg package (core/numba_blas.py)
        det = PalmBlobDetector(session.palm.colour.low, session.palm.colour.high, settings)
        det.warm()
        setup = time.perf_counter() - setup
        start += setup
        found = _Blobs()
        for i, t, img in iter_frames_ahead(video, i420=True):
            if len(b := det.detect(img)):
                found.add(i, t, b)
            if on_frame:
                on_frame(i + 1)
        table = found.table()
        summary = {"blobs": found.k, "frames_with_6_or_more": found.frames_6,
                   "frames_searched_whole": det.full_searches, "kernel_setup_s": round(setup, 3)}
    else:
        if session.camera.patch is None:
            raise ConfigError(session.toml_path, "[camera] patch is missing, which detect needs",
                              "add patch = { hsv_low = [H, S, V], hsv_high = [H, S, V] }")
        settings = section(doc, "detect.patch", PatchSettings, where)
        setup = time.perf_counter()  # numba's import and the kernel's tables: kernel_setup_s
        preload()
        tracker = PatchTracker(session.camera.patch.low, session.camera.patch.high, settings,
                               fps=video.fps, frames=video.n_frames)
        setup = time.perf_counter() - setup
        start += setup
        for i, _, img in iter_frames_ahead(video, i420=True):
            tracker.step(i, img)
            if on_frame:
                on_frame(i + 1)
        d = tracker.detections(video.fps)
        table = {"frame": np.arange(d.shape[0]), "t": video.t[:d.shape[0]], "u": d[:, 0],
                 "v": d[:, 1], "ok": d[:, 5].astype(int), "width": d[:, 2], "height": d[:, 3],
                 "angle": d[:, 4]}  # columns, written block by block: no DataFrame, no text
        ok = d[:, 5] == 1
        lost = np.flatnonzero(np.diff(np.r_[0, (~ok).astype(int), 0]) != 0).reshape(-1, 2)
        summary = {"ok_frames": int(ok.sum()), "lost_spans": len(lost),
                   "longest_loss_s": round(float((lost[:, 1] - lost[:, 0]).max() / video.fps), 3)
                   if len(lost) else 0.0, "kernel_setup_s": round(setup, 3)}
    dest = out_dir(session, out)
    with output_set():
        write_columns(dest / "detections.csv", table, command="detect",
                    settings={"recipe": where, **dataclasses.asdict(settings)})
    elapsed = time.perf_counter() - start  # what the user waits for, the CSV included
    return {"detections": str(dest / "detections.csv"), "frames": video.n_frames,
            "seconds": round(elapsed, 3), "frames_per_s": round(video.n_frames / elapsed, 1),
            "kind": "palm" if session.palm is not None else "patch",
            "decoder_setup_s": round(decoder_setup, 3), **summary}


class _Blobs:
    """Every frame's blobs in one growing (K, 6) array, rows (frame, t, u, v, area, score):
    no Python object kept a frame, so a long session's bookkeeping is its numbers (issue 15)."""

    def __init__(self) -> None:
        self.rows, self.k, self.frames_6 = np.empty((4096, 6)), 0, 0

    def add(self, frame: int, t: float, blobs: np.ndarray) -> None:
        """blobs (m, 4): u, v, area, score of one frame's blobs."""
        k, m = self.k, len(blobs)
        if k + m > len(self.rows):  # doubling: a copy now and then, amortised
            grown = np.empty((max(k + m, 2 * len(self.rows)), 6))
            grown[:k] = self.rows[:k]
            self.rows = grown
        self.rows[k:k + m, 0], self.rows[k:k + m, 1], self.rows[k:k + m, 2:] = frame, t, blobs
        self.k += m
        self.frames_6 += m >= 6

    def table(self) -> dict[str, np.ndarray]:
        """detections.csv's columns (frame, t, blob, u, v, area, score)."""
        r = self.rows[:self.k]
        frame = r[:, 0].astype(np.int64)
        starts = np.flatnonzero(np.r_[True, frame[1:] != frame[:-1]]) if len(r) else np.zeros(0, int)
        blob = np.arange(len(r)) - np.repeat(starts, np.diff(np.r_[starts, len(r)]))
        return {"frame": frame, "t": r[:, 1].copy(), "blob": blob, "u": r[:, 2].copy(),
                "v": r[:, 3].copy(), "area": r[:, 4].astype(np.int64), "score": r[:, 5].copy()}
