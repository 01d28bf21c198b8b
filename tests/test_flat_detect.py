"""detect writes detections.csv as it goes, a block of frames at a time (issue 15: peak memory
flat with the session's length): the blocks' bytes equal the whole-table path's (the old
form, rebuilt here), the loss summary counts a run across a block boundary once, and a
failure mid-video leaves no detections.csv, an earlier one kept as it was."""

from __future__ import annotations

import dataclasses
import importlib

import numpy as np
import pytest

from armtrack_cli import pipeline
from armtrack_cli.detect.palm_blobs import PalmBlobDetector, PalmBlobSettings
from armtrack_cli.detect.patch_tracker import PatchSettings, PatchTracker
from armtrack_cli.session.column_csv import write_columns
from armtrack_cli.session.config import load_session
from armtrack_cli.session.video import iter_frames_ahead, probe_video
from armtrack_cli.simulate.arm_session import ArmSimSettings

from .conftest import REPO

detect_stage = importlib.import_module("armtrack_cli.pipeline.detect")
PALM = REPO / "sample_sessions" / "wrist-rom-01"


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    """8 s with two occlusions and a same-hue distractor: losses and re-acquisitions."""
    root = tmp_path_factory.mktemp("flatdet") / "arm"
    pipeline.simulate(root, ArmSimSettings(task="circle", duration_s=8.0, seed=0,
                                           distractor=True, occlusions=((3.0, 0.5), (5.5, 0.5)),
                                           calib_images=2))
    return root


def _old_patch(folder, dest):
    """detect's whole-table path as it was: every frame's row held, then one table."""
    session = load_session(folder)
    video = probe_video(session.camera.video)
    tr = PatchTracker(session.camera.patch.low, session.camera.patch.high, PatchSettings(),
                      fps=video.fps, frames=video.n_frames)
    for i, _, img in iter_frames_ahead(video, i420=True):
        tr.step(i, img)
    d = tr.detections()
    write_columns(dest, {"frame": np.arange(d.shape[0]), "t": video.t[:d.shape[0]],
                         "u": d[:, 0], "v": d[:, 1], "ok": d[:, 5].astype(int),
                         "width": d[:, 2], "height": d[:, 3], "angle": d[:, 4]},
                  command="detect", settings={"recipe": "defaults",
                                              **dataclasses.asdict(PatchSettings())})
    return d[:, 5] == 1, video.fps


def _old_loss(ok, fps):
    """The summary's closed form over the whole session (the old code)."""
    lost = np.flatnonzero(np.diff(np.r_[0, (~ok).astype(int), 0]) != 0).reshape(-1, 2)
    return {"ok_frames": int(ok.sum()), "lost_spans": len(lost),
            "longest_loss_s": round(float((lost[:, 1] - lost[:, 0]).max() / fps), 3)
            if len(lost) else 0.0}


def _spy_blocks(monkeypatch):
    """The rows of every block detect hands write_column_blocks."""
    sizes: list[int] = []
    write = detect_stage.write_column_blocks

    def spy(path, blocks, **kw):
        def counted():
            for b in blocks:
                sizes.append(len(b["frame"]))
                yield b
        return write(path, counted(), **kw)

    monkeypatch.setattr(detect_stage, "write_column_blocks", spy)
    return sizes


@pytest.mark.parametrize("block", [1, 7, 64])
def test_patch_blocks_write_the_whole_tables_bytes(arm, tmp_path, monkeypatch, block):
    ok, fps = _old_patch(arm, tmp_path / "old" / "detections.csv")
    assert 0 < ok.sum() < len(ok) - 10  # losses to count
    monkeypatch.setattr(detect_stage, "BLOCK_FRAMES", block)
    sizes = _spy_blocks(monkeypatch)
    r = pipeline.detect(arm, out=tmp_path / "new")
    for name in ("detections.csv", "detections.meta.json"):
        assert (tmp_path / "new" / name).read_bytes() == (tmp_path / "old" / name).read_bytes()
    assert {k: r[k] for k in ("ok_frames", "lost_spans", "longest_loss_s")} == _old_loss(ok, fps)
    assert sum(sizes) == len(ok) and len(sizes) > 1  # written as it went, every frame once


