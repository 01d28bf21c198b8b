"""Regenerate the bad-input corpus: one small session folder per malformed input.

    python tests/data/bad/make_corpus.py

Each case is a session folder that `armtrack info` must refuse with exit code 1 and one line
`error: FILE: …` naming ``file`` and containing ``expect`` (cases.toml). The good parts are
written by armtrack's own exporters; the bad part is written by hand below.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import cv2
import numpy as np

from armtrack_cli.core import quaternion as Q
from armtrack_cli.session.export.mcap import write_imu_mcap
from armtrack_cli.session.export.qualisys import format_qtm_tsv
from armtrack_cli.session.export.xsens import format_mt_manager

HERE = Path(__file__).resolve().parent
RNG = np.random.default_rng(2026)
GARBAGE = bytes(RNG.integers(0, 256, 4096, dtype=np.uint8))

# ---------------------------------------------------------------- good building blocks
N = 200
T = np.arange(N) / 100.0
QT = Q.normalize(np.cumsum(RNG.normal(0, 0.01, (N, 4)), 0) + [1, 0, 0, 0])
ACC = Q.rotate(Q.conjugate(QT), [0, 0, 9.81]) + RNG.normal(0, 0.02, (N, 3))
GYR = RNG.normal(0, 0.05, (N, 3))
XSENS = format_mt_manager(T, ACC, GYR, QT, style="legacy")
XSENS_LINES = XSENS.splitlines()
HEAD = 5  # legacy header: 4 comment lines + the column header
CSV = "t,ax,ay,az,gx,gy,gz\n" + "\n".join(
    f"{T[i]:.2f}," + ",".join(f"{v:.5f}" for v in (*ACC[i], *GYR[i])) for i in range(N)) + "\n"
MARKERS = np.stack([np.tile([100.0, 450.0, 320.0], (N, 1)), np.tile([150.0, 300.0, 150.0], (N, 1)),
                    np.c_[300 + 50 * np.cos(T), 250 + 50 * np.sin(T), np.full(N, 80.0)]], 1) / 1e3
QTM = format_qtm_tsv(MARKERS, ["R_SHO", "R_ELB", "R_WRI"], 100.0)
QTM_LINES = QTM.splitlines()

IMU_TOML = '[imu]\nfile = "imu.txt"\n'
CSV_TOML = '[imu]\nfile = "imu.csv"\n'
MCAP_TOML = '[imu]\nfile = "imu.mcap"\n'
GT_TOML = '[groundtruth]\nfile = "qualisys.tsv"\nmarkers = { wrist = "R_WRI" }\n'
VIDEO_TOML = '[camera]\nvideo = "video.mp4"\n'
ARM = '[arm]\nupper_arm_m = 0.31\nforearm_m = 0.27\nshoulder_m = [0.10, 0.45, 0.32]\n'


def replace_line(lines: list[str], i: int, new: str) -> str:
    out = list(lines)
    out[i] = new
    return "\n".join(out) + "\n"


def csv_rows(rows: list[str]) -> str:
    return "t,ax,ay,az,gx,gy,gz\n" + "\n".join(rows) + "\n"


def tiny_video() -> bytes:
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "v.mp4"
        w = cv2.VideoWriter(str(p), cv2.VideoWriter_fourcc(*"mp4v"), 30.0, (64, 48))
        for i in range(10):
            w.write(np.full((48, 64, 3), 20 * i, np.uint8))
        w.release()
        return p.read_bytes()


def mcap_bytes(**kw) -> bytes:
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "x.mcap"
        write_imu_mcap(p, T, ACC, GYR, QT, **kw)
        return p.read_bytes()


def mcap_other_topic() -> bytes:
    from mcap.writer import Writer

    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "x.mcap"
        with open(p, "wb") as f:
            w = Writer(f)
            w.start()
            sid = w.register_schema("std_msgs/msg/String", "jsonschema", b"{}")
            cid = w.register_channel("/chatter", "json", sid)
            w.add_message(cid, log_time=1, publish_time=1, data=b'{"data": "hi"}')
            w.finish()
        return p.read_bytes()


def mcap_two_topics() -> bytes:
    from mcap_ros2.writer import Writer

    from armtrack_cli.session.export.mcap import IMU_MSGDEF, _imu_msg

    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "x.mcap"
        with open(p, "wb") as f:
            w = Writer(f)
            s = w.register_msgdef("sensor_msgs/msg/Imu", IMU_MSGDEF)
            for topic in ("/left/imu", "/right/imu"):
                for i in range(5):
                    w.write_message(topic, s, _imu_msg(1 + i / 100, ACC[i], GYR[i], QT[i]),
                                    log_time=10**9 + i * 10**7)
            w.finish()
        return p.read_bytes()


VIDEO = tiny_video()
GOOD_MCAP = mcap_bytes()
TS = "frame,t\n" + "\n".join(f"{i},{i / 30:.4f}" for i in range(10)) + "\n"
INTRINSICS = ("%YAML:1.0\n---\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
              "   data: [ 600., 0., 320., 0., 600., 240., 0., 0., 1. ]\nimage_width: 640\n"
              "image_height: 480\n")

# name: (session.toml, {file: content}, file the error names, text the error contains)
CASES: dict[str, tuple[str, dict, str, str]] = {
    # ---- session.toml
    "toml-empty": ("", {}, "session.toml", "is empty"),
    "toml-syntax": ("[arm\nupper_arm_m = 0.31\n", {}, "session.toml", "not valid TOML"),
    "toml-binary": (None, {"session.toml": GARBAGE}, "session.toml", "not a text file"),
    "toml-unknown-key": (ARM.replace("upper_arm_m", "upper_arm"), {}, "session.toml",
                         "[arm] upper_arm is not a key armtrack knows"),
    "toml-unknown-section": ('[camra]\nvideo = "video.mp4"\n', {}, "session.toml",
                             "did you mean [camera]"),
    "toml-negative-length": (ARM.replace("0.27", "-0.27"), {}, "session.toml",
                             "[arm] forearm_m = -0.27 is impossible"),
    "toml-missing-key": (ARM.replace("forearm_m = 0.27\n", ""), {}, "session.toml",
                         "[arm] forearm_m is missing"),
    "toml-wrong-type": (ARM.replace("0.31", '"31cm"'), {}, "session.toml",
                        "upper_arm_m = '31cm' is a string, expected a number"),
    "toml-lengths-in-mm": (ARM.replace("0.31", "310"), {}, "session.toml", "lengths are in metres"),
    "toml-bad-side": ('[session]\nside = "both"\n' + IMU_TOML, {"imu.txt": XSENS}, "session.toml",
                      "[session] side = 'both'"),
    "toml-bad-axis": (IMU_TOML + 'forearm_axis = "y"\n', {"imu.txt": XSENS}, "session.toml",
                      "forearm_axis = 'y' has no sign"),
    "toml-hsv-range": ('[camera]\npatch = { hsv_low = [0, 140, 90], hsv_high = [200, 255, 255] }\n',
                       {}, "session.toml", "out of OpenCV's HSV range"),
    "toml-to-world": (GT_TOML + "to_world = [[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\n",
                      {"qualisys.tsv": QTM}, "session.toml", "is not a rigid transform"),
    "toml-palm-links": ('[palm]\nmarkers = ["WRIST", "MCP2", "MCP3", "MCP4", "MCP5", "CMC1"]\n'
                        'link_m = [0.0, 0.085, 0.080, 0.075, 0.070]\n'
                        'colour = { hsv_low = [100, 150, 60], hsv_high = [130, 255, 255] }\n',
                        {}, "session.toml", "link_m"),
    "toml-bad-dictionary": ('[camera]\nboard = { type = "charuco", squares = [7, 5], square_m = 0.04, '
                            'marker_m = 0.03, dictionary = "DICT_9X9_50" }\n', {}, "session.toml",
                            "dictionary = 'DICT_9X9_50'"),
    "toml-marker-too-big": ('[camera]\nboard = { type = "charuco", squares = [7, 5], square_m = 0.03,'
                            ' marker_m = 0.04, dictionary = "DICT_4X4_50" }\n', {}, "session.toml",
                            "marker_m = 0.04 is not smaller than square_m"),
    "toml-bad-offset": (IMU_TOML + '[sync]\nimu_offset_s = "soon"\n', {"imu.txt": XSENS},
                        "session.toml", "neither a number of seconds nor \"auto\""),
    "toml-shoulder-unreachable": (ARM.replace("[0.10, 0.45, 0.32]", "[3.0, 3.0, 1.0]") + GT_TOML,
                                  {"qualisys.tsv": QTM}, "session.toml",
                                  "farther than L1 + L2"),
    "toml-gt-unknown-role": (GT_TOML.replace("wrist =", "hand ="), {"qualisys.tsv": QTM},
                             "session.toml", "markers.hand is not a joint"),
    "toml-missing-file": ('[imu]\nfile = "nope.txt"\n', {}, "nope.txt", "not found"),
    "no-session-toml": (None, {"imu.txt": XSENS}, "session.toml", "not found"),
    # ---- IMU exports
    "imu-empty": (IMU_TOML, {"imu.txt": ""}, "imu.txt", "is empty"),
    "imu-binary": (IMU_TOML, {"imu.txt": b"\x00\x01" + GARBAGE}, "imu.txt", "binary file"),
    "imu-header-only": (IMU_TOML, {"imu.txt": "\n".join(XSENS_LINES[:4]) + "\n"}, "imu.txt",
                        "only comment lines"),
    # (an export without Acc_X..Z is described by info since issue 16: tests/test_lab_exports.py)
    "imu-non-numeric": (IMU_TOML, {"imu.txt": replace_line(
        XSENS_LINES, HEAD + 10, XSENS_LINES[HEAD + 10].replace("\t", "\tabc\t", 1).replace(
            "\t", "", 1))}, "imu.txt", "is not a number"),
    "imu-no-rate": (IMU_TOML, {"imu.txt": format_mt_manager(T, ACC, GYR, QT,
                                                            sample_time_fine=False)},
                    "imu.txt", "set [imu] rate_hz"),
    "imu-quat-norm": (IMU_TOML, {"imu.txt": format_mt_manager(T, ACC, GYR, QT * 2,
                                                              style="legacy")},
                      "imu.txt", "has norm 2.000"),
    "imu-counter-repeats": (IMU_TOML, {"imu.txt": replace_line(
        XSENS_LINES, HEAD + 20, XSENS_LINES[HEAD + 19])}, "imu.txt", "repeats the previous packet"),
    "imu-counter-backwards": (IMU_TOML, {"imu.txt": "\n".join(
        XSENS_LINES[:HEAD + 50] + XSENS_LINES[HEAD + 10:HEAD + 30]) + "\n"}, "imu.txt",
        "jumps back"),
    "imu-ragged-row": (IMU_TOML, {"imu.txt": replace_line(
        XSENS_LINES, HEAD + 40, XSENS_LINES[HEAD + 40] + "\t1.0\t2.0")}, "imu.txt",
        "fields but the header has"),
    "imu-stf-partial": (IMU_TOML, {"imu.txt": replace_line(
        XSENS_LINES, HEAD + 30, "\t".join(
            c if k != 1 else "" for k, c in enumerate(XSENS_LINES[HEAD + 30].split("\t"))))},
        "imu.txt", "SampleTimeFine is missing in some rows"),
    "imu-too-short": (IMU_TOML, {"imu.txt": "\n".join(XSENS_LINES[:HEAD + 1]) + "\n"},
                      "imu.txt", "too short"),
    "imu-unknown-format": (IMU_TOML, {"imu.txt": "hello,world\n1,2\n"}, "imu.txt",
                           "not an IMU format armtrack reads"),
    "dot-no-header": (IMU_TOML, {"imu.txt": "sep=,\nMovella DOT\n1,2,3\n"}, "imu.txt",
                      "without a PacketCounter/SampleTimeFine header"),
    "csv-missing-columns": (CSV_TOML, {"imu.csv": "t,ax,ay\n0,0,0\n0.01,0,0\n"}, "imu.csv",
                            "lacks column(s) az, gx, gy, gz"),
    "csv-time-backwards": (CSV_TOML, {"imu.csv": csv_rows(
        [f"{t:.2f},0,0,9.81,0,0,0" for t in (0, 0.01, 0.02, 0.015, 0.03)])}, "imu.csv",
        "time goes back"),
    "csv-time-repeated": (CSV_TOML, {"imu.csv": csv_rows(
        [f"{t:.2f},0,0,9.81,0,0,0" for t in (0, 0.01, 0.01, 0.02)])}, "imu.csv",
        "repeats the previous row"),
    "csv-nan-times": (CSV_TOML, {"imu.csv": csv_rows(
        [f"{'NaN' if 5 <= i < 9 else f'{i / 100:.2f}'},0,0,9.81,0,0,0" for i in range(20)])},
        "imu.csv", "empty or NaN in 4 rows"),
    "csv-gyro-degrees": (CSV_TOML, {"imu.csv": csv_rows(
        [f"{i / 100:.2f},0,0,9.81,{120 * np.sin(i / 5):.3f},0,0" for i in range(100)])},
        "imu.csv", "look like degrees per second"),
    "csv-acc-in-g": (CSV_TOML, {"imu.csv": csv_rows(
        [f"{i / 100:.2f},0.01,0.02,1.0,0,0,0" for i in range(100)])}, "imu.csv", "look like g"),
    "csv-semicolons": (CSV_TOML, {"imu.csv": CSV.replace(",", ";")}, "imu.csv",
                       "separated by semicolons, not commas"),
    "csv-quat-norm": (CSV_TOML, {"imu.csv": "t,ax,ay,az,gx,gy,gz,qw,qx,qy,qz\n" + "\n".join(
        f"{i / 100:.2f},0,0,9.81,0,0,0,0.5,0,0,0" for i in range(20)) + "\n"}, "imu.csv",
        "has norm 0.500"),
    "mcap-no-imu": (MCAP_TOML, {"imu.mcap": mcap_other_topic()}, "imu.mcap",
                    "has no IMU messages (sensor_msgs/msg/Imu, alone or as a field of another "
                    "message); it holds: "
                    "/chatter (std_msgs/msg/String)"),
    "mcap-garbage": (MCAP_TOML, {"imu.mcap": b"\x89MCAP0\r\n" + GARBAGE}, "imu.mcap",
                     "damaged or truncated MCAP"),
    "mcap-truncated": (MCAP_TOML, {"imu.mcap": GOOD_MCAP[: len(GOOD_MCAP) // 2]}, "imu.mcap",
                       "damaged or truncated MCAP"),
    "mcap-two-topics": (MCAP_TOML, {"imu.mcap": mcap_two_topics()}, "imu.mcap",
                        "several IMU topics: /left/imu, /right/imu"),
    # ---- Qualisys exports
    "qtm-empty": (GT_TOML, {"qualisys.tsv": ""}, "qualisys.tsv", "is empty"),
    "qtm-binary": (GT_TOML, {"qualisys.tsv": b"\x00" + GARBAGE}, "qualisys.tsv", "binary file"),
    "qtm-no-marker-names": (GT_TOML, {"qualisys.tsv": "\n".join(
        ln for ln in QTM_LINES if not ln.startswith("MARKER_NAMES")) + "\n"}, "qualisys.tsv",
        "has no MARKER_NAMES line"),
    "qtm-6dof": (GT_TOML, {"qualisys.tsv": "NO_OF_FRAMES\t2\nFREQUENCY\t100\nNO_OF_BODIES\t1\n"
                           "BODY_NAMES\thand\nDATA_INCLUDED\t6D\n"
                           "1\t0.0\t1\t2\t3\t0\t0\t0\n"}, "qualisys.tsv", "6DOF (rigid body)"),
    "qtm-column-mismatch": (GT_TOML, {"qualisys.tsv": "\n".join(
        [ln for ln in QTM_LINES if not ln.startswith("Frame")][:11]
        + ["\t".join(ln.split("\t")[2:-3]) for ln in QTM_LINES[12:]]) + "\n"}, "qualisys.tsv",
        "does not fit 3 markers"),
    "qtm-non-numeric": (GT_TOML, {"qualisys.tsv": replace_line(
        QTM_LINES, 20, QTM_LINES[20].replace(QTM_LINES[20].split("\t")[3], "n.a.", 1))},
        "qualisys.tsv", "is not a number"),
    "qtm-unknown-marker": (GT_TOML.replace("R_WRI", "RWRI"), {"qualisys.tsv": QTM},
                           "qualisys.tsv", "has no marker 'RWRI'"),
    "qtm-no-frequency": (GT_TOML, {"qualisys.tsv": QTM.replace("FREQUENCY\t100", "FREQUENCY\t")},
                         "qualisys.tsv", "FREQUENCY"),
    "qtm-time-backwards": (GT_TOML, {"qualisys.tsv": replace_line(
        QTM_LINES, 30, QTM_LINES[30].replace(QTM_LINES[30].split("\t")[1], "0.01000", 1))},
        "qualisys.tsv", "time goes from"),
    "qtm-header-only": (GT_TOML, {"qualisys.tsv": "\n".join(QTM_LINES[:11]) + "\n"},
                        "qualisys.tsv", "has a header but no data"),
    # ---- video, timestamps, intrinsics
    "video-not-a-video": (VIDEO_TOML, {"video.mp4": "this is not a video\n" * 50}, "video.mp4",
                          "not a video OpenCV's FFmpeg can open"),
    "video-empty": (VIDEO_TOML, {"video.mp4": ""}, "video.mp4", "is empty (0 bytes)"),
    "video-timestamps-backwards": (VIDEO_TOML, {"video.mp4": VIDEO, "video_timestamps.csv":
                                                TS.replace("3,0.1000", "3,0.0100")},
                                   "video_timestamps.csv", "t does not increase"),
    "video-timestamps-count": (VIDEO_TOML, {"video.mp4": VIDEO, "video_timestamps.csv":
                                            "\n".join(TS.splitlines()[:6]) + "\n"},
                               "video_timestamps.csv", "lists 5 frames but the video has 10"),
    "video-mcap-without-images": ('[camera]\nvideo = "imu.mcap"\n', {"imu.mcap": GOOD_MCAP},
                                  "imu.mcap", "has no camera image messages"),
    "intrinsics-garbage": ('[camera]\nintrinsics = "intrinsics.yaml"\n',
                           {"intrinsics.yaml": "camera: [1, 2\n  ]]] not yaml {{\n"},
                           "intrinsics.yaml", "not OpenCV FileStorage YAML"),
    "intrinsics-no-matrix": ('[camera]\nintrinsics = "intrinsics.yaml"\n',
                             {"intrinsics.yaml": INTRINSICS.split("camera_matrix")[0]
                              + "image_width: 640\nimage_height: 480\n"},
                             "intrinsics.yaml", "has no 3x3 camera_matrix"),
}


def main() -> None:
    for old in HERE.iterdir():
        if old.is_dir():
            shutil.rmtree(old)
    lines = ["# Bad inputs: `armtrack info CASE` must exit 1 with one line naming `file` and",
             "# containing `expect`. Regenerate with tests/data/bad/make_corpus.py.", ""]
    for name, (toml, files, file, expect) in CASES.items():
        d = HERE / name
        d.mkdir()
        if toml is not None:
            (d / "session.toml").write_text(toml)
        for fname, content in files.items():
            (d / fname).write_bytes(content if isinstance(content, bytes) else content.encode())
        lines += [f"[{name}]", f"file = {file!r}", f"expect = {expect!r}", ""]
    (HERE / "cases.toml").write_text("\n".join(lines))
    print(f"{len(CASES)} cases written to {HERE}")


if __name__ == "__main__":
    main()
