"""IMU samples from MCAP: ROS 2 ``sensor_msgs/msg/Imu`` in CDR, or JSON with the same fields.

ROS stores quaternions as (x, y, z, w); they are reordered to (w, x, y, z) here. An
``orientation_covariance[0] == -1`` means the message carries no orientation (REP 145).
Times: ``header.stamp`` when set, else the log time; taken relative to the first sample.
An Imu (and MagneticField) nested inside a driver's own message is found by walking its ROS 2
schema (``ros2_schema``); ``[imu] field`` names the path when there is more than one.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from armtrack_cli.core.errors import DataError, ImuFileError
from armtrack_cli.core.streams import ImuSamples
from armtrack_cli.session.imu_checks import rate_and_dropped, unit_quaternions
from armtrack_cli.session.ros2_schema import field_paths, get_path

MAGIC = b"\x89MCAP0\r\n"
IMU_SCHEMAS = ("sensor_msgs/msg/Imu", "sensor_msgs/Imu")
TESLA_TO_UT = 1e6  # sensor_msgs/MagneticField is in tesla; armtrack's magnetometer in µT
BLOCK = 4096  # messages made into arrays at a time
COLUMNS = ((0,), (1, 2, 3, 4), (5,), (6, 7, 8), (9, 10, 11), (12, 13, 14))  # a row's groups:
#         stamp, quaternion (w, x, y, z), orientation_covariance[0], gyro, acc[, magnetometer]


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


def _decode_cdr(reader, topic, field="", mag_field=None):
    from mcap_ros2.decoder import DecoderFactory

    factory = DecoderFactory()
    for schema, channel, message in reader.iter_messages(topics=[topic]):
        decode = factory.decoder_for(channel.message_encoding, schema)
        outer = decode(message.data)
        m = get_path(outer, field)
        o, w, a = m.orientation, m.angular_velocity, m.linear_acceleration
        b = get_path(outer, mag_field).magnetic_field if mag_field else None
        yield ((_stamp((m.header.stamp.sec, m.header.stamp.nanosec), message.log_time),
                o.w, o.x, o.y, o.z, float(m.orientation_covariance[0]),
                w.x, w.y, w.z, a.x, a.y, a.z)
               + ((b.x * TESLA_TO_UT, b.y * TESLA_TO_UT, b.z * TESLA_TO_UT) if b else ()))


def _decode_json(reader, topic, path):
    for _, _, message in reader.iter_messages(topics=[topic]):
        try:
            m = json.loads(message.data)
            st = m.get("header", {}).get("stamp", {})
            o, w, a = m["orientation"], m["angular_velocity"], m["linear_acceleration"]
            cov = m.get("orientation_covariance", [0.0])
            row = (_stamp((st.get("sec", 0), st.get("nanosec", st.get("nsec", 0))),
                          message.log_time),
                   o["w"], o["x"], o["y"], o["z"], float(cov[0]),
                   w["x"], w["y"], w["z"], a["x"], a["y"], a["z"])
        except (ValueError, KeyError, TypeError, IndexError) as exc:
            raise ImuFileError(path, f"topic {topic}: a JSON Imu message is malformed "
                               f"({type(exc).__name__}: {exc})") from None
        yield row


def _schemas(reader, path: Path) -> dict[str, tuple[str, str, str]]:
    """{topic: (schema name, schema text, message encoding)}."""
    summary = reader.get_summary()
    if summary is not None:
        return {c.topic: (summary.schemas[c.schema_id].name,
                          summary.schemas[c.schema_id].data.decode("utf-8", "replace"),
                          c.message_encoding)
                for c in summary.channels.values() if c.schema_id in summary.schemas}
    out = {}
    try:
        for schema, channel, _ in reader.iter_messages():
            if schema is not None:
                out[channel.topic] = (schema.name, schema.data.decode("utf-8", "replace"),
                                      channel.message_encoding)
    except Exception as exc:
        raise ImuFileError(path, f"is a damaged or truncated MCAP ({type(exc).__name__})") from None
    return out


def find_imu(path: Path, schemas: dict, topic: str | None, field: str | None
             ) -> tuple[str, str, str, str | None]:
    """(topic, encoding, Imu field path ('' = the message itself), MagneticField path or None)
    for the one IMU stream: a ``sensor_msgs/Imu`` topic, or an Imu field inside a topic's
    message found by walking its ROS 2 schema."""
    found = []
    for tp, (name, text, enc) in sorted(schemas.items()):
        if topic is not None and tp != topic:
            continue
        paths = [""] if name in IMU_SCHEMAS else (
            field_paths(name, text, "sensor_msgs/Imu") if enc == "cdr" else [])
        if field is not None:
            if field not in paths:
                if topic is not None:
                    raise ImuFileError(path, f"topic {tp}: its message ({name}) has no "
                                       f"sensor_msgs/Imu field {field!r}",
                                       "Imu fields found: " + (", ".join(paths) or "none"))
                continue
            paths = [field]
        mags = field_paths(name, text, "sensor_msgs/MagneticField") if enc == "cdr" else []
        found += [(tp, enc, p, mags[0] if len(mags) == 1 else None, name) for p in paths]
    key = "[imu] topic"
    if topic is not None and topic not in schemas:
        raise ImuFileError(path, f"has no IMU topic {topic!r}", f"check {key} in session.toml")
    if not found:
        have = ", ".join(f"{t} ({s[0] or 'no schema'})" for t, s in sorted(schemas.items()))
        raise ImuFileError(path, "has no IMU messages (sensor_msgs/msg/Imu, alone or as a field "
                           "of another message)", f"it holds: {have or 'no channels'}")
    if len({f[0] for f in found}) > 1:
        raise ImuFileError(path, "has several IMU topics: " + ", ".join(sorted({f[0] for f in
                           found})), f"name one with {key} in session.toml")
    if len(found) > 1:
        raise ImuFileError(path, f"topic {found[0][0]}: its message ({found[0][4]}) holds "
                           f"several sensor_msgs/Imu fields: {', '.join(f[2] for f in found)}",
                           "name one with [imu] field in session.toml")
    return found[0][:4]


def read_mcap_imu(path: Path, *, topic: str | None = None, field: str | None = None
                  ) -> ImuSamples:
    reader, f = open_summary(path, ImuFileError)
    try:
        topic, encoding, field, mag_field = find_imu(path, _schemas(reader, path), topic, field)
        if field and encoding != "cdr":
            raise ImuFileError(path, f"topic {topic}: [imu] field is read from CDR (ROS 2) "
                               f"messages only, not {encoding!r}")
        if encoding not in ("cdr", "json"):
            raise ImuFileError(path, f"topic {topic} uses message encoding {encoding!r}",
                               "armtrack reads cdr (ROS 2) and json")
        try:
            cols = _columns(_decode_cdr(reader, topic, field, mag_field) if encoding == "cdr"
                            else _decode_json(reader, topic, path))
        except ImuFileError:
            raise
        except Exception as exc:
            raise ImuFileError(path, f"topic {topic}: messages cannot be decoded "
                               f"({type(exc).__name__}: {exc})") from None
    finally:
        f.close()
    if cols is None:
        raise ImuFileError(path, f"topic {topic} has no messages")
    stamp = cols[0][:, 0]
    if (np.diff(stamp) < 0).any():  # out of time order: sorted (stably; in order, as it is)
        order = np.argsort(stamp, kind="stable")
        cols = [c[order] for c in cols]
        stamp = cols[0][:, 0]
    t = stamp - stamp[0]
    if (np.diff(t) <= 0).any():
        r = int(np.flatnonzero(np.diff(t) <= 0)[0]) + 1
        raise ImuFileError(path, f"topic {topic}: message {r} repeats the time stamp of the one "
                           "before it")
    q = cols[1]  # ROS (x, y, z, w) was reordered to (w, x, y, z) when decoding
    has_q = cols[2][:, 0] != -1.0
    notes: list[str] = [f"topic {topic}" + (f", field {field}" if field else "")]
    mag = cols[5] if len(cols) > 5 else None
    if mag is not None:
        notes.append(f"magnetometer from field {mag_field} (T -> µT)")
    if not has_q.any():
        q = None
    else:
        q[~has_q] = np.nan
        q = unit_quaternions(path, q, lambda r: f"topic {topic}: message {r}", "orientation",
                             "set orientation_covariance[0] = -1 when there is no orientation")
    rate, dropped = rate_and_dropped(t)
    return ImuSamples(str(path), "mcap", t, cols[4], cols[3], mag, q, rate, dropped,
                      "file" if q is not None else "none", tuple(notes))


def _columns(rows) -> list[np.ndarray] | None:
    """The decoded rows' columns, each group of COLUMNS in an array of its own (stamp,
    quaternion, covariance[0], gyro, accelerometer[, magnetometer]), made BLOCK rows at a
    time: no Python tuple per message held (a 60-minute recording's took 250 MB; issue 15),
    nothing kept that is not returned. None without rows."""
    parts: list[list[np.ndarray]] = []
    block: list[tuple] = []
    for row in rows:
        block.append(row)
        if len(block) == BLOCK:
            _add(parts, block)
    _add(parts, block)
    if not parts:
        return None
    out = []
    for p in parts:  # group by group: its blocks let go as it is joined
        out.append(p[0] if len(p) == 1 else np.concatenate(p))
        p.clear()
    return out


def _add(parts: list[list[np.ndarray]], block: list[tuple]) -> None:
    """The block's rows (cleared) as arrays, one per group of COLUMNS, onto ``parts``."""
    if not block:
        return
    a = np.array(block, dtype=float)
    block.clear()
    groups = [g for g in COLUMNS if g[-1] < a.shape[1]]
    if not parts:
        parts.extend([] for _ in groups)
    for p, g in zip(parts, groups, strict=True):
        p.append(a[:, g[0]:g[-1] + 1].copy())
