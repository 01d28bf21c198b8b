"""Camera frames and their session times: any container OpenCV's FFmpeg reads, or
compressed images in an MCAP (``sensor_msgs/msg/CompressedImage``, ``foxglove.CompressedImage``).

Frame i is at i / fps on the session clock unless ``video_timestamps.csv`` (frame,t) says
otherwise; MCAP frames use their stamps relative to the first. Frames are streamed.
"""

from __future__ import annotations

import base64
import json
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np

from armtrack_cli.core.errors import VideoError
from armtrack_cli.core.limits import MAX_OFFSET_S, VIDEO_FPS
from armtrack_cli.core.streams import VideoStream
from armtrack_cli.session import imu_mcap
from armtrack_cli.session.files import regular_file
from armtrack_cli.session.text_table import (
    header_line,
    parse_table,
    read_text_lines,
    sniff_delimiter,
)

IMAGE_SCHEMAS = ("sensor_msgs/msg/CompressedImage", "foxglove.CompressedImage")


def _capture(path: Path) -> cv2.VideoCapture:
    cap = cv2.VideoCapture(str(path), cv2.CAP_FFMPEG)
    if not cap.isOpened():
        raise VideoError(path, "is not a video OpenCV's FFmpeg can open",
                         "use .mp4, .avi or .mkv, or check the file is complete")
    return cap


def read_timestamps(path: Path, n_frames: int) -> np.ndarray:
    lines = read_text_lines(path, VideoError, "video_timestamps.csv (frame,t)")
    at = header_line(lines)
    if at is None:
        raise VideoError(path, "holds only comments", "its header is frame,t")
    delim = sniff_delimiter(lines[at])  # a camera driver's may be tab-separated
    tab = parse_table(path, lines, at, delim if delim in ("\t", ";") else ",", VideoError,
                      skip_prefixes=("#",))
    if not tab.has("frame", "t"):
        raise VideoError(path, f"has columns {','.join(tab.header)}, expected frame,t")
    frame, t = tab.columns("frame")[:, 0], tab.columns("t")[:, 0]
    if not np.isfinite(t).all() or not np.isfinite(frame).all():
        raise VideoError(path, "has empty frame or t cells")
    if not np.array_equal(frame, np.arange(frame.size)):
        raise VideoError(path, "frame column must count 0, 1, 2, … without gaps")
    if (np.diff(t) <= 0).any():
        r = int(np.flatnonzero(np.diff(t) <= 0)[0]) + 1
        raise VideoError(path, f"line {tab.line_of[r]}: t does not increase ({t[r - 1]:g} then "
                         f"{t[r]:g})")
    if frame.size != n_frames:
        raise VideoError(path, f"lists {frame.size} frames but the video has {n_frames}")
    _check_clock(path, t)
    return t


def _check_clock(path: Path, t: np.ndarray) -> None:
    """t is the session clock, in seconds: times in ms or µs, or an epoch or device clock,
    would pass as a video hours long or starting hours late, which no offset can meet."""
    step = float(np.median(np.diff(t))) if t.size > 1 else 1.0 / VIDEO_FPS[0]
    if not VIDEO_FPS[0] <= 1.0 / step <= VIDEO_FPS[1]:
        raise VideoError(path, f"t steps by {step:g} per frame, {1.0 / step:g} frames/s",
                         "t is in seconds (is it in ms?)")
    if abs(t[0]) > MAX_OFFSET_S:
        raise VideoError(path, f"t starts at {t[0]:g} s; it is the session clock, seconds from "
                         "the recording's start", "subtract the first frame's time (is it an "
                         "epoch or device clock?)")


