"""Palm-blob detection in a window around the previous blobs (detect/palm_blobs.py) against
the search of the hand's whole region on every frame: the same marker blobs, value for value."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from armtrack_cli.detect.palm_blobs import PalmBlobDetector, PalmBlobSettings
from armtrack_cli.session.config import load_session
from armtrack_cli.session.video import iter_frames, probe_video

SAMPLE = Path(__file__).resolve().parents[1] / "sample_sessions" / "wrist-rom-01"


def test_windowed_search_finds_the_same_marker_blobs_as_the_full_search():
    s = load_session(SAMPLE)
    truth = dict(np.load(SAMPLE.parent / "wrist-rom-01.truth.npz"))
    lo, hi = s.palm.colour.low, s.palm.colour.high
    fast, full = PalmBlobDetector(lo, hi), PalmBlobDetector(lo, hi, PalmBlobSettings(full_every=0))
    px, vis = truth["frame_marker_px"], truth["frame_marker_visible"]
    compared = 0
    for i, _, img in iter_frames(probe_video(s.camera.video)):
        a, b = fast.detect(img), full.detect(img)
        for k in np.flatnonzero(vis[i]):  # each visible marker's blob, found by the full search
            jb = np.argmin(np.linalg.norm(b[:, :2] - px[i, k], axis=1))
            if np.linalg.norm(b[jb, :2] - px[i, k]) > 1.5:
                continue  # merged with a neighbour: the same blob either way, checked below
            ja = np.argmin(np.linalg.norm(a[:, :2] - px[i, k], axis=1))
            assert np.array_equal(a[ja], b[jb]), (i, k, a[ja], b[jb])
            compared += 1
        # every blob of the full search well inside its region is found identically
        inside = [r for r in b if np.linalg.norm(r[:2] - truth["clutter_px"]) > 30]
        assert all(any(np.array_equal(r, q) for q in a) for r in inside), i
    assert compared > 0.95 * vis.sum()
    n = vis.shape[0]
    assert full.full_searches == n and fast.full_searches < 0.25 * n  # the window was used
