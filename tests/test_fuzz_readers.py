"""Property-based fuzzing of every reader: a valid file, mutated (truncated, bytes flipped, a
cell replaced, a row duplicated, a column shifted), is either read into finite, plausible
values or refused with armtrack's own error. Never anything else: no other exception, no
NaN where the contract promises numbers, no physically impossible value.

`make test` runs a few dozen mutations per reader; `make validate` runs 2,000
(ARMTRACK_FUZZ_EXAMPLES). Examples are derandomised: the same run on every machine.
"""

from __future__ import annotations

import os
import shutil

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from armtrack_cli.core.errors import ArmtrackError
from armtrack_cli.core.limits import MAX_ACCEL_M_S2, MAX_GYRO_RAD_S

from .conftest import REPO

EXAMPLES = int(os.environ.get("ARMTRACK_FUZZ_EXAMPLES", "25"))
FUZZ = settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
                suppress_health_check=list(HealthCheck))
SAMPLES = REPO / "sample_sessions"
TOKENS = ["", "nan", "NaN", "inf", "-inf", "-1e30", "1e308", "abc", "0", "-0", "1e-320",
          "99999999999999999999", "0x10", "1,5", " ", "\x00", "é"]


@st.composite
def mutation(draw):
    kind = draw(st.sampled_from(["truncate", "flip", "cell", "duplicate", "shift", "swap"]))
    return (kind, draw(st.floats(0, 1)), draw(st.floats(0, 1)), draw(st.sampled_from(TOKENS)),
            draw(st.integers(0, 255)))


def mutate(data: bytes, m) -> bytes:
    kind, a, b, token, byte = m
    if kind == "truncate":
        return data[: int(len(data) * a)]
    if kind == "flip":
        out = bytearray(data)
        if out:
            out[int(a * (len(out) - 1))] = byte
        return bytes(out)
    lines = data.split(b"\n")
    i = int(a * (len(lines) - 1))
    sep = b"\t" if b"\t" in lines[i] else b","
    cells = lines[i].split(sep)
    j = int(b * (len(cells) - 1))
    if kind == "cell":
        cells[j] = token.encode()
    elif kind == "shift":
        del cells[j]
    elif kind == "swap" and len(cells) > 1:
        cells[0], cells[j] = cells[j], cells[0]
    elif kind == "duplicate":
        lines.insert(i, lines[i])
    lines[i] = sep.join(cells)
    return b"\n".join(lines)


def _head(path, n_lines: int) -> bytes:
    return b"\n".join(path.read_bytes().split(b"\n")[:n_lines]) + b"\n"


def _plausible_imu(s) -> None:
    assert np.isfinite(s.t).all() and (np.diff(s.t) > 0).all()
    assert np.nanmax(np.abs(s.acc), initial=0) <= MAX_ACCEL_M_S2
    assert np.nanmax(np.abs(s.gyr), initial=0) <= MAX_GYRO_RAD_S
    ok = np.isfinite(s.quat).all(axis=1)
    assert ok.any() and np.allclose(np.linalg.norm(s.quat[ok], axis=1), 1.0, atol=1e-6)
    assert np.isfinite(s.acc).all(axis=1).any() and 0 < s.rate_hz <= 10000


def _check(tmp_path, name: str, data: bytes, read, plausible) -> None:
    path = tmp_path / name
    path.write_bytes(data)
    try:
        value = read(path)
    except ArmtrackError as exc:
        assert str(exc).startswith(str(path)) and "\n" not in str(exc), str(exc)
        return
    plausible(value)


class Files(dict):
    """Fixture data that hypothesis prints by name, not by its bytes."""

    def __repr__(self) -> str:
        return f"Files({', '.join(self)})"


@pytest.fixture(scope="module")
def imu_files(tmp_path_factory):
    from armtrack_cli.session.imu import read_imu

    d = tmp_path_factory.mktemp("fuzz-imu")
    s = read_imu(SAMPLES / "circle-01" / "imu.txt")
    csv = "t,ax,ay,az,gx,gy,gz\n" + "\n".join(
        f"{s.t[i]:.4f}," + ",".join(f"{v:.5f}" for v in (*s.acc[i], *s.gyr[i]))
        for i in range(300)) + "\n"
    return Files(xsens=_head(SAMPLES / "circle-01" / "imu.txt", 309), csv=csv.encode(),
                 mcap=(SAMPLES / "reach-01" / "imu.mcap").read_bytes(), dir=d)


