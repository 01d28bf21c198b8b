"""Ground truth from C3D and QTM 6DOF exports, checked against the QTM 3D TSV reader on the
same data: the same simulated session scored from either file gives the same errors.csv."""

from __future__ import annotations

import shutil

import numpy as np
import pandas as pd
import pytest

from armtrack_cli import pipeline
from armtrack_cli.core import quaternion as Q
from armtrack_cli.core.errors import ConfigError, GroundTruthError
from armtrack_cli.session.c3d import read_c3d, write_c3d
from armtrack_cli.session.config import load_session
from armtrack_cli.session.groundtruth import body_rotation_W, read_markers
from armtrack_cli.session.qtm6dof import euler_qtm
from armtrack_cli.session.qualisys import read_qualisys

NUMERIC = ["mean_cm", "std_cm", "rmse_cm", "max_abs_cm", "within_5cm_pct", "n"]


@pytest.fixture(scope="module")
def scored(tmp_path_factory):
    """A 4 s simulated arm session fused with the EKF and scored against its QTM TSV."""
    root = tmp_path_factory.mktemp("gt")
    pipeline.simulate(root / "s", pipeline.ArmSimSettings(task="circle", duration_s=4.0, seed=3))
    r = pipeline.run(root / "s", through="compare", methods=("ekf",), seed=1)
    assert r["stages"]["compare"] == "ran"
    return root / "s", pd.read_csv(root / "s" / "armtrack" / "errors.csv")


def _rescore(session, tmp_path, name, write, toml_edit):
    """A copy of the session whose [groundtruth] names another file; compare rerun."""
    other = tmp_path / name
    shutil.copytree(session, other)
    write(other)
    toml = other / "session.toml"
    toml.write_text(toml_edit(toml.read_text()))
    pipeline.compare(other, methods=("ekf",))
    return pd.read_csv(other / "armtrack" / "errors.csv")


def test_c3d_and_tsv_give_the_same_errors(scored, tmp_path):
    """Both files hold the same numbers: the simulated markers in mm rounded to float32 (what a
    float C3D stores), with gaps; the TSV is written with every digit of those floats. (With
    QTM's 3-decimal TSV instead, errors.csv differs in its last printed digit, ≤ 5e-6 cm,
    from float32 rounding of millimetres.)"""
    session, _ = scored
    qtm = read_qualisys(session / "qualisys.tsv")
    mm = (qtm.xyz * 1000).astype(np.float32).astype(float)
    mm[50:60, 2] = np.nan  # a wrist gap
    mm[200:205, 1] = np.nan
    lines = (session / "qualisys.tsv").read_text().splitlines()
    head = lines[:lines.index(next(ln for ln in lines if ln.startswith("Frame")))]
    rows = ["\t".join(["Frame", "Time"] + [f"{n} {a}" for n in qtm.names for a in "XYZ"])]
    rows += ["\t".join([str(i + 1), f"{i / qtm.rate_hz:.5f}"] + [
        "" if np.isnan(v) else repr(float(v)) for v in mm[i].ravel()]) for i in range(mm.shape[0])]

    def write_tsv(folder):
        (folder / "qualisys.tsv").write_text("\n".join(head + rows) + "\n")

    def write_c3d_too(folder):
        write_tsv(folder)
        write_c3d(folder / "trial.c3d", mm / 1000.0, list(qtm.names), qtm.rate_hz)

    tsv_errors = _rescore(session, tmp_path, "tsv", write_tsv, lambda t: t)
    c3d_errors = _rescore(session, tmp_path, "c3d", write_c3d_too,
                          lambda t: t.replace('file = "qualisys.tsv"', 'file = "trial.c3d"'))
    assert list(c3d_errors["joint"]) == list(tsv_errors["joint"])
    diff = np.abs(c3d_errors[NUMERIC].to_numpy() - tsv_errors[NUMERIC].to_numpy())
    assert diff[:, :4].max() < 1e-6, diff  # cm
    np.testing.assert_array_equal(c3d_errors["n"], tsv_errors["n"])
    assert tsv_errors["n"].min() < mm.shape[0] - 10  # the gaps were left out, not zeros


def test_c3d_units_gaps_and_first_frame(tmp_path):
    rng = np.random.default_rng(5)
    xyz = rng.uniform(-1.0, 1.0, (30, 2, 3))
    xyz[4:7, 1] = np.nan
    write_c3d(tmp_path / "cm.c3d", xyz, ["A", "B"], 150.0, units="cm", first_frame=200)
    m = read_markers(tmp_path / "cm.c3d")
    assert m.names == ("A", "B") and m.rate_hz == 150.0 and "first frame 200" in m.notes[0]
    np.testing.assert_allclose(m.t, np.arange(30) / 150.0)
    np.testing.assert_array_equal(np.isnan(m.xyz), np.isnan(xyz))
    np.testing.assert_allclose(m.xyz, xyz, atol=1e-8, equal_nan=True)  # float32 in cm


