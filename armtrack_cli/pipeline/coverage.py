"""How much of a session was tracked and measured, from its work folder: the report's data
quality and cohort.csv's columns read the same figures from here."""

from __future__ import annotations

from armtrack_cli.core.errors import ArmtrackError
from armtrack_cli.report.quality import spans
from armtrack_cli.session.config import Session
from armtrack_cli.session.tables import read_csv_table
from armtrack_cli.session.video import probe_video
from armtrack_cli.session.workfolder import WorkFolder


def tracked(work: WorkFolder, kind: str, video_frames: int = 0) -> tuple[float, int]:
    """(% of frames with a wrist detection, or with at least three palm blobs; frames). A palm
    session's detections.csv has no row for a frame without blobs: its frames are the video's
    (``video_frames``), not up to the last frame with a blob."""
    p = work / "detections.csv"
    if not work.has("detections.csv"):
        return float("nan"), 0
    if kind == "palm":
        d = read_csv_table(p, ("frame", "blob"), "run `armtrack detect SESSION` first")
        n = max(int(d["frame"].max()) + 1 if len(d) else 0, video_frames)
        per = d.groupby("frame").size()
        return (100.0 * float((per >= 3).sum()) / n if n else float("nan")), n
    d = read_csv_table(p, ("frame", "ok"), "run `armtrack detect SESSION` first")
    return (100.0 * float(d["ok"].mean()) if len(d) else float("nan")), len(d)


def video_frames(session: Session) -> int:
    """Frames in the session's video; 0 where it cannot be read (the count then comes from
    the detections alone)."""
    try:
        return probe_video(session.camera.video).n_frames if session.camera else 0
    except ArmtrackError:
        return 0


def durations(work: WorkFolder, method: str) -> tuple[float, float]:
    """(measured, recorded) s of trajectory-METHOD.csv: the span its measures are taken over
    (kinematics' session row: the first to the last frame with a wrist) and the trajectory's
    whole span, each with one frame interval; NaN where an output is missing."""
    nan = (float("nan"), float("nan"))
    if not (work.has(f"trajectory-{method}.csv") and work.has(f"kinematics-{method}.csv")):
        return nan
    t = read_csv_table(work / f"trajectory-{method}.csv", ("t",), "")["t"].to_numpy(float)
    k = read_csv_table(work / f"kinematics-{method}.csv", ("segment", "t_start", "t_end"), "")
    row = k[k["segment"] == "session"]
    if not len(row):
        return nan
    got = spans(float(row["t_start"].iloc[0]), float(row["t_end"].iloc[0]), t)
    return nan if got is None else (round(got[1] - got[0], 6), round(got[2], 6))