def probe_video(path: str | Path, *, topic: str | None = None) -> VideoStream:
    """What the camera recording holds, without keeping its frames."""
    path = regular_file(path, VideoError, "a video", hint="check [camera] video in session.toml")
    if path.stat().st_size == 0:
        raise VideoError(path, "is empty (0 bytes)")
    with open(path, "rb") as f:
        if f.read(8) == imu_mcap.MAGIC:
            return _probe_mcap(path, topic)
    cap = _capture(path)
    try:
        ok, frame = cap.read()
        if not ok or frame is None:
            raise VideoError(path, "has no decodable frames")
        fps = float(cap.get(cv2.CAP_PROP_FPS))
        n = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
        if n <= 0:  # containers without a frame count: count by grabbing
            n = 1
            while cap.grab():
                n += 1
    finally:
        cap.release()
    h, w = frame.shape[:2]
    ts_path = path.parent / "video_timestamps.csv"
    if ts_path.exists():
        t = read_timestamps(ts_path, n)
        fps = float(1.0 / np.median(np.diff(t))) if n > 1 else fps
        source = "video_timestamps.csv"
    else:
        if not (np.isfinite(fps) and fps > 0):
            raise VideoError(path, "states no frame rate", "add video_timestamps.csv (frame,t)")
        t = np.arange(n) / fps
        source = "fps"
    return VideoStream(str(path), "file", n, fps, w, h, t, source)


def iter_frames(video: VideoStream, decode_from: int = 0
                ) -> Iterator[tuple[int, float, np.ndarray]]:
    """(index, session time, BGR uint8 image) for every frame (from ``decode_from`` on, the
    earlier ones decoded and skipped), streamed."""
    if video.source == "mcap":
        yield from ((i, t, img) for i, t, img in _iter_mcap(video) if i >= decode_from)
        return
    cap = _capture(Path(video.path))
    try:
        i = 0
        while i < video.n_frames:
            if i < decode_from:
                ok, frame = cap.grab(), None
            else:
                ok, frame = cap.read()
            if not ok:
                raise VideoError(video.path, f"frame {i} of the {video.n_frames} its header states "
                                 "cannot be decoded: the file is damaged or truncated, or its "
                                 "header's frame count is wrong (a remuxed file)",
                                 "re-export or re-copy the video")
            if frame is not None:
                yield i, float(video.t[i]), frame
            i += 1
    finally:
        cap.release()


def iter_frames_i420(video: VideoStream) -> Iterator[tuple[int, float, object]]:
    """iter_frames, each frame a vision.yuv.YuvFrame (its I420 planes, not converted) where
    PyAV decodes the file to yuv420p, else a BGR image as iter_frames gives it. The same
    frames at the same indices and times as iter_frames (tests check it on the sample
    sessions): a file PyAV cannot open, or a frame it cannot decode, is read from there on by
    OpenCV, as iter_frames reads it."""
    if video.source != "file":
        yield from iter_frames(video)
        return
    i = 0
    for i, frame in _pyav_frames(video):
        yield i, float(video.t[i]), frame
        i += 1
    if i < video.n_frames:  # PyAV stopped early: OpenCV from frame i on
        yield from iter_frames(video, decode_from=i)


def load_decoder(video: VideoStream) -> None:
    """Import PyAV now where iter_frames_i420 will decode with it: a fresh process's one-time
    import (about 0.1 s of CPU), which would otherwise fall inside its first frame."""
    if video.source == "file":
        try:
            import av  # noqa: F401
        except ImportError:  # OpenCV will read it
            pass


def _pyav_frames(video: VideoStream) -> Iterator[tuple[int, object]]:
    """(index, YuvFrame or BGR image) for as many frames as PyAV decodes, at most n_frames."""
    try:
        import av
        container = av.open(video.path)
    except Exception:  # no PyAV, or a file it cannot open: OpenCV reads it all
        return
    try:
        stream = container.streams.video[0]
        stream.thread_type = "AUTO"  # FFmpeg's frame threads: no more CPU a frame than one thread
        #                              (benchmarks/decoders.py), at 2-4x the wall speed
        i = 0
        for frame in container.decode(stream):
            if i >= video.n_frames:
                return
            yield i, _as_planes(frame, video)
            i += 1
    except Exception:  # av.error.FFmpegError and kin mid-stream: OpenCV takes over
        return
    finally:
        container.close()


def _as_planes(frame, video: VideoStream):
    from armtrack_cli.vision.yuv import YuvFrame

    if frame.format.name != "yuv420p" or (frame.width, frame.height) != (video.width,
                                                                         video.height):
        return frame.to_ndarray(format="bgr24")
    y, u, v = (np.frombuffer(p, np.uint8).reshape(p.height, p.line_size)[:, :p.width]
               for p in frame.planes)
    return YuvFrame(y, u, v)


# ---------------------------------------------------------------- MCAP images