def test_damaged_c3d_is_one_clear_error(tmp_path):
    write_c3d(tmp_path / "a.c3d", np.zeros((5, 1, 3)) + 0.1, ["A"], 100.0)
    raw = (tmp_path / "a.c3d").read_bytes()
    (tmp_path / "a.c3d").write_bytes(raw[:600])
    with pytest.raises(GroundTruthError, match="a.c3d"):
        read_c3d(tmp_path / "a.c3d")


# ------------------------------------------------------------------ QTM 6DOF

def format_6dof(names, xyz_m, R, rate_hz, *, row_major=False) -> str:
    """A QTM 6DOF TSV: per body X Y Z (mm) Roll Pitch Yaw (deg) Residual Rot[0..8]."""
    n, b = xyz_m.shape[:2]
    head = [f"NO_OF_FRAMES\t{n}", "NO_OF_CAMERAS\t8", f"NO_OF_BODIES\t{b}",
            f"FREQUENCY\t{rate_hz:g}", "NO_OF_ANALOG\t0", "ANALOG_FREQUENCY\t0",
            "DESCRIPTION\t--", "TIME_STAMP\t2026-11-20, 10:15:00.000\t0.000",
            "DATA_INCLUDED\t6D", "BODY_NAMES\t" + "\t".join(names)]
    cols = ["Frame", "Time"] + [c for _ in names for c in
                                ["X", "Y", "Z", "Roll", "Pitch", "Yaw", "Residual"]
                                + [f"Rot[{k}]" for k in range(9)]]
    rows = ["\t".join(cols)]
    for i in range(n):
        cells = [str(i + 1), f"{i / rate_hz:.5f}"]
        for k in range(b):
            if not np.isfinite(xyz_m[i, k]).all():
                cells += ["0.000"] * 3 + ["NaN"] * 13
                continue
            r = R[i, k]
            # angles of R = Rx(roll) Ry(pitch) Rz(yaw)
            pitch = np.degrees(np.arcsin(np.clip(r[0, 2], -1, 1)))
            roll = np.degrees(np.arctan2(-r[1, 2], r[2, 2]))
            yaw = np.degrees(np.arctan2(-r[0, 1], r[0, 0]))
            rot = (r if row_major else r.T).ravel()
            cells += [f"{v:.3f}" for v in xyz_m[i, k] * 1000] + [
                f"{roll:.3f}", f"{pitch:.3f}", f"{yaw:.3f}", "0.500"] + [f"{v:.6f}" for v in rot]
        rows.append("\t".join(cells))
    return "\n".join(head + rows) + "\n"


def _hand_rotations(n, seed=2):
    rng = np.random.default_rng(seed)
    ang = np.cumsum(rng.normal(0, 0.02, (n, 3)), axis=0)
    return Q.to_matrix(Q.from_euler_zyx(ang[:, 0], ang[:, 1], ang[:, 2]))


@pytest.mark.parametrize("row_major", [False, True])
def test_6dof_rotation_and_position_read(tmp_path, row_major):
    n = 40
    R = _hand_rotations(n)[:, None]
    xyz = np.random.default_rng(1).uniform(-0.5, 0.5, (n, 1, 3))
    xyz[10:12] = np.nan
    p = tmp_path / "6d.tsv"
    p.write_text(format_6dof(["hand"], xyz, R, 100.0, row_major=row_major))
    m = read_markers(p)
    assert m.names == ("hand",) and m.rotations.shape == (n, 1, 3, 3)
    np.testing.assert_allclose(m.xyz, np.round(xyz * 1000, 3) / 1000, atol=1e-9, equal_nan=True)
    T = np.eye(4)
    T[:3, :3] = euler_qtm([0.0], [0.0], [90.0])[0]
    R_W = body_rotation_W(m, "hand", T, p)
    ok = np.isfinite(xyz[:, 0, 0])
    np.testing.assert_allclose(R_W[ok], T[:3, :3] @ R[ok, 0], atol=2e-6)
    assert np.isnan(R_W[~ok]).all()
    with pytest.raises(GroundTruthError, match="is a 6DOF \\(rigid body\\) export"):
        read_qualisys(p)  # the 3D reader still refuses it clearly


