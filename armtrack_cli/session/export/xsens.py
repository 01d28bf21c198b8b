"""Write Xsens MT Manager text exports (the simulator's IMU files; reader round-trip tests).

Times become SampleTimeFine ticks (10 kHz, wrapping at 2^32) and PacketCounter (wrapping at
2^16); dropped samples are simply left out, as MT Manager does.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from armtrack_cli.core import quaternion as quat
from armtrack_cli.session.outputs import write_text


def format_mt_manager(t: np.ndarray, acc: np.ndarray, gyr: np.ndarray, q: np.ndarray | None, *,
                      mag: np.ndarray | None = None, rate_hz: float = 100.0,
                      delimiter: str = "\t", style: str = "2022", orientation: str = "quat",
                      coordinate_system: str = "ENU", sample_time_fine: bool = True,
                      stf_start: int = 0, counter_start: int = 0,
                      device_id: str = "00B4SIM0") -> str:
    """Text of an export. t: (N,) s with gaps where samples were dropped; q: (N, 4) B -> W.

    style "legacy" writes ``// Update Rate``; "2022" writes the General-information header
    (no rate line) with ``// Coordinate system``. coordinate_system "NED" writes the
    orientation as MT Manager would in NED (reference turned 180° about x).
    """
    if coordinate_system != "ENU" and style == "legacy":
        raise ValueError("legacy exports state no coordinate system; use style='2022'")
    steps = np.round(np.asarray(t) * rate_hz).astype(np.int64)
    counter = (counter_start + steps) % 2**16
    head: list[str]
    if style == "legacy":
        head = ["// Start Time: Unknown", f"// Update Rate: {rate_hz:.1f}Hz",
                "// Filter Profile: human (46.1)", "// Firmware Version: 4.0.2"]
    else:
        head = ["// General information: ", "//  MT Manager version: 2022.2.0 ",
                "// Device information: ", f"//  DeviceId: {device_id}",
                "//  ProductCode: MTW2-3A7G6", "// Device settings: ",
                "//  Filter Profile: human(46.1)", f"// Coordinate system: {coordinate_system}"]
    cols = ["PacketCounter"] + (["SampleTimeFine"] if sample_time_fine else [])
    data = [counter.astype(float)[:, None]]
    if sample_time_fine:
        stf = (stf_start + np.round(np.asarray(t) * 1e4).astype(np.int64)) % 2**32
        data.append(stf.astype(float)[:, None])
    cols += ["Acc_X", "Acc_Y", "Acc_Z", "Gyr_X", "Gyr_Y", "Gyr_Z"]
    data += [acc, gyr]
    if mag is not None:
        cols += ["Mag_X", "Mag_Y", "Mag_Z"]
        data.append(mag)
    if q is not None:
        if coordinate_system == "NED":
            q = quat.multiply(np.array([0.0, 1.0, 0.0, 0.0]), q)  # z-up -> NED (self-inverse)
        if orientation == "quat":
            cols += [f"Quat_q{i}" for i in range(4)]
            data.append(q)
        elif orientation == "matrix":
            R = quat.to_matrix(q)
            cols += [f"Mat[{i}][{j}]" for j in (1, 2, 3) for i in (1, 2, 3)]
            data.append(np.stack([R[:, i - 1, j - 1] for j in (1, 2, 3) for i in (1, 2, 3)], 1))
        elif orientation == "euler":
            R = quat.to_matrix(q)
            roll = np.arctan2(R[:, 2, 1], R[:, 2, 2])
            pitch = -np.arcsin(np.clip(R[:, 2, 0], -1, 1))
            yaw = np.arctan2(R[:, 1, 0], R[:, 0, 0])
            cols += ["Roll", "Pitch", "Yaw"]
            data.append(np.rad2deg(np.stack([roll, pitch, yaw], 1)))
        else:
            raise ValueError(f"orientation must be quat, matrix or euler, not {orientation!r}")
    table = np.hstack(data)
    n_int = 2 if sample_time_fine else 1
    rows = []
    for row in table:
        cells = [f"{int(v):05d}" if k == 0 else f"{int(v)}" for k, v in enumerate(row[:n_int])]
        cells += ["NaN" if np.isnan(v) else f"{v:.6f}" for v in row[n_int:]]
        rows.append(delimiter.join(cells))
    return "\n".join(head + [delimiter.join(cols)] + rows) + "\n"


def write_mt_manager(path: str | Path, *args, **kwargs) -> Path:
    return write_text(path, format_mt_manager(*args, **kwargs))
