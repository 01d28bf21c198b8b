"""Palm-marker sessions (Cordella set-up): rendering, depth and the wrist-angle conventions."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from armtrack_cli import pipeline
from armtrack_cli.core import quaternion as Q
from armtrack_cli.session.config import load_session
from armtrack_cli.session.depth import depth_path, read_depth_png
from armtrack_cli.session.qualisys import read_qualisys, to_world
from armtrack_cli.session.video import iter_frames, probe_video
from armtrack_cli.simulate import hand
from armtrack_cli.simulate.palm_session import PalmSimSettings


@pytest.fixture(scope="module")
def palm(tmp_path_factory):
    root = tmp_path_factory.mktemp("palm")
    pipeline.simulate(root / "rom", PalmSimSettings(task="wrist-rom", duration_s=8.0, seed=4,
                                                    hide=((3, 2.0, 1.0),), gt_gaps=1))
    return root / "rom", dict(np.load(root / "rom.truth.npz"))


def test_marker_blobs_are_the_projected_markers(palm):
    folder, truth = palm
    s = load_session(folder)
    lo, hi = s.palm.colour.low, s.palm.colour.high
    errs, clutter_seen, hidden_seen = [], 0, 0
    px = truth["frame_marker_px"]
    sep = np.linalg.norm(px[:, :, None] - px[:, None, :], axis=-1) + 1e9 * np.eye(6)
    apart = sep.min(axis=2) >= 13  # closer blobs merge (video compression bleeds the gap)
    assert apart.mean() > 0.9
    for i, _, img in iter_frames(probe_video(s.camera.video)):
        mask = cv2.inRange(cv2.cvtColor(img, cv2.COLOR_BGR2HSV), lo, hi)
        n, _, stats, cen = cv2.connectedComponentsWithStats(mask)
        blobs = cen[1:][stats[1:, cv2.CC_STAT_AREA] >= 8]
        clutter_seen += np.linalg.norm(blobs - truth["clutter_px"], axis=1).min() < 2
        for k in range(6):
            d = np.linalg.norm(blobs - truth["frame_marker_px"][i, k], axis=1)
            if truth["frame_marker_visible"][i, k] and apart[i, k]:
                errs.append(d.min())
            elif not truth["frame_marker_visible"][i, k]:
                hidden_seen += d.min() < 3
    errs = np.array(errs)
    assert np.percentile(errs, 99) < 1.0 and np.median(errs) < 0.3, (np.median(errs), errs.max())
    assert clutter_seen == truth["frame_t"].size and hidden_seen == 0
    assert (~truth["frame_marker_visible"][:, 3]).sum() == 30  # MCP4 hidden for 1 s


def test_depth_frames_give_the_markers_depth(palm):
    folder, truth = palm
    for i in (0, 60, 150, 230):
        depth = read_depth_png(depth_path(folder, i))
        X_C = truth["frame_markers_W"][i] @ truth["R_WC"].T + truth["T_WC"]
        px = np.round(truth["frame_marker_px"][i]).astype(int)
        d = depth[px[:, 1], px[:, 0]]
        ok = np.isfinite(d)
        assert ok.sum() >= 5
        # the markers lie on the back of the hand: depth = their z_C, within noise and 1 mm steps
        np.testing.assert_allclose(d[ok], X_C[ok, 2], atol=0.005)
        table = depth[5, 5]
        assert 0.55 < table < 0.8  # the table under the corner of the image


def test_wrist_angles_follow_the_contract(palm):
    _, truth = palm
    q_FH = Q.multiply(Q.conjugate(truth["q_WF"]), truth["frame_q_WH"])
    a = np.deg2rad(truth["frame_angles_deg"])
    np.testing.assert_allclose(Q.to_matrix(q_FH), Q.to_matrix(hand.R_FH(a[:, 0], a[:, 1], a[:, 2])),
                               atol=1e-12)
    mcp3_F = Q.rotate(q_FH, truth["palm_H"][2])
    flex = truth["frame_angles_deg"][:, 0]
    dev = truth["frame_angles_deg"][:, 1]
    k = np.argmax(flex)
    assert flex[k] > 40 and mcp3_F[k, 2] < -0.05  # palmar flexion: fingers towards the palm
    k = np.argmax(dev)
    assert dev[k] > 10 and mcp3_F[k, 1] > 0.02  # radial deviation: towards the thumb (+y_H)
    assert np.abs(truth["frame_angles_deg"][: int(1.0 * 30)]).max() == 0  # neutral first second


def test_palm_markers_in_qualisys_equal_the_truth(palm):
    folder, truth = palm
    s = load_session(folder)
    m = read_qualisys(s.groundtruth.file)
    t = m.t + s.sync.groundtruth_offset_s
    on = (t >= 0) & (t <= truth["frame_t"][-1])
    ft = truth["frame_t"]
    for k, name in enumerate(hand.MARKERS):
        got = to_world(m.marker(s.groundtruth.markers[name])[on], s.groundtruth.to_world)
        fr = np.round(t[on] * 30).astype(int)
        exact = np.abs(fr / 30 - t[on]) < 1e-9  # QTM samples that fall on video frames
        ok = exact & np.isfinite(got[:, 0])
        err = np.abs(got[ok] - truth["frame_markers_W"][fr[ok], k])
        assert err.max() < 1e-3 + 5 * 0.0003, (name, err.max())
    assert np.isnan(m.marker("WRIST")[:, 0]).any()  # the gap is carried as missing
    assert len(ft) == 240