def test_palm_blocks_write_the_per_frame_rows(tmp_path, monkeypatch):
    """The independent reference: each frame's blobs as a list, numbered in plain Python."""
    session = load_session(PALM)
    video = probe_video(session.camera.video)
    det = PalmBlobDetector(session.palm.colour.low, session.palm.colour.high)
    rows = [(i, t, k, *b) for i, t, img in iter_frames_ahead(video, i420=True)
            for k, b in enumerate(det.detect(img))]
    a = np.array(rows, float)
    write_columns(tmp_path / "old" / "detections.csv",
                  {"frame": a[:, 0].astype(np.int64), "t": a[:, 1], "blob": a[:, 2].astype(
                      np.int64), "u": a[:, 3], "v": a[:, 4], "area": a[:, 5].astype(np.int64),
                   "score": a[:, 6]}, command="detect",
                  settings={"recipe": "defaults", **dataclasses.asdict(PalmBlobSettings())})
    monkeypatch.setattr(detect_stage, "BLOCK_FRAMES", 50)
    sizes = _spy_blocks(monkeypatch)
    r = pipeline.detect(PALM, out=tmp_path / "new")
    for name in ("detections.csv", "detections.meta.json"):
        assert (tmp_path / "new" / name).read_bytes() == (tmp_path / "old" / name).read_bytes()
    per_frame = np.bincount(a[:, 0].astype(int), minlength=video.n_frames)
    assert r["blobs"] == len(rows) and r["frames_with_6_or_more"] == int((per_frame >= 6).sum())
    assert r["frames_searched_whole"] == det.full_searches
    assert len(sizes) == -(-video.n_frames // 50) and sum(sizes) == len(rows)


@pytest.mark.parametrize("seed", range(6))
def test_loss_spans_across_blocks_equal_the_whole_sessions(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(0, 400))
    ok = rng.random(n) < rng.choice([0.05, 0.5, 0.95])  # mostly lost, mixed, mostly seen
    ok[rng.integers(0, n, 3) if n else []] = rng.random() < 0.5
    cuts = np.sort(rng.integers(0, n + 1, int(rng.integers(0, 12))))
    acc = detect_stage.LossSpans()
    for part in np.split(ok, cuts):  # empty parts too
        acc.add(part)
    assert acc.summary(30.0) == _old_loss(ok, 30.0)


def test_a_loss_across_a_block_boundary_is_one_span():
    acc = detect_stage.LossSpans()
    for part in ([1, 1, 0, 0], [], [0, 0, 0], [0, 1, 0], [0]):
        acc.add(np.array(part, bool))
    assert acc.summary(10.0) == {"ok_frames": 3, "lost_spans": 2, "longest_loss_s": 0.6}


def _square(frame: int, at) -> np.ndarray:
    img = np.full((120, 160, 3), 90, np.uint8)
    if at is not None:
        x, y = at
        img[y:y + 14, x:x + 14] = (0, 0, 220)  # the patch's red (hue 0)
    return img


@pytest.mark.parametrize("path", ["still", "moves, hides, comes back"])
def test_take_hands_out_only_rows_no_later_frame_changes(path):
    """A tracker whose rows are taken every few frames gives the rows of one that held every
    frame: while nothing moved, frame 0's tracklets hold all back; an acquisition's held."""
    if path == "still":
        where = [(70, 50)] * 60
    else:
        where = [(20 + 2 * i, 50) for i in range(30)] + [None] * 8 + [(80, 50)] * 30
    whole, taken = (PatchTracker((170, 140, 90), (10, 255, 255), frames=4) for _ in range(2))
    got = []
    for i, at in enumerate(where):
        whole.step(i, _square(i, at))
        taken.step(i, _square(i, at))
        if i % 3 == 2:
            first, rows = taken.take()
            assert first == sum(len(g) for g in got)
            got.append(rows)
    got.append(taken.take(final=True)[1])
    rows = np.concatenate(got)
    np.testing.assert_array_equal(rows, whole.detections())
    held = [len(g) for g in got[:-1]]
    if path == "still":  # the first frame's largest region, known only at the end
        assert held == [0] * len(held) and rows[:, 5].all()
    else:  # frame 0 on held until the square had moved, then reported after the fact
        assert held[0] == 0 and sum(held) > 40 and rows[0, 5] == 1 and not rows[32, 5]


def _fail_at(monkeypatch, cls, method, frame, exc):
    orig = getattr(cls, method)
    calls = iter(range(10 ** 6))

    def failing(self, *a, **kw):
        if next(calls) == frame:
            raise exc
        return orig(self, *a, **kw)

    monkeypatch.setattr(cls, method, failing)


@pytest.mark.parametrize("exc", [RuntimeError("mid-video"), KeyboardInterrupt()])
@pytest.mark.parametrize("kind", ["patch", "palm"])
def test_a_failure_mid_video_leaves_the_earlier_detections(arm, tmp_path, monkeypatch, exc,
                                                           kind):
    folder = arm if kind == "patch" else PALM
    out = tmp_path / "out"
    pipeline.detect(folder, out=out)
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    monkeypatch.setattr(detect_stage, "BLOCK_FRAMES", 16)
    sizes = _spy_blocks(monkeypatch)
    if kind == "patch":
        _fail_at(monkeypatch, PatchTracker, "step", 200, exc)
    else:
        _fail_at(monkeypatch, PalmBlobDetector, "detect", 200, exc)
    with pytest.raises(type(exc)):
        pipeline.detect(folder, out=out)
    assert len(sizes) > 1  # blocks were written before it failed
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before  # no temp file either
