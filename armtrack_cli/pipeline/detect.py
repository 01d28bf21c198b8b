"""`armtrack detect`: the wrist patch (CamShift) or every palm-marker candidate, per frame."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from armtrack_cli.core.errors import ConfigError
from armtrack_cli.core.numba_blas import preload
from armtrack_cli.detect.palm_blobs import CENTROIDS, PalmBlobDetector, PalmBlobSettings
from armtrack_cli.detect.patch_tracker import PatchSettings, PatchTracker
from armtrack_cli.pipeline.common import out_dir, resolve_recipe
from armtrack_cli.session.column_csv import write_column_blocks
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
    dest, summary = out_dir(session, out), {}
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
        blocks = _palm_blocks(det, video, on_frame, summary)
    else:
        if session.camera.patch is None:
            raise ConfigError(session.toml_path, "[camera] patch is missing, which detect needs",
                              "add patch = { hsv_low = [H, S, V], hsv_high = [H, S, V] }")
        settings = section(doc, "detect.patch", PatchSettings, where)
        setup = time.perf_counter()  # numba's import and the kernel's tables: kernel_setup_s
        preload()
        tracker = PatchTracker(session.camera.patch.low, session.camera.patch.high, settings,
                               fps=video.fps, frames=min(video.n_frames, 2 * BLOCK_FRAMES))
        setup = time.perf_counter() - setup
        blocks = _patch_blocks(tracker, video, on_frame, summary)
    start += setup
    with output_set():  # the frame loop runs as the CSV is written, a block at a time
        write_column_blocks(dest / "detections.csv", blocks, command="detect",
                            settings={"recipe": where, **dataclasses.asdict(settings)})
    summary["kernel_setup_s"] = round(setup, 3)
    elapsed = time.perf_counter() - start  # what the user waits for, the CSV included
    return {"detections": str(dest / "detections.csv"), "frames": video.n_frames,
            "seconds": round(elapsed, 3), "frames_per_s": round(video.n_frames / elapsed, 1),
            "kind": "palm" if session.palm is not None else "patch",
            "decoder_setup_s": round(decoder_setup, 3), **summary}


BLOCK_FRAMES = 4096  # frames whose rows are written at once: a block's rows held, not a session's


def _patch_blocks(tracker: PatchTracker, video, on_frame, summary: dict) -> Iterator[dict]:
    """detections.csv's columns a block at a time, as the tracker makes its rows final
    (PatchTracker.take: frames an acquisition may still report are held back); the loss
    summary into ``summary`` once the video ended."""
    loss = LossSpans()

    def block(first: int, d: np.ndarray) -> dict[str, np.ndarray]:
        loss.add(d[:, 5] == 1)
        return {"frame": np.arange(first, first + d.shape[0]), "t": video.t[first:first +
                d.shape[0]], "u": d[:, 0], "v": d[:, 1], "ok": d[:, 5].astype(int),
                "width": d[:, 2], "height": d[:, 3], "angle": d[:, 4]}

    for i, _, img in iter_frames_ahead(video, i420=True):
        tracker.step(i, img)
        if on_frame:
            on_frame(i + 1)
        if (i + 1) % BLOCK_FRAMES == 0:
            first, d = tracker.take()
            if len(d):
                yield block(first, d)
    yield block(*tracker.take(final=True))  # the last, or the only (maybe empty: the header)
    summary.update(loss.summary(video.fps))


def _palm_blocks(det: PalmBlobDetector, video, on_frame, summary: dict) -> Iterator[dict]:
    """detections.csv's columns a block of frames at a time; blob counts into ``summary``."""
    found = _Blobs()
    for i, t, img in iter_frames_ahead(video, i420=True):
        if len(b := det.detect(img)):
            found.add(i, t, b)
        if on_frame:
            on_frame(i + 1)
        if (i + 1) % BLOCK_FRAMES == 0 and found.k:
            yield found.take()
    yield found.take()  # the last, or the only (maybe empty: the header)
    summary.update({"blobs": found.total, "frames_with_6_or_more": found.frames_6,
                    "frames_searched_whole": det.full_searches})


class LossSpans:
    """Runs of frames without the patch (ok = 0), counted as blocks of ok flags arrive in
    order: a run across a block boundary is one run."""

    def __init__(self) -> None:
        self.ok = self.spans = self.longest = self.open = 0  # open: the run reaching the end

    def add(self, ok: np.ndarray) -> None:
        lost = np.flatnonzero(np.diff(np.r_[0, (~ok).astype(int), 0]) != 0).reshape(-1, 2)
        lengths = lost[:, 1] - lost[:, 0]
        if len(lost) and lost[0, 0] == 0 and self.open:  # the open run goes on
            lengths[0] += self.open
            self.spans -= 1
        self.ok += int(ok.sum())
        self.spans += len(lost)
        self.longest = max(self.longest, int(lengths.max()) if len(lost) else 0)
        if len(ok):
            self.open = int(lengths[-1]) if len(lost) and lost[-1, 1] == len(ok) else 0

    def summary(self, fps: float) -> dict[str, Any]:
        return {"ok_frames": self.ok, "lost_spans": self.spans,
                "longest_loss_s": round(float(self.longest / fps), 3) if self.spans else 0.0}


class _Blobs:
    """A block's blobs in one growing (K, 6) array, rows (frame, t, u, v, area, score),
    handed out by ``take``: no Python object kept a frame, and no row past its block, so a
    long session's bookkeeping is a block's numbers (issue 15)."""

    def __init__(self) -> None:
        self.rows, self.k, self.total, self.frames_6 = np.empty((4096, 6)), 0, 0, 0

    def add(self, frame: int, t: float, blobs: np.ndarray) -> None:
        """blobs (m, 4): u, v, area, score of one frame's blobs."""
        k, m = self.k, len(blobs)
        if k + m > len(self.rows):  # doubling: a copy now and then, amortised
            grown = np.empty((max(k + m, 2 * len(self.rows)), 6))
            grown[:k] = self.rows[:k]
            self.rows = grown
        self.rows[k:k + m, 0], self.rows[k:k + m, 1], self.rows[k:k + m, 2:] = frame, t, blobs
        self.k += m
        self.total += m
        self.frames_6 += m >= 6

    def take(self) -> dict[str, np.ndarray]:
        """table(), the rows then dropped."""
        out, self.k = self.table(), 0
        return out

    def table(self) -> dict[str, np.ndarray]:
        """detections.csv's columns (frame, t, blob, u, v, area, score) of the rows held (whole
        frames: a frame's blobs are numbered from 0)."""
        r = self.rows[:self.k]
        frame = r[:, 0].astype(np.int64)
        starts = np.flatnonzero(np.r_[True, frame[1:] != frame[:-1]]) if len(r) else np.zeros(0, int)
        blob = np.arange(len(r)) - np.repeat(starts, np.diff(np.r_[starts, len(r)]))
        return {"frame": frame, "t": r[:, 1].copy(), "blob": blob, "u": r[:, 2].copy(),
                "v": r[:, 3].copy(), "area": r[:, 4].astype(np.int64), "score": r[:, 5].copy()}
