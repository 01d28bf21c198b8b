"""palm.toml: the user-specific palm model that calibrate measures on the first frame."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from armtrack_cli.session.outputs import write_text


def _vec(v) -> str:
    return "[" + ", ".join(f"{x:.6f}" for x in v) + "]"


def write_palm_toml(path: Path, *, side: str, names, link_m, angle_deg, position_H,
                    pixels: np.ndarray, link_residual_m, frame: int, depth: bool) -> Path:
    """Each marker's position in H (m), the measured links, and how the fit went."""
    return write_text(path, "\n".join([
        f"# palm model measured by armtrack calibrate on frame {frame} "
        f"({'with' if depth else 'without'} depth)",
        "[palm]", f'side = "{side}"',
        "markers = [" + ", ".join(f'"{m}"' for m in names) + "]",
        "link_m = " + _vec(link_m) + "   # as measured (session.toml)",
        "angle_deg = " + _vec(angle_deg) + "   # in-plane angle from x_H, from the frame",
        "position_m = [" + ", ".join(_vec(p) for p in position_H) + "]   # each marker in H",
        "", "[fit]", f"frame = {frame}",
        "pixels = [" + ", ".join(_vec(p) for p in pixels) + "]",
        "link_residual_m = " + _vec(link_residual_m), ""]))
