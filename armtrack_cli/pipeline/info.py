"""Stage 0: what a session folder, or a single recorded file, holds."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from armtrack_cli.core.errors import DataError
from armtrack_cli.session import info as session_info
from armtrack_cli.session.config import load_session
from armtrack_cli.session.imu import read_imu
from armtrack_cli.session.outputs import write_json
from armtrack_cli.session.qualisys import read_qualisys
from armtrack_cli.session.video import probe_video

VIDEO_EXT = (".mp4", ".avi", ".mkv", ".mov", ".m4v")


def info(path: str | Path, *, imu_rate_hz: float | None = None,
         out_dir: str | Path | None = None) -> dict[str, Any]:
    """Stage 0: what a session folder (or a single recorded file) holds."""
    path = Path(path)
    if path.is_dir():
        result = session_info.describe(load_session(path), imu_rate_hz=imu_rate_hz)
    elif path.is_file():
        result = _info_file(path, imu_rate_hz)
    else:
        raise DataError(path, "not found", "give a session folder or a recorded file")
    if out_dir is not None:
        write_json(Path(out_dir) / "info.json", result)
    return result


def _info_file(path: Path, imu_rate_hz: float | None) -> dict[str, Any]:
    """A lone file: a Qualisys TSV, a video, or an IMU export (told apart by content)."""
    out: dict[str, Any] = {"session": {"folder": str(path.parent), "id": path.name, "subject": None,
                                       "task": None, "side": "right", "kind": "file",
                                       "recorded": None}, "methods": {}}
    suffix = path.suffix.lower()
    if suffix == ".tsv":
        out["groundtruth"] = session_info.describe_markers(read_qualisys(path), 0.0)
    elif suffix in VIDEO_EXT:
        out["video"] = session_info.describe_video(probe_video(path))
    else:
        s = read_imu(path, rate_hz=imu_rate_hz)
        out["imu"] = session_info.describe_imu(s, 0.0)
        out["imu"]["forearm_axis"] = "+y"
    return out


format_info = session_info.format_text




def frame_count(path: str | Path) -> int:
    """Frames in a session's video (for progress bars)."""
    session = load_session(path)
    return probe_video(session.camera.video).n_frames if session.camera and \
        session.camera.video else 0
