"""calibrate and detect on simulated sessions, several seeds and tasks (issue 4)."""

from __future__ import annotations

import shutil
import sys

import cv2
import numpy as np
import pandas as pd
import pytest

from armtrack_cli import pipeline
from armtrack_cli.session.camera_yaml import read_camera_yaml
from armtrack_cli.simulate.arm_session import ArmSimSettings
from armtrack_cli.simulate.palm_session import PalmSimSettings

from .conftest import run_cli

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ARM = {
    "circle-s0": ArmSimSettings(task="circle", duration_s=8.0, seed=0, distractor=True,
                                occlusions=((3.0, 0.5), (5.5, 0.5)), calib_images=15),
    "rect-s1": ArmSimSettings(task="rectangle", duration_s=8.0, seed=1, distractor=True),
    "reach-s2": ArmSimSettings(task="reach", duration_s=8.0, seed=2, occlusions=((4.0, 0.5),)),
    "fig8-s3": ArmSimSettings(task="figure8", duration_s=8.0, seed=3, distortion=False),
}
PALM = {"rom-s4": PalmSimSettings(task="wrist-rom", duration_s=8.0, seed=4),
        "grasp-s5": PalmSimSettings(task="reach-grasp", duration_s=8.0, seed=5)}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    root = tmp_path_factory.mktemp("cd")
    out = {}
    for name, settings in {**ARM, **PALM}.items():
        pipeline.simulate(root / name, settings)
        assert run_cli("calibrate", root / name).exit_code == 0
        r = run_cli("detect", root / name, "--json")
        assert r.exit_code == 0, r.stderr
        out[name] = (root / name, dict(np.load(root / f"{name}.truth.npz")))
    return out


def _angle_deg(Ra, Rb):
    return np.degrees(np.arccos(np.clip((np.trace(Ra @ Rb.T) - 1) / 2, -1, 1)))


@pytest.mark.parametrize("name", list(ARM) + list(PALM))
def test_extrinsics_within_1cm_and_half_a_degree(runs, name):
    folder, truth = runs[name]
    cam = read_camera_yaml(folder / "armtrack" / "camera.yaml")
    eye = cam.centre_W
    assert np.linalg.norm(eye - (-truth["R_WC"].T @ truth["T_WC"])) < 0.01
    assert _angle_deg(cam.R_WC, truth["R_WC"]) < 0.5
    assert cam.reprojection_error_px < 0.5


def test_intrinsics_from_board_images(runs):
    """Intrinsics computed from 15 board images, then the pose from frame 0: the true wrist
    path projected with the fitted camera lands where the true camera puts it."""
    folder, truth = runs["circle-s0"]
    cam = read_camera_yaml(folder / "armtrack" / "camera.yaml")
    K = truth["K"]
    assert abs(cam.K[0, 0] / K[0, 0] - 1) < 0.01 and abs(cam.K[1, 1] / K[1, 1] - 1) < 0.01
    assert np.abs(cam.K[:2, 2] - K[:2, 2]).max() < 5.0
    px = cv2.projectPoints(truth["frame_wrist"], cv2.Rodrigues(cam.R_WC)[0], cam.T_WC, cam.K,
                           cam.dist)[0].reshape(-1, 2)
    err = np.linalg.norm(px - truth["frame_wrist_px"], axis=1)
    assert np.median(err) < 1.0 and err.max() < 2.0, (np.median(err), err.max())


def _patch(folder):
    return pd.read_csv(folder / "armtrack" / "detections.csv")


def test_patch_centre_is_the_projected_wrist(runs):
    errs = []
    for name in ARM:
        folder, truth = runs[name]
        d = _patch(folder)
        ok = d["ok"].to_numpy() == 1
        vis = truth["frame_patch_visible"]
        assert (ok == vis).mean() > 0.99, name  # found when visible, absent when not
        assert not (ok & truth["frame_occluded"]).any(), name  # occluded frames are ok = 0
        e = np.hypot(d["u"] - truth["frame_wrist_px"][:, 0], d["v"] - truth["frame_wrist_px"][:, 1])
        e = e.to_numpy()[ok & vis]
        assert e.max() < 5.0, f"{name}: a detection {e.max():.1f} px from the wrist"
        errs.append(e)
    e = np.concatenate(errs)
    assert np.median(e) <= 1.5 and np.percentile(e, 95) <= 4.0, (np.median(e), np.percentile(e, 95))


def test_never_on_the_distractor(runs):
    for name in ("circle-s0", "rect-s1"):
        folder, truth = runs[name]
        d = _patch(folder)
        ok = d["ok"].to_numpy() == 1
        near = np.hypot(d["u"] - truth["distractor_px"][0], d["v"] - truth["distractor_px"][1]) < 15
        assert ok.sum() > 200 and not (ok & near.to_numpy()).any()


def test_lost_frames_have_no_position(runs):
    folder, _ = runs["circle-s0"]
    text = (folder / "armtrack" / "detections.csv").read_text().splitlines()
    lost = [ln for ln in text[1:] if ln.split(",")[4] == "0"]
    assert lost and all(ln.split(",")[2:4] == ["", ""] for ln in lost)  # empty, never zero


