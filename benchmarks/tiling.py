"""Copies of one simulated arm session back to back (benchmarks/sessions.tiled_session): the
Xsens text export, the Qualisys TSV and the video, each cut to whole periods of its own clock
and continued with continuous time stamps, frame numbers and packet counters."""

from __future__ import annotations

import shutil
from pathlib import Path

import cv2

COUNTER_WRAP = 2**16  # Xsens PacketCounter is a uint16
STF_PER_S = 10_000  # SampleTimeFine ticks per second (MT Manager)


def _split(path: Path, header_end) -> tuple[list[str], list[str]]:
    lines = path.read_text().splitlines(keepends=True)
    k = next(i for i, line in enumerate(lines) if header_end(line)) + 1
    return lines[:k], lines[k:]


def tile_imu(src: Path, dst: Path, copies: int, period_s: float) -> None:
    head, rows = _split(src, lambda line: line.startswith("PacketCounter"))
    stf0 = [int(r.split("\t", 2)[1]) for r in rows]
    keep = [i for i, v in enumerate(stf0) if v - stf0[0] < period_s * STF_PER_S]
    with dst.open("w") as f:
        f.writelines(head)
        n = 0
        for c in range(copies):
            for i in (keep if c < copies - 1 else range(len(rows))):
                _, _, rest = rows[i].split("\t", 2)
                stf = stf0[i] + round(c * period_s * STF_PER_S)
                f.write(f"{n % COUNTER_WRAP:05d}\t{stf}\t{rest}")
                n += 1


def tile_qualisys(src: Path, dst: Path, copies: int, period_s: float) -> None:
    head, rows = _split(src, lambda line: line.startswith("Frame\t"))
    t = [float(r.split("\t", 2)[1]) for r in rows]
    keep = [i for i, v in enumerate(t) if v - t[0] < period_s - 1e-9]
    out, n = [], 0
    for c in range(copies):
        for i in (keep if c < copies - 1 else range(len(rows))):
            _, _, rest = rows[i].split("\t", 2)
            n += 1
            out.append(f"{n}\t{t[i] + c * period_s:.5f}\t{rest}")
    head = [f"NO_OF_FRAMES\t{n}\n" if h.startswith("NO_OF_FRAMES") else h for h in head]
    dst.write_text("".join(head + out))


def tile_video(src: Path, dst: Path, copies: int, period_s: float) -> None:
    cap = cv2.VideoCapture(str(src))
    fps = cap.get(cv2.CAP_PROP_FPS)
    size = int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))
    cap.release()
    per = round(period_s * fps)
    writer = cv2.VideoWriter(str(dst), cv2.VideoWriter_fourcc(*"mp4v"), fps, size)
    for _ in range(copies):
        cap = cv2.VideoCapture(str(src))
        for _ in range(per):
            ok, img = cap.read()
            if not ok:
                raise RuntimeError(f"{src}: fewer than {per} frames")
            writer.write(img)
        cap.release()
    writer.release()


def tile(base: str, out: str, copies: int, period_s: float) -> None:
    b, o = Path(base), Path(out)
    tile_imu(b / "imu.txt", o / "imu.txt", copies, period_s)
    tile_qualisys(b / "qualisys.tsv", o / "qualisys.tsv", copies, period_s)
    for name in ("intrinsics.yaml",):
        shutil.copy(b / name, o / name)
    toml = (b / "session.toml").read_text()
    (o / "session.toml").write_text(toml.replace(
        "# simulated by:", f"# {copies} copies of {b.name} back to back (benchmarks/tiling.py); "
        "that one simulated by:", 1))
    tile_video(b / "video.mp4", o / "video.mp4", copies, period_s)
