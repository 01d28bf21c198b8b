"""Vicon Nexus trajectories CSV and joint centres by CAST (landmarks from a static trial,
carried by cluster rigid fits), checked on exact synthetic motion and on the real UE-ADL
trials against the authors' processed elbow flexion."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from armtrack_cli.compare import joint_centres as jc
from armtrack_cli.core import quaternion as Q
from armtrack_cli.pipeline.groundtruth import read_truth
from armtrack_cli.session.config import load_session
from armtrack_cli.session.groundtruth import read_markers

UE_ADL = Path(__file__).resolve().parents[2] / "shared" / "realdata" / "ue-adl"
needs_ue_adl = pytest.mark.skipif(not UE_ADL.is_dir(), reason="shared/realdata/ue-adl absent")


def _vicon_csv(names, xyz_mm, rate=100, first=41) -> bytes:
    head = ["Trajectories", str(rate), ",," + ",".join(f"P01:{n},," for n in names),
            "Frame,Sub Frame," + ",".join("X,Y,Z" for _ in names),
            ",," + ",".join("mm,mm,mm" for _ in names)]
    rows = [f"{first + i},0," + ",".join("" if not np.isfinite(v) else f"{v:.6f}"
                                         for v in xyz_mm[i].ravel()) for i in range(len(xyz_mm))]
    return ("\ufeff" + "\r\n".join(head + rows) + "\r\n").encode("utf-8")


def test_vicon_csv_with_bom_gaps_and_subject_prefix(tmp_path):
    xyz = np.random.default_rng(0).uniform(-900, 900, (20, 3, 3))
    xyz[5:8, 1] = np.nan
    (tmp_path / "t.csv").write_bytes(_vicon_csv(["A", "B", "C"], xyz))
    m = read_markers(tmp_path / "t.csv")
    assert m.names == ("A", "B", "C") and m.rate_hz == 100.0 and m.notes[0] == "first frame 41"
    np.testing.assert_allclose(m.t, np.arange(20) / 100.0)
    np.testing.assert_allclose(m.xyz, xyz / 1000.0, atol=1e-9, equal_nan=True)


def _rigid_motion(n, seed):
    rng = np.random.default_rng(seed)
    ang = np.cumsum(rng.normal(0, 0.05, (n, 3)), axis=0)
    return Q.to_matrix(Q.from_euler_zyx(ang[:, 0], ang[:, 1], ang[:, 2])), \
        np.cumsum(rng.normal(0, 0.01, (n, 3)), axis=0)


def test_cast_carries_a_landmark_exactly_under_rigid_motion():
    rng = np.random.default_rng(3)
    cluster0 = rng.normal(0, 0.04, (4, 3))  # a cluster of 4, 4 cm spread
    landmark0 = np.array([0.03, -0.12, 0.02])  # 12 cm away, as an epicondyle from its cluster
    R, t = _rigid_motion(200, 4)
    cluster = np.einsum("nij,kj->nki", R, cluster0) + t[:, None]
    truth = np.einsum("nij,j->ni", R, landmark0) + t
    cluster[50:60, 2] = np.nan  # one marker hidden: 3 still fix the fit
    cluster[100:105, 1:] = np.nan  # two hidden: a gap
    static = cluster0[None].repeat(10, axis=0)
    ref, point = jc.calibrate(static, landmark0[None].repeat(10, axis=0))
    got = jc.carry(ref, point, cluster)
    ok = np.isfinite(got).all(axis=1)
    assert (~ok).sum() == 5
    np.testing.assert_allclose(got[ok], truth[ok], atol=1e-12)


@needs_ue_adl
def test_ue_adl_truth_through_groundtruth_keys(tmp_path):
    (tmp_path / "session.toml").write_text(f"""