@pytest.mark.parametrize("fmt", ["xsens", "csv", "mcap"])
@FUZZ
@given(m=mutation())
def test_imu_readers(tmp_path_factory, imu_files, fmt, m):
    from armtrack_cli.session.imu import read_imu

    tmp = tmp_path_factory.mktemp("imu")
    _check(tmp, f"imu.{ {'xsens': 'txt'}.get(fmt, fmt) }", mutate(imu_files[fmt], m), read_imu,
           _plausible_imu)


@FUZZ
@given(m=mutation())
def test_qualisys_reader(tmp_path_factory, m):
    from armtrack_cli.session.qualisys import read_qualisys

    def plausible(q):
        assert np.isfinite(q.t).all() and (np.diff(q.t) > 0).all() and q.rate_hz > 0
        assert np.nanmax(np.abs(q.xyz), initial=0) < 100.0

    data = _head(SAMPLES / "circle-01" / "qualisys.tsv", 312)
    _check(tmp_path_factory.mktemp("qtm"), "qualisys.tsv", mutate(data, m), read_qualisys,
           plausible)


@FUZZ
@given(m=mutation())
def test_camera_yaml_reader(tmp_path_factory, m):
    from armtrack_cli.session.camera_yaml import read_camera_yaml

    def plausible(c):
        assert np.isfinite(c.K).all() and np.isfinite(c.dist).all() and c.width > 0
        if c.R_WC is not None:
            assert np.allclose(c.R_WC @ c.R_WC.T, np.eye(3), atol=1e-6)

    data = (SAMPLES / "circle-01" / "intrinsics.yaml").read_bytes()
    _check(tmp_path_factory.mktemp("cam"), "camera.yaml", mutate(data, m), read_camera_yaml,
           plausible)


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    from armtrack_cli import pipeline

    folder = tmp_path_factory.mktemp("fuzz-work") / "reach-01"
    shutil.copytree(SAMPLES / "reach-01", folder)
    pipeline.run(folder, through="fuse", methods=("ekf",))
    return folder / "armtrack"


@FUZZ
@given(m=mutation())
def test_detections_reader(tmp_path_factory, work, m):
    from armtrack_cli.session.tables import read_patch_detections

    def plausible(r):
        t, uv = r
        assert np.isfinite(t).all() and (np.diff(t) > 0).all()
        ok = np.isfinite(uv).all(axis=1)
        assert (np.abs(uv[ok]) < 2000).all()

    _check(tmp_path_factory.mktemp("det"), "detections.csv",
           mutate((work / "detections.csv").read_bytes(), m),
           lambda p: read_patch_detections(p, width=640, height=480, n_frames=360), plausible)


@FUZZ
@given(m=mutation())
def test_trajectory_reader(tmp_path_factory, work, m):
    from armtrack_cli.session.tables import read_trajectory

    def plausible(df):
        t = df["t"].to_numpy()
        assert np.isfinite(t).all() and (np.diff(t) > 0).all()
        assert np.isfinite(df.to_numpy()[~np.isnan(df.to_numpy())]).all()

    _check(tmp_path_factory.mktemp("traj"), "trajectory-ekf.csv",
           mutate((work / "trajectory-ekf.csv").read_bytes(), m), read_trajectory, plausible)


@FUZZ
@given(m=mutation())
def test_session_toml_reader(tmp_path_factory, m):
    from armtrack_cli.session.config import load_session

    folder = tmp_path_factory.mktemp("toml")
    for f in ("imu.txt", "video.mp4", "qualisys.tsv", "intrinsics.yaml"):
        (folder / f).symlink_to(SAMPLES / "circle-01" / f)
    data = (SAMPLES / "circle-01" / "session.toml").read_bytes()
    (folder / "session.toml").write_bytes(mutate(data, m))
    try:
        s = load_session(folder)
    except ArmtrackError as exc:
        assert "\n" not in str(exc) and "session.toml" in str(exc), str(exc)
        return
    if s.arm is not None:
        assert np.isfinite(s.arm.shoulder_m).all() and s.arm.upper_arm_m > 0