def test_6dof_body_as_the_wrist_scores_like_the_marker(scored, tmp_path):
    session, tsv_errors = scored
    qtm = read_qualisys(session / "qualisys.tsv")
    wrist = qtm.marker("R_WRI")[:, None]

    def write(folder):
        (folder / "hand_6d.tsv").write_text(
            format_6dof(["hand"], wrist, _hand_rotations(wrist.shape[0])[:, None], qtm.rate_hz))

    def edit(text):
        return text.replace('file = "qualisys.tsv"', 'file = "hand_6d.tsv"').replace(
            'markers = { shoulder = "R_SHO", elbow = "R_ELB", wrist = "R_WRI" }',
            'markers = { wrist = "hand" }\nhand = "hand"')

    errs = _rescore(session, tmp_path, "sixdof", write, edit)
    ref = tsv_errors[tsv_errors["joint"] == "wrist"].reset_index(drop=True)
    assert list(errs["joint"].unique()) == ["wrist"]
    np.testing.assert_allclose(errs[NUMERIC].to_numpy(), ref[NUMERIC].to_numpy(), atol=1e-9)


# ------------------------------------------------------------------ session.toml keys

@pytest.mark.parametrize("extra, message", [
    ('statics = "x.csv"', "[groundtruth] statics is not a key armtrack knows"),
    ('clusters = { RLEP = "RUAR" }', "[groundtruth] clusters needs [groundtruth] static"),
    ('static = "s.csv"\nclusters = { RLEP = ["A", "B"] }',
     "[groundtruth] clusters.RLEP = ['A', 'B'] is neither a marker prefix nor a list"),
])
def test_new_groundtruth_keys_are_validated(tmp_path, extra, message):
    (tmp_path / "session.toml").write_text(
        f'[groundtruth]\nfile = "t.tsv"\nmarkers = {{ elbow = "mid(RLEP, RMEP)" }}\n{extra}\n')
    with pytest.raises(ConfigError) as e:
        load_session(tmp_path)
    assert message in str(e.value)


def test_a_malformed_point_is_refused(tmp_path):
    (tmp_path / "session.toml").write_text('[groundtruth]\nfile = "t.tsv"\n'
                                           'markers = { elbow = "mid(RLEP)" }\n')
    with pytest.raises(ConfigError, match="markers.elbow = 'mid\\(RLEP\\)' is not a marker name"):
        load_session(tmp_path)


@pytest.mark.parametrize("side", ["right", "left"])
def test_wrist_angles_from_a_6dof_hand_body(tmp_path, side):
    """A hand body turned through known wrist angles (the simulator's R_FH) after a neutral
    first second, exported as QTM 6DOF, read back and decomposed: the same angles."""
    from armtrack_cli.compare.hand_truth import wrist_angles_deg
    from armtrack_cli.simulate.hand import default_motion

    motion = default_motion("wrist-rom", 8.0)
    t = np.arange(0, 8.0, 0.01)
    q_WH = motion.q_WH(t, side)
    R_lab = Q.to_matrix(q_WH)  # to_world = identity
    p = tmp_path / "hand.tsv"
    p.write_text(format_6dof(["hand"], np.tile([0.4, 0.1, 0.05], (t.size, 1, 1)),
                             R_lab[:, None], 100.0))
    R_W = body_rotation_W(read_markers(p), "hand", np.eye(4), p)
    got = wrist_angles_deg(t, R_W, side)
    want = np.degrees(motion.angles(t))
    np.testing.assert_allclose(got, want, atol=0.01)  # Rot[] written with 6 decimals
    from armtrack_cli.pipeline.groundtruth import read_hand_angles

    (tmp_path / "session.toml").write_text(
        f'[session]\nside = "{side}"\n[groundtruth]\nfile = "hand.tsv"\n'
        'markers = { wrist = "hand" }\nhand = "hand"\n[sync]\ngroundtruth_offset_s = 0.5\n')
    t_s, via_session = read_hand_angles(load_session(tmp_path))
    np.testing.assert_allclose(t_s, t + 0.5)
    np.testing.assert_allclose(via_session, got)


def test_6dof_named_where_3d_markers_are_expected(tmp_path):
    """A 6DOF export with Euler angles only, named in session.toml as if it held markers: read
    (rotation from the angles), and the marker name refused saying it is a 6DOF export."""
    (tmp_path / "qualisys.tsv").write_text(
        "NO_OF_FRAMES\t2\nFREQUENCY\t100\nNO_OF_BODIES\t1\nBODY_NAMES\thand\nDATA_INCLUDED\t6D\n"
        "1\t0.0\t1\t2\t3\t0\t0\t90\n2\t0.01\t1\t2\t3\t0\t0\t90\n")
    m = read_markers(tmp_path / "qualisys.tsv")
    np.testing.assert_allclose(m.rotations[0, 0], euler_qtm([0.0], [0.0], [90.0])[0], atol=1e-12)
    (tmp_path / "session.toml").write_text('[groundtruth]\nfile = "qualisys.tsv"\n'
                                           'markers = { wrist = "R_WRI" }\n')
    from armtrack_cli.pipeline.groundtruth import read_truth

    with pytest.raises(GroundTruthError, match=r"is a 6DOF \(rigid body\) export with no body "
                                               r"'R_WRI'.*its bodies are hand"):
        read_truth(load_session(tmp_path))
