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
