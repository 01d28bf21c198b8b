"""Stage 0: what a session folder, or a single recorded file, holds."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from armtrack_cli.core.errors import DescribedError
from armtrack_cli.pipeline.groundtruth import name_problems
from armtrack_cli.session import info as session_info
from armtrack_cli.session.config import load_session
from armtrack_cli.session.outputs import write_json
from armtrack_cli.session.video import probe_video


def info(path: str | Path, *, imu_rate_hz: float | None = None,
         out_dir: str | Path | None = None) -> dict[str, Any]:
    """What a session folder (or a single recorded file) holds; info.json with --out."""
    problems: list = []

    def check(session, trial, static) -> list:
        problems.extend(name_problems(session, trial, static))
        return problems

    result = session_info.describe_path(Path(path), imu_rate_hz=imu_rate_hz, check=check)
    if problems:  # compare would fail: each listed, the first as the error, nothing written
        raise DescribedError(problems, result)
    if out_dir is not None:
        write_json(Path(out_dir) / "info.json", result)
    return result


def frame_count(path: str | Path) -> int:
    """Frames in a session's video (for progress bars)."""
    session = load_session(path)
    return probe_video(session.camera.video).n_frames if session.camera and \
        session.camera.video else 0