@pytest.mark.parametrize("name", list(PALM))
def test_palm_markers_found_and_clutter_reported(runs, name):
    folder, truth = runs[name]
    d = pd.read_csv(folder / "armtrack" / "detections.csv")
    px = truth["frame_marker_px"]
    sep = np.linalg.norm(px[:, :, None] - px[:, None, :], axis=-1) + 1e9 * np.eye(6)
    apart = sep.min(axis=2) >= 13  # nearer markers merge into one blob in the image
    hits, total, clutter = 0, 0, 0
    for i, g in d.groupby("frame"):
        b = g[["u", "v"]].to_numpy()
        clutter += np.linalg.norm(b - truth["clutter_px"], axis=1).min() < 2
        for k in range(6):
            if truth["frame_marker_visible"][i, k] and apart[i, k]:
                total += 1
                hits += np.linalg.norm(b - px[i, k], axis=1).min() < 2
    assert hits / total >= 0.99, hits / total
    assert clutter >= 0.9 * truth["frame_t"].size
    assert (d["score"] > 0).all() and (d["area"] > 0).all()


@pytest.mark.parametrize("name", list(PALM))
def test_palm_model_from_the_first_frame(runs, name):
    folder, truth = runs[name]
    doc = tomllib.loads((folder / "armtrack" / "palm.toml").read_text())
    true_angles = np.degrees(np.arctan2(truth["palm_H"][:, 1], truth["palm_H"][:, 0]))
    assert np.abs(np.array(doc["palm"]["angle_deg"]) - true_angles).max() < 3.0
    assert np.abs(doc["fit"]["link_residual_m"]).max() < 0.003
    px = np.array(doc["fit"]["pixels"])
    assert np.abs(px - truth["frame_marker_px"][0]).max() < 2.0  # each name on its marker


def test_markers_given_by_hand(runs, tmp_path):
    folder, truth = runs["rom-s4"]
    spec = ";".join(f"{u:.1f},{v:.1f}" for u, v in truth["frame_marker_px"][0])
    r = run_cli("calibrate", folder, "--markers", spec, "--out", tmp_path, "--json")
    assert r.exit_code == 0, r.stderr
    doc = tomllib.loads((tmp_path / "palm.toml").read_text())
    np.testing.assert_allclose(doc["fit"]["pixels"], np.round(truth["frame_marker_px"][0], 1),
                               atol=1e-6)


def test_calibrate_errors_suggest_another_frame(runs, tmp_path):
    folder, _ = runs["rect-s1"]
    r = run_cli("calibrate", folder, "--frame", "100000")
    assert r.exit_code == 1 and "frame 100000 does not exist" in r.stderr
    r = run_cli("calibrate", folder, "--set", "calibrate.max_error_px=0.001", "--out", tmp_path)
    assert r.exit_code == 1 and "board reprojection error" in r.stderr and "--frame" in r.stderr
    assert not list(tmp_path.iterdir())
    blank = tmp_path / "blank"
    shutil.copytree(folder, blank, ignore=shutil.ignore_patterns("armtrack"))
    w = cv2.VideoWriter(str(blank / "video.mp4"), cv2.VideoWriter_fourcc(*"mp4v"), 30, (640, 480))
    for _ in range(5):
        w.write(np.full((480, 640, 3), 128, np.uint8))
    w.release()
    r = run_cli("calibrate", blank)
    assert r.exit_code == 1
    assert r.stderr.strip().splitlines() == [
        f"error: {blank / 'video.mp4'}: frame 0: no ChArUco board found; try another --frame "
        "where the board lies whole and unoccluded"]
    assert not (blank / "armtrack").exists()


def test_recipe_settings_are_checked(runs, tmp_path):
    folder, _ = runs["rect-s1"]
    r = run_cli("detect", folder, "--set", "detect.patch.move_pxx=15", "--out", tmp_path)
    assert r.exit_code == 1 and "move_pxx is not a setting; did you mean 'move_px'?" in r.stderr
    r = run_cli("detect", folder, "--recipe", "nonexistent-recipe")
    assert r.exit_code == 1 and "neither a recipe file nor a recipe name" in r.stderr


def test_detect_is_reproducible_and_records_its_settings(runs, tmp_path):
    folder, _ = runs["reach-s2"]
    assert run_cli("detect", folder, "--out", tmp_path).exit_code == 0
    assert (tmp_path / "detections.csv").read_bytes() == (
        folder / "armtrack" / "detections.csv").read_bytes()
    meta = (tmp_path / "detections.meta.json").read_text()
    assert '"move_px": 12.0' in meta and '"armtrack_version"' in meta


def test_default_recipe_is_the_defaults(runs, tmp_path):
    """recipes/default.toml writes the defaults out: using it changes nothing."""
    folder, _ = runs["reach-s2"]
    assert run_cli("detect", folder, "--recipe", "default", "--out", tmp_path).exit_code == 0
    assert (tmp_path / "detections.csv").read_bytes() == (
        folder / "armtrack" / "detections.csv").read_bytes()
