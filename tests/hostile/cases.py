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


ARM_CASES = [
    # --- the IMU export, as fuse and info meet it
    ("imu-acc-1e30", FUSE, cell(IMU, 100, "Acc_X", "1e30", "\t"), IMU, "16 g"),
    ("imu-acc-1e30-info", INFO, cell(IMU, 100, "Acc_X", "1e30", "\t"), IMU, "16 g"),
    ("imu-gyr-deg", FUSE, cell(IMU, 7, "Gyr_Y", "500", "\t"), IMU, "35 rad/s"),
    ("imu-stf-back", FUSE, stf_back, IMU, "SampleTimeFine steps back"),
    ("imu-stf-back-info", INFO, stf_back, IMU, "SampleTimeFine steps back"),
    ("imu-update-rate-silly", FUSE, lines(IMU, lambda ls: ["// Update Rate: 3.0Hz"] + ls), IMU,
     "Update Rate 3 Hz"),
    ("imu-update-rate-text", INFO, lines(IMU, lambda ls: ["// Update Rate: fastHz"] + ls), IMU,
     "is not a number"),
    ("imu-update-rate-huge", FUSE, lines(IMU, lambda ls: ["// Update Rate: 1e12Hz"] + ls), IMU,
     "outside 1"),
    ("imu-all-acc-nan", FUSE, both(column(IMU, "Acc_X", "NaN"), column(IMU, "Acc_Y", "NaN"),
                                   column(IMU, "Acc_Z", "NaN")), IMU, "no usable accelerometer"),
    ("imu-all-quat-nan", FUSE, both(*(column(IMU, f"Quat_q{k}", "NaN") for k in range(4))), IMU,
     "orientation is empty"),
    ("imu-mcap-acc-nan", FUSE, mcap_imu(acc_nan=True), "imu.mcap", "no usable accelerometer"),
    ("imu-mcap-truncated", FUSE, both(mcap_imu(), truncate("imu.mcap", 0.5)), "imu.mcap", "MCAP"),
    ("imu-csv-acc-nan", INFO, csv_imu(lambda r: [x.replace("0.01,0.02,9.81", "nan,nan,nan")
                                                 for x in r]), "imu.csv", "no usable"),
    ("imu-csv-acc-1e30", FUSE, csv_imu(lambda r: r[:50] + ["0.50,1e30,0,9.81,0,0,0"] + r[51:]),
     "imu.csv", "16 g"),
    ("imu-fifo", FUSE, fifo(IMU), IMU, "named pipe"),
    ("imu-fifo-info", INFO, fifo(IMU), IMU, "named pipe"),
    ("imu-dev-zero", INFO, link(IMU, "/dev/zero"), IMU, "a device"),
    ("imu-folder", FUSE, folder(IMU), IMU, "is a folder"),
    ("imu-link-loop", INFO, link(IMU, IMU), IMU, "loop of symbolic links"),
    ("imu-dangling-link", INFO, link(IMU, "/nonexistent/imu.txt"), IMU, "link to nothing"),
    ("imu-empty", FUSE, write(IMU, ""), IMU, "empty"),
    ("imu-garbage", FUSE, write(IMU, GARBAGE), IMU, "binary"),
    ("imu-header-garbled", INFO, lines(IMU, lambda ls: ls[:8] + ["PacketCounter\tSampleTimeFine"]
                                       + ls[9:]), IMU, "fields"),
    ("imu-text-cell", FUSE, cell(IMU, 10, "Acc_Y", "abc", "\t"), IMU, "line"),
    ("imu-run", RUN, cell(IMU, 100, "Acc_X", "1e30", "\t"), IMU, "16 g"),
    # --- detections.csv (the work folder), as fuse meets it
    ("det-empty-t", FUSE, cell(DET, 10, "t", ""), DET, "t is empty"),
    ("det-u-1e9", FUSE, cell(DET, 10, "u", "1e9"), DET, "far outside"),
    ("det-v-negative", FUSE, cell(DET, 20, "v", "-5000"), DET, "far outside"),
    ("det-text-cell", FUSE, cell(DET, 10, "u", "abc"), DET, "is not a number"),
    ("det-inf", FUSE, cell(DET, 10, "v", "inf"), DET, "not finite"),
    ("det-ok-nan-u", FUSE, cell(DET, 12, "u", ""), DET, "u or v is empty"),
    ("det-ok-2", FUSE, cell(DET, 12, "ok", "2"), DET, "ok = 2"),
    ("det-time-backwards", FUSE, cell(DET, 40, "t", "0.5"), DET, "does not increase"),
    ("det-missing-column", FUSE, edit(DET, lambda t: t.replace(",ok,", ",okay,", 1)), DET,
     "lacks column"),
    ("det-truncated-rows", FUSE, lines(DET, lambda ls: ls[:300]), DET, "video has 600 frames"),
    ("det-extra-rows", FUSE, lines(DET, lambda ls: ls + [ls[-1].replace("599,", "600,", 1)]), DET,
     "video has 600 frames"),
    ("det-frames-shuffled", FUSE, lines(DET, lambda ls: ls[:1] + ls[2:3] + ls[1:2] + ls[3:]), DET,
     "frames"),
    ("det-garbage", FUSE, write(DET, GARBAGE), DET, "CSV"),
    ("det-empty", FUSE, write(DET, ""), DET, "CSV"),
    ("det-fifo", FUSE, fifo(DET), DET, "named pipe"),
    ("det-folder", FUSE, folder(DET), DET, "is a folder"),
    ("det-missing", FUSE, lambda s: (s / DET).unlink(), DET, "not found"),
    # --- camera.yaml (the work folder), as fuse meets it
    ("cam-nan-distortion", FUSE, replace(CAM, "data: [ -0.12,", "data: [ .nan,"), CAM,
     "distortion_coefficients"),
    ("cam-fx-inf", FUSE, replace(CAM, "data: [ 560., 0.,", "data: [ .inf, 0.,"), CAM,
     "camera_matrix"),
    ("cam-R-scaled", FUSE, replace(CAM, "data: [ 0.99999974229311461,", "data: [ 1.9999997,"),
     CAM, "not a rotation"),
    ("cam-T-huge", FUSE, replace(CAM, "data: [ -0.22010649275941904,", "data: [ -1e9,"), CAM,
     "T_WC"),
    ("cam-T-nan", FUSE, replace(CAM, "data: [ -0.22010649275941904,", "data: [ .nan,"), CAM,
     "not finite"),
    ("cam-size-mismatch", FUSE, replace(CAM, "image_width: 640", "image_width: 1280"), CAM,
     "1280x480"),
    ("cam-garbage", FUSE, write(CAM, GARBAGE), CAM, "FileStorage"),
    ("cam-binary", FUSE, write(CAM, b"\x00" * 100), CAM, "binary"),
    ("cam-not-yaml", FUSE, write(CAM, "hello: [1, 2\n"), CAM, "FileStorage"),
    ("cam-no-pose", FUSE, edit(CAM, lambda t: t[: t.index("R_WC")] + "reprojection_error_px: 0.1\n"),
     CAM, "R_WC"),
    ("cam-missing", FUSE, lambda s: (s / CAM).unlink(), CAM, "calibrate"),
    ("cam-fifo", FUSE, fifo(CAM), CAM, "named pipe"),
    # --- intrinsics.yaml, as calibrate meets it
    ("intr-nan-distortion", CALIB, replace("intrinsics.yaml", "data: [ -0.12,", "data: [ .nan,"),
     "intrinsics.yaml", "distortion_coefficients"),
    ("intr-fx-inf", CALIB, replace("intrinsics.yaml", "data: [ 560., 0.,", "data: [ .inf, 0.,"),
     "intrinsics.yaml", "camera_matrix"),
    ("intr-fx-negative", CALIB, replace("intrinsics.yaml", "data: [ 560., 0.,", "data: [ -560., 0.,"),
     "intrinsics.yaml", "pinhole"),
    ("intr-size", CALIB, replace("intrinsics.yaml", "image_width: 640", "image_width: 1920"),
     "intrinsics.yaml", "1920x480"),
    ("intr-dev-null", CALIB, link("intrinsics.yaml", "/dev/null"), "intrinsics.yaml", "a device"),
    # --- session.toml
    ("toml-board-huge", CALIB, replace(TOML, "squares = [7, 5]", "squares = [100000, 100000]"),
     TOML, "squares"),
    ("toml-shoulder-far", FUSE, replace(TOML, "shoulder_m = [0.12, 0.58, 0.3]",
                                        "shoulder_m = [5.0, 5.0, 3.0]"), TOML, "reach"),
    ("toml-fifo", INFO, fifo(TOML), TOML, "named pipe"),
    ("toml-folder", INFO, folder(TOML), TOML, "is a folder"),
    ("toml-dev-null", INFO, link(TOML, "/dev/null"), TOML, "a device"),
    ("toml-nan-length", FUSE, replace(TOML, "upper_arm_m = 0.31", "upper_arm_m = nan"), TOML,
     "upper_arm_m"),
    ("toml-nan-offset", FUSE, replace(TOML, "imu_offset_s = -1", "imu_offset_s = nan"), TOML,
     "imu_offset_s"),
    ("toml-inf-offset", COMPARE, replace(TOML, "groundtruth_offset_s = -1.5",
                                         "groundtruth_offset_s = inf"), TOML, "groundtruth_offset"),
    ("toml-nan-to-world", COMPARE, replace(TOML, "[[0,-1,0,0.62]", "[[0,-1,0,nan]"), TOML,
     "to_world"),
    ("toml-auto-offset", FUSE, replace(TOML, "imu_offset_s = -1", 'imu_offset_s = "auto"'), TOML,
     '"auto"'),
    ("toml-binary", FUSE, write(TOML, GARBAGE), TOML, "not a text file"),
    # --- the video, as detect and calibrate meet it
    ("video-truncated", DETECT, truncate("video.mp4", 0.4), "video.mp4", "file is complete"),
    ("video-damaged-middle", DETECT, zero_middle("video.mp4"), "video.mp4", "damaged"),
    ("video-damaged-run", RUN, zero_middle("video.mp4"), "video.mp4", "damaged"),
    ("video-garbage", DETECT, write("video.mp4", GARBAGE), "video.mp4", "video"),
    ("video-fifo", DETECT, fifo("video.mp4"), "video.mp4", "named pipe"),
    ("video-empty", CALIB, write("video.mp4", b""), "video.mp4", "empty"),
    ("video-folder", CALIB, folder("video.mp4"), "video.mp4", "is a folder"),
    ("calib-frame-past-end", ["calibrate", "{S}", "--frame", "100000"], nothing, "video.mp4",
     "does not exist"),
    # --- Qualisys and the trajectories, as compare meets them
    ("qtm-time-ms", COMPARE, qtm_time_ms, QTM, "in ms"),
    ("qtm-marker-never-seen", COMPARE, qtm_marker_gone, QTM, "never seen"),
    ("qtm-fifo", COMPARE, fifo(QTM), QTM, "named pipe"),
    ("qtm-binary", COMPARE, write(QTM, GARBAGE), QTM, "binary"),
    ("qtm-frequency-nan", COMPARE, replace(QTM, "FREQUENCY\t100", "FREQUENCY\tnan"), QTM,
     "FREQUENCY"),
    ("qtm-frequency-zero", COMPARE, replace(QTM, "FREQUENCY\t100", "FREQUENCY\t0"), QTM,
     "FREQUENCY"),
    ("qtm-time-backwards", COMPARE, cell(QTM, 30, "Time", "0.01000", "\t"), QTM, "time goes"),
    ("traj-time-backwards", COMPARE, cell(TRAJ, 40, "t", "0.1"), TRAJ, "does not increase"),
    ("traj-text-cell", COMPARE, cell(TRAJ, 40, "wrist_x", "abc"), TRAJ, "is not a number"),
    ("traj-inf", COMPARE, cell(TRAJ, 40, "wrist_y", "inf"), TRAJ, "not finite"),
    ("traj-far", COMPARE, cell(TRAJ, 40, "wrist_z", "1e9"), TRAJ, "beyond"),
    ("traj-empty-t", COMPARE, cell(TRAJ, 40, "t", ""), TRAJ, "t is empty"),
    ("traj-missing-column", COMPARE, edit(TRAJ, lambda t: t.replace("wrist_x", "wrist_q", 1)),
     TRAJ, "lacks column"),
    ("traj-header-only", COMPARE, lines(TRAJ, lambda ls: ls[:1]), TRAJ, "no rows"),
    ("traj-garbage", COMPARE, write(TRAJ, GARBAGE), TRAJ, "CSV"),
    ("kin-text-cell", COMPARE, cell(KIN, 2, "value", "lots"), KIN, "is not a number"),
    ("kin-missing", COMPARE, lambda s: (s / KIN).unlink(), KIN, "not found"),
    # --- options and recipes
    ("set-pixel-sigma-zero", FUSE + ["--set", "fuse.pixel_sigma=0"], nothing, "--set", "outside"),
    ("set-particles-fraction", FUSE + ["--set", "fuse.particles=20.5"], nothing, "--set",
     "whole number"),
    ("set-particles-huge", FUSE + ["--set", "fuse.particles=1000000000"], nothing, "--set",
     "outside"),
    ("set-accel-noise-nan", FUSE + ["--set", "fuse.accel_noise=nan"], nothing, "--set", "finite"),
    ("set-accel-noise-inf", FUSE + ["--set", "fuse.accel_noise=inf"], nothing, "--set", "finite"),
    ("set-seed-negative", FUSE + ["--set", "fuse.seed=-1"], nothing, "--set", "outside"),
    ("set-min-area-negative", DETECT + ["--set", "detect.patch.min_area_px=-1"], nothing, "--set",
     "outside"),
    ("set-max-error-inf", CALIB + ["--set", "calibrate.max_error_px=inf"], nothing, "--set",
     "finite"),
    ("set-method-typo", FUSE[:2] + ["--set", "fuse.method=ekff"], nothing, "--set",
     "did you mean 'ekf'?"),
    ("set-no-equals", FUSE + ["--set", "fuse.particles"], nothing, "--set", "KEY=VALUE"),
    ("set-unknown-key", FUSE + ["--set", "fuse.particle=30"], nothing, "--set", "did you mean"),
    ("set-unknown-section", FUSE + ["--set", "fusion.pf.x=3"], nothing, "--set", "section"),
    ("set-not-a-table", FUSE + ["--set", "fuse.pff.x=3"], nothing, "--set", "is not a setting"),
    ("set-string-for-number", FUSE + ["--set", "fuse.particles=many"], nothing, "--set",
     "finite number"),
    ("recipe-binary", FUSE + ["--recipe", "{S}/bad.toml"], write("bad.toml", GARBAGE), "bad.toml",
     "not a text file"),
    ("recipe-dev-zero", FUSE + ["--recipe", "/dev/zero"], nothing, "/dev/zero", "a device"),
    ("recipe-fifo", FUSE + ["--recipe", "{S}/pipe.toml"], lambda s: os.mkfifo(s / "pipe.toml"),
     "pipe.toml", "named pipe"),
    ("recipe-bad-toml", FUSE + ["--recipe", "{S}/bad.toml"], write("bad.toml", "[fuse\n"),
     "bad.toml", "TOML"),
    ("recipe-unknown-name", FUSE + ["--recipe", "tao2008-pf-constrain"], nothing,
     "tao2008-pf-constrain", "did you mean"),
    ("recipe-nan", FUSE + ["--recipe", "{S}/bad.toml"], write("bad.toml", "[fuse]\nwalk_pos_m = nan\n"),
     "bad.toml", "finite"),
    ("run-bad-recipe", RUN + ["--recipe", "{S}/bad.toml"], write("bad.toml", "[fuse]\nparticles = 0\n"),
     "bad.toml", "outside"),
]

