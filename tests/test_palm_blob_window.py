"""Palm-blob detection in a window around the previous blobs (detect/palm_blobs.py) against
the search of the hand's whole region on every frame: the same marker blobs, value for value
(to 1e-9 px: the centroid is taken in the window, then shifted to the image)."""

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
            assert np.abs(a[ja] - b[jb]).max() < 1e-9, (i, k, a[ja], b[jb])
            compared += 1
        # every blob of the full search well inside its region is found identically
        inside = [r for r in b if np.linalg.norm(r[:2] - truth["clutter_px"]) > 30]
        assert all(np.abs(a - r).max(axis=1).min() < 1e-9 for r in inside), i
    assert compared > 0.95 * vis.sum()
    n = vis.shape[0]
    assert full.full_searches == n and fast.full_searches < 0.25 * n  # the window was used


def test_scores_are_opencvs_bhattacharyya_of_each_region():
    """All regions' histograms in one bincount against cv2.calcHist + cv2.compareHist per
    region (the way the detector scored them before)."""
    import cv2

    from armtrack_cli.detect.colour import hs_histogram

    s = load_session(SAMPLE)
    det = PalmBlobDetector(s.palm.colour.low, s.palm.colour.high)
    img = next(iter_frames(probe_video(s.camera.video)))[2]
    det.detect(img)
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    n, labels, _, _ = cv2.connectedComponentsWithStats(det._candidates_mask(hsv), connectivity=8)
    lab = labels.ravel()
    ours = det._bhattacharyya(hsv, lab, np.flatnonzero(lab), n)
    ref = det.reference.astype(np.float32).reshape(30, 32)
    for k in range(1, n):
        h = hs_histogram(hsv, (labels == k).astype(np.uint8) * 255)
        assert abs(ours[k] - cv2.compareHist(ref, h, cv2.HISTCMP_BHATTACHARYYA)) < 1e-6
    assert n > 6


def test_core_centroid_takes_the_wrist_blob_nearer_its_marker():
    """centroid = "core" (docs/palm-ukf.md): the WRIST blob's mean offset from the true
    projection, pulled towards the bluish sleeve by the rim pixels, shrinks."""
    s = load_session(SAMPLE)
    truth = dict(np.load(SAMPLE.parent / "wrist-rom-01.truth.npz"))
    lo, hi = s.palm.colour.low, s.palm.colour.high
    dets = {c: PalmBlobDetector(lo, hi, PalmBlobSettings(centroid=c)) for c in ("region", "core")}
    off = {c: [] for c in dets}
    for i, _, img in iter_frames(probe_video(s.camera.video)):
        if i % 4:
            continue
        p = truth["frame_marker_px"][i, 0]
        for c, d in dets.items():
            b = d.detect(img)
            j = np.argmin(np.linalg.norm(b[:, :2] - p, axis=1))
            off[c].append(b[j, :2] - p)
    region, core = (np.linalg.norm(np.mean(off[c], axis=0)) for c in ("region", "core"))
    assert region > 0.5 and core < 0.6 * region, (region, core)
