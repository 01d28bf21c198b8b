"""IMU samples from MCAP: ROS 2 ``sensor_msgs/msg/Imu`` in CDR, or JSON with the same fields.

ROS stores quaternions as (x, y, z, w); they are reordered to (w, x, y, z) here. An
``orientation_covariance[0] == -1`` means the message carries no orientation (REP 145).
Times: ``header.stamp`` when set, else the log time; taken relative to the first sample.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from armtrack_cli.core.errors import DataError, ImuFileError
from armtrack_cli.core.streams import ImuSamples
from armtrack_cli.session.imu_checks import rate_and_dropped, unit_quaternions

MAGIC = b"\x89MCAP0\r\n"
IMU_SCHEMAS = ("sensor_msgs/msg/Imu", "sensor_msgs/Imu")


def open_summary(path: Path, error: type[DataError]):
    """(reader, file) after checking the magic and reading channels and schemas."""
    from mcap.reader import make_reader

    f = open(path, "rb")  # noqa: SIM115  (closed by the caller)
    head = f.read(8)
    if head != MAGIC:
        f.close()
        raise error(path, "is not an MCAP file (bad magic bytes)")
    f.seek(0)
    try:
        reader = make_reader(f)
        summary = reader.get_summary()
    except Exception as exc:  # the mcap library raises several types on damaged files
        f.close()
        raise error(path, f"is a damaged or truncated MCAP ({type(exc).__name__}: {exc})") from None
    if summary is None:  # no summary section: scan the records instead
        f.seek(0)
        reader = make_reader(f)
    return reader, f


def channels(reader, path: Path, error: type[DataError]):
    """{channel_id: (topic, schema_name, message_encoding)} from the summary or a full scan."""
    summary = reader.get_summary()
    if summary is not None:
        return {cid: (c.topic, summary.schemas[c.schema_id].name if c.schema_id in
                      summary.schemas else "", c.message_encoding)
                for cid, c in summary.channels.items()}
    out = {}
    try:
        for schema, channel, _ in reader.iter_messages():
            out[channel.id] = (channel.topic, schema.name if schema else "", channel.message_encoding)
    except Exception as exc:
        raise error(path, f"is a damaged or truncated MCAP ({type(exc).__name__})") from None
    return out


def pick_topic(path: Path, chans: dict, schemas: tuple[str, ...], wanted: str | None,
               error: type[DataError], what: str, key: str) -> tuple[str, str]:
    """The one topic carrying ``schemas`` (or the ``wanted`` one); clear errors otherwise."""
    found = sorted({(t, s, e) for t, s, e in chans.values() if s in schemas})
    if wanted is not None:
        found = [f for f in found if f[0] == wanted]
        if not found:
            raise error(path, f"has no {what} topic {wanted!r}", f"check {key} in session.toml")
    if not found:
        have = ", ".join(f"{t} ({s or 'no schema'})" for t, s, _ in sorted(set(chans.values())))
        raise error(path, f"has no {what} messages ({' or '.join(schemas)})",
                    f"it holds: {have or 'no channels'}")
    if len(found) > 1:
        raise error(path, f"has several {what} topics: {', '.join(f[0] for f in found)}",
                    f"name one with {key} in session.toml")
    return found[0][0], found[0][2]


def _stamp(msg_header_stamp, log_time_ns: int) -> float:
    sec, nsec = msg_header_stamp
    return sec + nsec * 1e-9 if (sec or nsec) else log_time_ns * 1e-9


def _decode_cdr(reader, topic):
    from mcap_ros2.decoder import DecoderFactory

    rows = []
    factory = DecoderFactory()
    for schema, channel, message in reader.iter_messages(topics=[topic]):
        decode = factory.decoder_for(channel.message_encoding, schema)
        m = decode(message.data)
        o, w, a = m.orientation, m.angular_velocity, m.linear_acceleration
        rows.append((_stamp((m.header.stamp.sec, m.header.stamp.nanosec), message.log_time),
                     o.w, o.x, o.y, o.z, float(m.orientation_covariance[0]),
                     w.x, w.y, w.z, a.x, a.y, a.z))
    return rows


def _decode_json(reader, topic, path):
    rows = []
    for _, _, message in reader.iter_messages(topics=[topic]):
        try:
            m = json.loads(message.data)
            st = m.get("header", {}).get("stamp", {})
            o, w, a = m["orientation"], m["angular_velocity"], m["linear_acceleration"]
            cov = m.get("orientation_covariance", [0.0])
            rows.append((_stamp((st.get("sec", 0), st.get("nanosec", st.get("nsec", 0))),
                                message.log_time),
                         o["w"], o["x"], o["y"], o["z"], float(cov[0]),
                         w["x"], w["y"], w["z"], a["x"], a["y"], a["z"]))
        except (ValueError, KeyError, TypeError, IndexError) as exc:
            raise ImuFileError(path, f"topic {topic}: a JSON Imu message is malformed "
                               f"({type(exc).__name__}: {exc})") from None
    return rows


def read_mcap_imu(path: Path, *, topic: str | None = None) -> ImuSamples:
    reader, f = open_summary(path, ImuFileError)
    try:
        chans = channels(reader, path, ImuFileError)
        topic, encoding = pick_topic(path, chans, IMU_SCHEMAS, topic, ImuFileError, "IMU",
                                     "[imu] topic")
        try:
            rows = (_decode_cdr(reader, topic) if encoding == "cdr"
                    else _decode_json(reader, topic, path) if encoding == "json" else None)
        except ImuFileError:
            raise
        except Exception as exc:
            raise ImuFileError(path, f"topic {topic}: messages cannot be decoded "
                               f"({type(exc).__name__}: {exc})") from None
        if rows is None:
            raise ImuFileError(path, f"topic {topic} uses message encoding {encoding!r}",
                               "armtrack reads cdr (ROS 2) and json")
    finally:
        f.close()
    if not rows:
        raise ImuFileError(path, f"topic {topic} has no messages")
    a = np.array(rows, dtype=float)
    order = np.argsort(a[:, 0], kind="stable")
    a = a[order]
    t = a[:, 0] - a[0, 0]
    if (np.diff(t) <= 0).any():
        r = int(np.flatnonzero(np.diff(t) <= 0)[0]) + 1
        raise ImuFileError(path, f"topic {topic}: message {r} repeats the time stamp of the one "
                           "before it")
    q = a[:, 1:5]  # ROS (x, y, z, w) was reordered to (w, x, y, z) when decoding
    has_q = a[:, 5] != -1.0
    notes: list[str] = [f"topic {topic}"]
    if not has_q.any():
        q = None
    else:
        q = q.copy()
        q[~has_q] = np.nan
        q = unit_quaternions(path, q, lambda r: f"topic {topic}: message {r}", "orientation",
                             "set orientation_covariance[0] = -1 when there is no orientation")
    rate, dropped = rate_and_dropped(t)
    return ImuSamples(str(path), "mcap", t, a[:, 9:12], a[:, 6:9], None, q, rate, dropped,
                      "file" if q is not None else "none", tuple(notes))