# the same damaged inputs through every fusion method
for _m in ("inertial", "ukf", "pf", "pf-constraint"):
    ARM_CASES += [
        (f"det-u-1e9-{_m}", ["fuse", "{S}", "--method", _m], cell(DET, 10, "u", "1e9"), DET,
         "far outside"),
        (f"imu-acc-1e30-{_m}", ["fuse", "{S}", "--method", _m],
         cell(IMU, 100, "Acc_X", "1e30", "\t"), IMU, "16 g"),
        (f"cam-nan-{_m}", ["fuse", "{S}", "--method", _m],
         replace(CAM, "data: [ -0.12,", "data: [ .nan,"), CAM, "distortion_coefficients"),
    ]
ARM_CASES += [
    ("simulate-exists", ["simulate", "{S}"], nothing, "s", "already exists"),
    ("compare-no-groundtruth", COMPARE, edit(TOML, lambda t: t[: t.index("[groundtruth]")]
                                             + t[t.index("[sync]"):]), TOML, "groundtruth"),
    ("compare-unknown-method-file", ["compare", "{S}", "--method", "pf"], nothing,
     "trajectory-pf.csv", "not found"),
    ("info-missing-video", INFO, lambda s: (s / "video.mp4").unlink(), "video.mp4", "not found"),
    ("run-imu-fifo", RUN, fifo(IMU), IMU, "named pipe"),
    ("run-qtm-ms", RUN, qtm_time_ms, QTM, "in ms"),
]

# wrong usage: exit code 2 and click's own message naming the option
USAGE_CASES = [
    (["simulate", "{S}/new", "--duration", "nan"], "--duration"),
    (["simulate", "{S}/new", "--fps", "inf"], "--fps"),
    (["simulate", "{S}/new", "--acc-noise", "nan"], "--acc-noise"),
    (["simulate", "{S}/new", "--occlusion", "nan:1"], "--occlusion"),
    (["simulate", "{S}/new", "--seed", "-1"], "--seed"),
    (["fuse", "{S}", "--seed", "-1"], "--seed"),
    (["fuse", "{S}", "--particles", "1000000000"], "--particles"),
    (["fuse", "{S}", "--method", "kalman"], "--method"),
    (["calibrate", "{S}", "--markers", "nan,1;2,3"], "--markers"),
    (["calibrate", "{S}", "--frame", "-3"], "--frame"),
    (["info", "{S}", "--imu-rate", "nan"], "--imu-rate"),
    (["run", "{S}", "--through", "everything"], "--through"),
]
