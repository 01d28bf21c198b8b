"""Mutations of a worked session folder: each returns a function that damages one file."""


from __future__ import annotations

import os
from pathlib import Path

import numpy as np

W = "armtrack"


def edit(rel: str, fn):
    """A mutation rewriting the text of SESSION/rel by fn(text) -> text."""
    def mutate(s: Path) -> None:
        p = s / rel
        p.write_text(fn(p.read_text()))
    return mutate


def lines(rel: str, fn):
    """A mutation rewriting the list of lines of SESSION/rel."""
    return edit(rel, lambda t: "\n".join(fn(t.splitlines())) + "\n")


def cell(rel: str, row: int, col: str, value: str, sep: str = ","):
    """Replace one cell (data row ``row``, column ``col``) of a delimited table."""
    def fn(ls):
        head = next(i for i, line in enumerate(ls) if col in line.split(sep))
        k = ls[head].split(sep).index(col)
        parts = ls[head + 1 + row].split(sep)
        parts[k] = value
        ls[head + 1 + row] = sep.join(parts)
        return ls
    return lines(rel, fn)


def replace(rel: str, old: str, new: str):
    def fn(t):
        assert old in t, (rel, old)
        return t.replace(old, new, 1)
    return edit(rel, fn)


def write(rel: str, data: bytes | str):
    def mutate(s: Path) -> None:
        p = s / rel
        p.unlink(missing_ok=True)
        p.write_bytes(data if isinstance(data, bytes) else data.encode())
    return mutate


def fifo(rel: str):
    def mutate(s: Path) -> None:
        (s / rel).unlink()
        os.mkfifo(s / rel)
    return mutate


def link(rel: str, target: str):
    def mutate(s: Path) -> None:
        (s / rel).unlink()
        os.symlink(target, s / rel)
    return mutate


def folder(rel: str):
    def mutate(s: Path) -> None:
        p = s / rel
        p.unlink()
        p.mkdir()
    return mutate


def truncate(rel: str, share: float):
    def mutate(s: Path) -> None:
        p = s / rel
        data = p.read_bytes()
        p.write_bytes(data[: int(len(data) * share)])
    return mutate


def nothing(s: Path) -> None:
    return None


GARBAGE = bytes(np.random.default_rng(7).integers(0, 256, 3000, dtype=np.uint8))
IMU = "imu.txt"
DET = f"{W}/detections.csv"
CAM = f"{W}/camera.yaml"
TRAJ = f"{W}/trajectory-ekf.csv"
KIN = f"{W}/kinematics-ekf.csv"
QTM = "qualisys.tsv"
TOML = "session.toml"
FUSE = ["fuse", "{S}", "--method", "ekf"]
COMPARE = ["compare", "{S}"]
CALIB = ["calibrate", "{S}"]
DETECT = ["detect", "{S}"]
INFO = ["info", "{S}"]
RUN = ["run", "{S}", "--method", "ekf", "--force"]


def stf_back(s: Path) -> None:
    """SampleTimeFine one tick behind its predecessor in row 50."""
    def fn(ls):
        k = ls[8].split("\t").index("SampleTimeFine")
        prev = ls[8 + 50].split("\t")
        row = ls[8 + 51].split("\t")
        row[k] = str(int(prev[k]) - 1)
        ls[8 + 51] = "\t".join(row)
        return ls
    lines(IMU, fn)(s)


def column(rel: str, col: str, value: str, sep: str = "\t", header_at: int = 8):
    """Every data row's ``col`` set to ``value``."""
    def fn(ls):
        k = ls[header_at].split(sep).index(col)
        for i in range(header_at + 1, len(ls)):
            parts = ls[i].split(sep)
            parts[k] = value
            ls[i] = sep.join(parts)
        return ls
    return lines(rel, fn)


def qtm_time_ms(s: Path) -> None:
    def fn(ls):
        for i in range(12, len(ls)):
            parts = ls[i].split("\t")
            parts[1] = f"{float(parts[1]) * 1000:.3f}"
            ls[i] = "\t".join(parts)
        return ls
    lines(QTM, fn)(s)


def qtm_marker_gone(s: Path) -> None:
    def fn(ls):
        for i in range(12, len(ls)):
            parts = ls[i].split("\t")
            parts[8:11] = ["", "", ""]
            ls[i] = "\t".join(parts)
        return ls
    lines(QTM, fn)(s)


def zero_middle(rel: str):
    """The middle third of a file overwritten with zeros (a damaged copy)."""
    def mutate(s: Path) -> None:
        p = s / rel
        b = bytearray(p.read_bytes())
        n = len(b)
        b[n // 3: 2 * n // 3] = bytes(2 * n // 3 - n // 3)
        p.write_bytes(bytes(b))
    return mutate


def both(*mutations):
    def mutate(s: Path) -> None:
        for m in mutations:
            m(s)
    return mutate


def mcap_imu(acc_nan: bool = False, quat_nan: bool = False):
    def mutate(s: Path) -> None:
        from armtrack_cli.session.export.mcap import write_imu_mcap

        t = np.arange(300) / 100.0
        acc = np.tile([0.0, 0.0, 9.81], (300, 1))
        q = np.tile([1.0, 0.0, 0.0, 0.0], (300, 1))
        if acc_nan:
            acc[:] = np.nan
        if quat_nan:
            q[:] = np.nan
        (s / IMU).unlink()
        write_imu_mcap(s / "imu.mcap", t, acc, np.zeros((300, 3)), q)
        replace(TOML, 'file = "imu.txt"', 'file = "imu.mcap"')(s)
    return mutate


def csv_imu(edit_rows):
    def mutate(s: Path) -> None:
        t = np.arange(300) / 100.0
        rows = [f"{t[i]:.2f},0.01,0.02,9.81,0.001,0.002,0.003" for i in range(300)]
        (s / IMU).unlink()
        (s / "imu.csv").write_text("t,ax,ay,az,gx,gy,gz\n" + "\n".join(edit_rows(rows)) + "\n")
        replace(TOML, 'file = "imu.txt"', 'file = "imu.csv"')(s)
    return mutate


