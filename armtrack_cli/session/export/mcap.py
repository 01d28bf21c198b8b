"""Write MCAP recordings: ROS 2 ``sensor_msgs/msg/Imu`` (CDR or JSON) and camera images.

Used by the simulator (`--imu-format mcap`) and by reader tests. ROS quaternions are
(x, y, z, w); ours are (w, x, y, z) and are reordered here.
"""

from __future__ import annotations

import base64
import json
from pathlib import Path

import numpy as np

from armtrack_cli.session.outputs import atomic_write

_TIME = "int32 sec\nuint32 nanosec"
_HEADER = "builtin_interfaces/Time stamp\nstring frame_id"
_SEP = "=" * 80
IMU_MSGDEF = "\n".join([
    "std_msgs/Header header", "geometry_msgs/Quaternion orientation",
    "float64[9] orientation_covariance", "geometry_msgs/Vector3 angular_velocity",
    "float64[9] angular_velocity_covariance", "geometry_msgs/Vector3 linear_acceleration",
    "float64[9] linear_acceleration_covariance",
    _SEP, "MSG: std_msgs/Header", _HEADER, _SEP, "MSG: builtin_interfaces/Time", _TIME,
    _SEP, "MSG: geometry_msgs/Quaternion", "float64 x\nfloat64 y\nfloat64 z\nfloat64 w",
    _SEP, "MSG: geometry_msgs/Vector3", "float64 x\nfloat64 y\nfloat64 z"])
IMAGE_MSGDEF = "\n".join(["std_msgs/Header header", "string format", "uint8[] data",
                          _SEP, "MSG: std_msgs/Header", _HEADER,
                          _SEP, "MSG: builtin_interfaces/Time", _TIME])


def _stamp(t: float) -> dict:
    ns = int(round(t * 1e9))
    return {"sec": ns // 10**9, "nanosec": ns % 10**9}


def _imu_msg(t, acc, gyr, q, frame_id="imu"):
    has_q = q is not None and np.isfinite(q).all()
    w, x, y, z = (q if has_q else (1.0, 0.0, 0.0, 0.0))
    cov = [0.0] * 9
    if not has_q:
        cov[0] = -1.0  # REP 145: no orientation
    return {"header": {"stamp": _stamp(t), "frame_id": frame_id},
            "orientation": {"x": float(x), "y": float(y), "z": float(z), "w": float(w)},
            "orientation_covariance": cov,
            "angular_velocity": dict(zip("xyz", map(float, gyr))),
            "angular_velocity_covariance": [0.0] * 9,
            "linear_acceleration": dict(zip("xyz", map(float, acc))),
            "linear_acceleration_covariance": [0.0] * 9}


def write_imu_mcap(path: str | Path, t: np.ndarray, acc: np.ndarray, gyr: np.ndarray,
                   q: np.ndarray | None, *, topic: str = "/imu/data", encoding: str = "cdr",
                   t0: float = 1_700_000_000.0, images: list[tuple[float, bytes]] | None = None,
                   image_topic: str = "/camera/image/compressed") -> Path:
    """An MCAP with one IMU topic (and optionally JPEG images); times t (s) after t0."""

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as f:
            if encoding == "cdr":
                from mcap_ros2.writer import Writer

                w = Writer(f)
                schema = w.register_msgdef("sensor_msgs/msg/Imu", IMU_MSGDEF)
                ischema = w.register_msgdef("sensor_msgs/msg/CompressedImage", IMAGE_MSGDEF)
                for i in range(t.size):
                    ns = int(round((t0 + t[i]) * 1e9))
                    w.write_message(topic, schema, _imu_msg(t0 + t[i], acc[i], gyr[i],
                                                           None if q is None else q[i]),
                                    log_time=ns, publish_time=ns)
                for ti, data in images or []:
                    ns = int(round((t0 + ti) * 1e9))
                    w.write_message(image_topic, ischema, {"header": {"stamp": _stamp(t0 + ti),
                                    "frame_id": "camera"}, "format": "jpeg", "data": data},
                                    log_time=ns, publish_time=ns)
                w.finish()
            else:
                from mcap.writer import Writer

                w = Writer(f)
                w.start(profile="", library="armtrack")
                sid = w.register_schema("sensor_msgs/msg/Imu", "jsonschema", b"{}")
                cid = w.register_channel(topic, "json", sid)
                img_cid = None
                if images:
                    isid = w.register_schema("foxglove.CompressedImage", "jsonschema", b"{}")
                    img_cid = w.register_channel(image_topic, "json", isid)
                for i in range(t.size):
                    ns = int(round((t0 + t[i]) * 1e9))
                    msg = _imu_msg(t0 + t[i], acc[i], gyr[i], None if q is None else q[i])
                    w.add_message(cid, log_time=ns, publish_time=ns,
                                  data=json.dumps(msg).encode())
                for ti, data in images or []:
                    ns = int(round((t0 + ti) * 1e9))
                    st = _stamp(t0 + ti)
                    msg = {"timestamp": {"sec": st["sec"], "nsec": st["nanosec"]},
                           "frame_id": "camera", "format": "jpeg",
                           "data": base64.b64encode(data).decode()}
                    w.add_message(img_cid, log_time=ns, publish_time=ns,
                                  data=json.dumps(msg).encode())
                w.finish()

    return atomic_write(path, write)