[groundtruth]
file = "{UE_ADL / 'ADL001FR1.csv'}"
static = "{UE_ADL / 'ADL001_static.csv'}"
markers = {{ shoulder = "RGTH", elbow = "mid(RLEP, RMEP)", wrist = "mid(RSPR, RSPU)" }}
clusters = {{ RGTH = "RUAR", RLEP = "RUAR", RMEP = "RUAR", RSPR = "RLAR", RSPU = "RLAR" }}
""")
    truth = read_truth(load_session(tmp_path))
    assert set(truth.xyz) == {"shoulder", "elbow", "wrist"} and truth.rate_hz == 100.0
    static = read_markers(UE_ADL / "ADL001_static.csv")
    # the carried joints keep the static trial's segment lengths (rigid carriage), to 1 mm
    seg = np.linalg.norm(truth.xyz["elbow"] - truth.xyz["shoulder"], axis=1)
    el0 = (static.marker("RLEP") + static.marker("RMEP")).mean(axis=0) / 2
    assert np.nanmax(np.abs(seg - np.linalg.norm(el0 - static.marker("RGTH").mean(axis=0)))) < 1e-3
    assert np.isfinite(truth.xyz["wrist"]).all(axis=1).mean() > 0.95


@needs_ue_adl
@pytest.mark.parametrize("trial, three_point, isb, isb_upper, functional", [
    # measured (validation/ue_adl.py); the authors' RoM: DR1 63.9, CR1 64.5, FR1 81.0 deg
    ("DR1", -9.3, -4.5, -7.9, -2.9), ("CR1", -7.2, 1.0, -5.7, 0.9),
    ("FR1", -9.3, 7.0, 2.4, 0.0)])
def test_ue_adl_elbow_rom_beside_the_authors(trial, three_point, isb, isb_upper, functional):
    from armtrack_cli.compare.peer_angles import rom_beside_peer

    peer = pd.read_csv(UE_ADL / f"ADL001{trial}angles.csv")
    r = rom_beside_peer(read_markers(UE_ADL / "ADL001_static.csv"),
                        read_markers(UE_ADL / f"ADL001{trial}.csv"),
                        peer["elbow flexion-extension"].to_numpy(),
                        peer["Finger Velocity"].to_numpy())
    assert r["window_correlation"] > 0.98  # the authors' window found
    p = r["peer_rom_deg"]
    # three-point angle: 4-10 deg below their Euler angle (no segment axes; see docs)
    assert -10.5 < r["three_point_rom_deg"] - p < 0
    for key, want in (("three_point", three_point), ("isb", isb),
                      ("isb_upper_epicondyles", isb_upper), ("functional_axis", functional)):
        assert r[f"{key}_rom_deg"] - p == pytest.approx(want, abs=0.1), key
    # ISB frames from the clusters: within 5 deg on the drinking and combing trials
    if trial in ("DR1", "CR1"):
        assert abs(r["isb_rom_deg"] - p) < 5.0
    # with the functional flexion axis (from the trial's own motion): within 5 deg on each
    assert abs(r["functional_axis_rom_deg"] - p) < 5.0


def test_info_describes_a_lone_vicon_csv(tmp_path):
    from .conftest import run_cli

    xyz = np.random.default_rng(1).uniform(-900, 900, (10, 2, 3))
    (tmp_path / "trial.csv").write_bytes(_vicon_csv(["RLEP", "RMEP"], xyz))
    r = run_cli("info", tmp_path / "trial.csv", "--json")
    assert r.exit_code == 0, r.stderr
    assert '"markers": [\n      "RLEP",\n      "RMEP"\n    ]' in r.stdout


def test_three_point_angle_is_arccos_of_cos_flexion_times_cos_carrying():
    """Random elbow poses: the three-point angle at the elbow from the same points the ISB
    frames use equals arccos(cos a · cos b) of their Z-X-Y angles (isb_angles docstring)."""
    from armtrack_cli.compare import isb_angles as ia

    rng = np.random.default_rng(4)
    n = 200
    gh = np.tile([0.0, 0.3, 0.0], (n, 1))
    el, em = np.tile([0.03, 0.0, 0.0], (n, 1)), np.tile([-0.03, 0.0, 0.0], (n, 1))
    a, b, c = (np.radians(rng.uniform(lo, hi, n)) for lo, hi in ((0, 140), (-20, 20), (-80, 80)))
    R = Q.to_matrix(Q.multiply(Q.multiply(Q.from_axis_angle(np.array([0, 0, 1.0]), a),
                                          Q.from_axis_angle(np.array([1.0, 0, 0]), b)),
                               Q.from_axis_angle(np.array([0, 1.0, 0]), c)))
    H = np.array([[0, 0, 1.0], [0, 1, 0], [-1, 0, 0]])  # humerus X, Y, Z (columns) in the lab
    F = H @ R  # forearm axes in the lab
    us = -0.25 * F[:, :, 1]  # the forearm's Y runs from US to the elbow centre (the origin)
    rs = us + 0.05 * F[:, :, 2]  # the radial styloid lateral of it (forearm Z)
    got = ia.zxy_deg(ia.joint_rotation(gh, el, em, rs, us))
    np.testing.assert_allclose(got, np.degrees(np.stack([a, b, c], -1)), atol=1e-9)
    three = 180 - jc.three_point_angle_deg(gh, (el + em) / 2, us)
    np.testing.assert_allclose(three, np.degrees(np.arccos(np.cos(a) * np.cos(b))), atol=1e-6)
