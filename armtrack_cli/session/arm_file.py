"""arm-auto.json in the work folder: the arm model fuse estimated for `[arm] … = "auto"`,
with its SDs (fuse writes it; kinematics, report and info read it)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from armtrack_cli.core.errors import DataError
from armtrack_cli.session.outputs import write_json

ARM_FILE = "arm-auto.json"


def write_arm_estimate(folder: str | Path, estimate: dict[str, Any]) -> Path:
    return write_json(Path(folder) / ARM_FILE, estimate)


def read_arm_estimate(folder: str | Path) -> dict[str, Any] | None:
    """The estimate fuse wrote, or None when there is none."""
    path = Path(folder) / ARM_FILE
    if not path.is_file():
        return None
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
        doc["shoulder_m"] = [float(v) for v in doc["shoulder_m"]]
        doc["upper_arm_m"], doc["forearm_m"] = float(doc["upper_arm_m"]), float(doc["forearm_m"])
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise DataError(path, f"is not the arm estimate fuse writes ({e})",
                        "rerun `armtrack fuse`") from None
    return doc
