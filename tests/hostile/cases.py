"""Hostile inputs across every command: damaged, hand-edited or odd files that a user can
make. Each case copies a worked sample session (its armtrack/ work folder filled by calibrate,
detect, fuse ekf and compare), applies one mutation, runs one command, and names the file the
one-line error must blame and a phrase it must contain.

A case is (name, command args with {S} for the session folder, mutation, file, phrase).
"""

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
