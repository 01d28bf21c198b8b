"""`armtrack simulate --moving-distractor --clutter` then `armtrack detect` (issue 14): the
other arm, in a sleeve of the patch's hue, sweeps over and near the patch; frames reported
``ok = 1`` are on the patch (within 3 px of the simulator's true wrist pixel), and without the
appearance check frames off the patch are reported (docs/validation-detect.md has the study)."""

from __future__ import annotations

import cv2
import numpy as np
import pandas as pd
import pytest

from armtrack_cli.simulate.arm_session import ArmSimSettings, simulate_arm

from .conftest import run_cli

ARGS = ("--task", "rectangle", "--seed", "4", "--duration", "10", "--moving-distractor",
        "--clutter", "--distractor", "--occlusion", "6.5:0.5")
SETTINGS = ArmSimSettings(task="rectangle", seed=4, duration_s=10.0, moving_distractor=True,
                          clutter=True, distractor=True, occlusions=((6.5, 0.5),))
NO_CHECK = ("detect.patch.max_hue_distance=1.0", "detect.patch.lost_fraction=0.0",
            "detect.patch.max_growth=1e9", "detect.patch.max_aspect=1e9",
            "detect.patch.max_aspect_change=1e9")


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    root = tmp_path_factory.mktemp("moving")
    folder = root / "md"
    r = run_cli("simulate", folder, *ARGS)
    assert r.exit_code == 0, r.stderr
    r = run_cli("detect", folder)
    assert r.exit_code == 0, r.stderr
    return folder, dict(np.load(root / "md.truth.npz"))


def _scored(path, truth):
    d = pd.read_csv(path, comment="#")
    ok = d["ok"].to_numpy() == 1
    px = truth["frame_wrist_px"]
    return ok, np.hypot(d["u"].to_numpy() - px[:, 0], d["v"].to_numpy() - px[:, 1])


def test_ok_means_the_patch(session):
    folder, truth = session
    covered = truth["frame_patch_covered"]
    assert (covered > 0.5).sum() >= 3  # the sleeve does cross the patch
    ok, err = _scored(folder / "armtrack" / "detections.csv", truth)
    assert (err[ok] <= 3.0).mean() >= 0.99, np.sort(err[ok])[-5:]
    assert not ok[covered > 0.5].any()  # half under the other arm: not reported (lost_fraction)
    vis = truth["frame_patch_visible"]
    assert (ok & vis).sum() >= 0.9 * vis.sum()  # and the patch is still found when in view


def test_without_the_check_frames_off_the_patch_are_reported(session, tmp_path):
    """The same session with the appearance check off (hue, mass and aspect bands wide open):
    frames off the patch by more than 3 px, or on the sleeve over it, are reported ok = 1;
    with the check (test above) none are."""
    folder, truth = session
    r = run_cli("detect", folder, "--out", tmp_path, *[a for s in NO_CHECK for a in ("--set", s)])
    assert r.exit_code == 0, r.stderr
    ok, err = _scored(tmp_path / "detections.csv", truth)
    assert (ok & ((err > 3.0) | (truth["frame_patch_covered"] > 0.5))).sum() >= 3
    ok, err = _scored(folder / "armtrack" / "detections.csv", truth)
    assert not (ok & ((err > 3.0) | (truth["frame_patch_covered"] > 0.5))).any()


def test_covered_share_is_what_the_frames_show(session):
    """The truth's share of the patch under the other arm against the rendered pixels: in a
    5 px disc about the true wrist pixel, the patch's own hue (H ≤ 3 or ≥ 178, S ≥ 140) fills
    the disc when the patch is in view and uncovered, and is gone when it is covered."""
    folder, truth = session
    assert "--moving-distractor --clutter" in (folder / "session.toml").read_text().splitlines()[0]
    sim = simulate_arm(SETTINGS)
    covered, vis, px = (truth[k] for k in ("frame_patch_covered", "frame_patch_visible",
                                           "frame_wrist_px"))
    yy, xx = np.mgrid[-5:6, -5:6]
    disc = xx**2 + yy**2 <= 25
    checked = 0
    for i, img in sim.frames():
        if not (covered[i] > 0.98 or (vis[i] and i % 10 == 0)):
            continue
        u, v = (int(round(c)) for c in px[i])
        hsv = cv2.cvtColor(img[v - 5:v + 6, u - 5:u + 6], cv2.COLOR_BGR2HSV)
        own = ((hsv[..., 0] <= 3) | (hsv[..., 0] >= 178)) & (hsv[..., 1] >= 140)
        share = own[disc].mean()
        assert share < 0.05 if covered[i] > 0.98 else share > 0.9, (i, covered[i], share)
        checked += 1
    assert checked >= 25


def _reacquire():
    import importlib
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "validation"))
    return importlib.import_module("reacquire")


def test_the_sleeve_gap_agrees_with_the_rendered_cover(session):
    """validation/reacquire.py's gap between the patch's outline and the other arm (from the
    3-D truth, projected) against the renderer's own share of the patch under the other arm:
    a covered frame has the two overlapping, a frame with them 2 px apart is not covered."""
    _, truth = session
    gap = _reacquire().sleeve_gap_px(truth)
    covered = truth["frame_patch_covered"] > 0
    assert covered.sum() >= 3 and (gap > 2).sum() >= 100
    assert (gap[covered] <= 1.0).all()
    assert not covered[gap > 2.0].any()


def test_the_patch_is_taken_again_as_soon_as_it_is_clear(session):
    """After the card and after every pass of the other arm, ok = 1 again within 3 frames of
    the patch being in clear view (visible, the sleeve more than 5 px away): the detections
    the forward filter relies on (docs/validation-detect.md has the study)."""
    folder, truth = session
    rq = _reacquire()
    ok, _ = _scored(folder / "armtrack" / "detections.csv", truth)
    clear = truth["frame_patch_visible"].astype(bool) & (rq.sleeve_gap_px(truth) > rq.CLEAR_PX)
    ev = [e for e in rq.lags(clear, ok, truth["frame_occluded"].astype(bool)) if e[2] >= 5]
    assert {e[1] for e in ev} >= {"card", "arm"}
    assert all(e[3] is not None and e[3] <= 3 for e in ev), ev


def test_lags_count_clear_frames_before_the_first_report():
    """reacquire.lags on a hand-made sequence: causes, stretch lengths and lags."""
    clear = np.array([1, 1, 1, 0, 0, 1, 1, 1, 1, 0, 1, 1], bool)
    ok = np.array([0, 1, 1, 0, 0, 0, 0, 1, 1, 0, 0, 0], bool)
    card = np.array([0, 0, 0, 1, 1, 0, 0, 0, 0, 0, 0, 0], bool)
    assert _reacquire().lags(clear, ok, card) == [(0, "start", 3, 1), (5, "card", 4, 2),
                                                   (10, "arm", 2, None)]