def _image_messages(path: Path, topic: str):
    reader, f = imu_mcap.open_summary(path, VideoError)
    try:
        from mcap_ros2.decoder import DecoderFactory

        factory = DecoderFactory()
        for schema, channel, message in reader.iter_messages(topics=[topic]):
            if channel.message_encoding == "cdr":
                m = factory.decoder_for("cdr", schema)(message.data)
                st = m.header.stamp
                t = st.sec + st.nanosec * 1e-9 if (st.sec or st.nanosec) else message.log_time * 1e-9
                yield t, bytes(m.data)
            elif channel.message_encoding == "json":
                m = json.loads(message.data)
                st = m.get("timestamp", {})
                t = st.get("sec", 0) + st.get("nsec", 0) * 1e-9 or message.log_time * 1e-9
                yield t, base64.b64decode(m["data"])
            else:
                raise VideoError(path, f"topic {topic}: message encoding "
                                 f"{channel.message_encoding!r} is not cdr or json")
    finally:
        f.close()


def _probe_mcap(path: Path, topic: str | None) -> VideoStream:
    reader, f = imu_mcap.open_summary(path, VideoError)
    try:
        chans = imu_mcap.channels(reader, path, VideoError)
    finally:
        f.close()
    topic, _ = imu_mcap.pick_topic(path, chans, IMAGE_SCHEMAS, topic, VideoError, "camera image",
                                   "[camera] video")
    times, first = [], None
    for t, data in _image_messages(path, topic):
        times.append(t)
        if first is None:
            first = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
            if first is None:
                raise VideoError(path, f"topic {topic}: the first image cannot be decoded")
    t = np.asarray(times) - times[0]
    if (np.diff(t) <= 0).any():
        raise VideoError(path, f"topic {topic}: image stamps do not increase")
    fps = float(1.0 / np.median(np.diff(t))) if t.size > 1 else 0.0
    h, w = first.shape[:2]
    return VideoStream(str(path), "mcap", len(times), fps, w, h, t, "mcap", topic)


def _iter_mcap(video: VideoStream) -> Iterator[tuple[int, float, np.ndarray]]:
    for i, (_, data) in enumerate(_image_messages(Path(video.path), video.topic)):
        img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
        if img is None:
            raise VideoError(video.path, f"topic {video.topic}: image {i} cannot be decoded")
        yield i, float(video.t[i]), img


def read_frame(video: VideoStream, index: int) -> np.ndarray:
    """One frame by index (decodes from the start: for the first frames of a session)."""
    if not 0 <= index < video.n_frames:
        raise VideoError(video.path, f"has {video.n_frames} frames; frame {index} does not exist",
                         f"use --frame between 0 and {video.n_frames - 1}")
    for i, _, img in iter_frames(video):
        if i == index:
            return img
    raise VideoError(video.path, f"frame {index} cannot be decoded")


BATCH = 8  # frames handed between the threads at a time: one wake-up per batch, not per frame


def iter_frames_ahead(video: VideoStream, depth: int = 16, *, i420: bool = False
                      ) -> Iterator[tuple[int, float, np.ndarray]]:
    """iter_frames (or with ``i420`` iter_frames_i420) with decoding on a second thread, so
    decoding and detection overlap (OpenCV and PyAV release the GIL while they decode, OpenCV
    while it filters). Frames cross in batches of BATCH, at most ``depth`` frames waiting."""
    import queue
    import threading

    q: queue.Queue = queue.Queue(maxsize=max(1, depth // BATCH))
    stop = threading.Event()
    done = object()

    def produce() -> None:
        batch = []
        try:
            for item in (iter_frames_i420 if i420 else iter_frames)(video):
                if stop.is_set():
                    return
                batch.append(item)
                if len(batch) == BATCH:
                    q.put(batch)
                    batch = []
        except BaseException as exc:  # handed to the consumer, after the frames before it
            q.put(batch)
            q.put(exc)
            return
        q.put(batch)
        q.put(done)

    th = threading.Thread(target=produce, daemon=True)
    th.start()
    try:
        while True:
            item = q.get()
            if item is done:
                break
            if isinstance(item, BaseException):
                raise item
            yield from item
    finally:
        stop.set()
        while th.is_alive():
            try:
                q.get_nowait()
            except queue.Empty:
                th.join(0.01)
