"""Palm sessions scored against a QTM 6DOF hand body (issue 16): each wrist angle, its range of
motion and the WRIST position, from the body's rotation and origin.

The session is the bundled wrist-rom-01 with its ground truth replaced by a 6DOF export of the
simulator's exact hand pose (written here in QTM's 6DOF TSV layout, in a lab frame turned and
shifted from W), and a synthetic trajectory-ukf-palm.csv: the exact angles plus seeded smooth
noise. The scores are checked against the same noise measured directly against the exact truth.
"""

from __future__ import annotations

import shutil

import numpy as np
import pandas as pd
import pytest

from armtrack_cli.core import quaternion as Q
from armtrack_cli.pipeline.kinematics import kinematics_table
from armtrack_cli.session.config import load_session

from .conftest import REPO, run_cli
from .test_groundtruth_formats import format_6dof

SAMPLE = REPO / "sample_sessions" / "wrist-rom-01"
TO_WORLD = np.array([[0, -1, 0, 0.62], [1, 0, 0, -0.31], [0, 0, 1, 0], [0, 0, 0, 1.0]])
ANGLES = ("flexion", "deviation", "pronation")


def _smooth_noise(rng, sd, n):
    """Noise with SD about ``sd`` smoothed over 15 frames (a filter's errors are smooth)."""
    return np.apply_along_axis(lambda x: np.convolve(x, np.ones(15) / np.sqrt(15), "same"), 0,
                               rng.normal(0, sd, (n, 3)))


@pytest.fixture(scope="module")
def scored(tmp_path_factory):
    root = tmp_path_factory.mktemp("palm6dof")
    folder, work = root / "rom", root / "work"
    folder.mkdir()
    for name in ("video.mp4", "intrinsics.yaml"):
        shutil.copy(SAMPLE / name, folder / name)
    tr = dict(np.load(SAMPLE.parent / "wrist-rom-01.truth.npz"))
    t_q = tr["t"][::2]  # 100 Hz, on the session clock
    R_WH = Q.to_matrix(tr["q_WH"][::2])
    lab = np.linalg.inv(TO_WORLD)  # W -> lab: the export is in the lab's frame
    xyz_lab = tr["wrist"][::2] @ lab[:3, :3].T + lab[:3, 3]
    R_lab = lab[:3, :3] @ R_WH
    xyz_lab[300:310] = np.nan  # a 0.1 s gap in the body
    (folder / "hand6d.tsv").write_text(format_6dof(["hand"], xyz_lab[:, None], R_lab[:, None], 100.0))
    toml = (SAMPLE / "session.toml").read_text()
    head = toml[:toml.index("[groundtruth]")]
    (folder / "session.toml").write_text(
        head + '[groundtruth]\nfile = "hand6d.tsv"\nhand = "hand"\nto_world = '
        + str(TO_WORLD.tolist()) + f"\n\n[sync]\ngroundtruth_offset_s = {t_q[0]}\n")
    rng = np.random.default_rng(11)
    t = tr["frame_t"]
    est_ang = tr["frame_angles_deg"] + _smooth_noise(rng, 0.5, t.size)
    est_w = tr["frame_wrist"] + _smooth_noise(rng, 0.001, t.size)
    traj = pd.DataFrame({"t": t, **{f"wrist_{a}": est_w[:, k] for k, a in enumerate("xyz")},
                         **{f"{a}_deg": est_ang[:, k] for k, a in enumerate(ANGLES)}})
    work.mkdir()
    traj.to_csv(work / "trajectory-ukf-palm.csv", index=False)
    kinematics_table(traj, load_session(folder)).to_csv(work / "kinematics-ukf-palm.csv",
                                                        index=False)
    r = run_cli("compare", folder, "--out", work)
    assert r.exit_code == 0, r.stderr
    return work, tr, est_ang, est_w


def test_each_wrist_angle_scored_against_the_6dof_rotation(scored):
    work, tr, est_ang, _ = scored
    ang = pd.read_csv(work / "wrist-angle-errors.csv", comment="#").set_index("angle")
    err = est_ang - tr["frame_angles_deg"]  # the noise we added, against the exact angles
    for k, a in enumerate(ANGLES):
        assert ang.loc[a, "rmse_deg"] == pytest.approx(np.sqrt(np.mean(err[:, k] ** 2)), abs=0.05)
        assert ang.loc[a, "mean_deg"] == pytest.approx(err[:, k].mean(), abs=0.05)
        exact_rom = np.ptp(tr["frame_angles_deg"][:, k])
        assert ang.loc[a, "rom_truth_deg"] == pytest.approx(exact_rom, abs=0.5)
        assert abs(ang.loc[a, "rom_error_deg"]) <= 2.0  # issue 12: wrist-angle RoM within 2°
    assert ang["n"].min() >= tr["frame_t"].size - 5  # the 0.1 s gap: ≤ 4 frames at 30 fps


def test_the_measures_and_position_use_the_6dof_truth(scored):
    work, tr, _, est_w = scored
    m = pd.read_csv(work / "measures.csv", comment="#")
    m = m[m.segment == "session"].set_index("measure")
    for k, a in enumerate(ANGLES):
        exact = tr["frame_angles_deg"][:, k]
        assert float(m.loc[f"wrist_{a}_rom", "truth"]) == pytest.approx(np.ptp(exact), abs=0.5)
        assert abs(m.loc[f"wrist_{a}_rom", "error"]) <= 2.0
    pos = pd.read_csv(work / "errors.csv", comment="#").set_index("axis")
    e = (est_w - tr["frame_wrist"]) * 100
    assert pos.loc["3d", "rmse_cm"] == pytest.approx(np.sqrt(np.mean(np.sum(e**2, 1))), abs=0.01)


def test_a_6dof_export_without_the_named_hand_body_is_one_line(scored, tmp_path):
    work, *_ = scored
    folder = tmp_path / "rom"
    shutil.copytree(work.parent / "rom", folder)
    toml = folder / "session.toml"
    toml.write_text(toml.read_text().replace('hand = "hand"', 'hand = "palm"'))
    r = run_cli("compare", folder, "--out", work)
    assert r.exit_code == 1 and len(r.stderr.strip().splitlines()) == 1
    assert "hand6d.tsv" in r.stderr and "'palm'" in r.stderr and "hand" in r.stderr
