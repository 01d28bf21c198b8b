"""Write the contract's generic IMU CSV: t,ax,ay,az,gx,gy,gz[,qw,qx,qy,qz]."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from armtrack_cli.session.outputs import write_text


def write_imu_csv(path: str | Path, t: np.ndarray, acc: np.ndarray, gyr: np.ndarray,
                  q: np.ndarray | None) -> Path:
    cols = ["t", "ax", "ay", "az", "gx", "gy", "gz"] + (["qw", "qx", "qy", "qz"] if q is not None
                                                        else [])
    data = np.column_stack([t, acc, gyr] + ([q] if q is not None else []))
    rows = [",".join(cols)] + [",".join("" if np.isnan(v) else f"{v:.6f}" for v in row)
                               for row in data]
    return write_text(path, "\n".join(rows) + "\n")
