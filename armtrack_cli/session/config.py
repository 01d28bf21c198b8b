"""session.toml -> frozen dataclasses, validated key by key (SESSION_FORMAT.md, "session.toml").

Unknown keys, missing required keys, wrong types and impossible values raise ConfigError
naming the key, what was seen and how to fix it.
"""

from __future__ import annotations

import datetime as _dt
import sys
from pathlib import Path
from typing import Any

import numpy as np

from armtrack_cli.core.errors import ConfigError, did_you_mean
from armtrack_cli.core.limits import MAX_BOARD_SQUARES
from armtrack_cli.session.files import misnamed_session_toml, read_small_text
from armtrack_cli.session.point_expr import point_markers
from armtrack_cli.session.session_types import (  # noqa: F401  (re-exported for the stages)
    ArmConfig,
    BoardConfig,
    CameraConfig,
    GroundTruthConfig,
    HsvRange,
    ImuConfig,
    PalmConfig,
    Session,
    SessionMeta,
    SyncConfig,
)

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

SIDES = ("right", "left")
AXES = ("+x", "-x", "+y", "-y", "+z", "-z")
BOARD_TYPES = ("charuco",)
ARM_ROLES = ("shoulder", "elbow", "wrist")
ARUCO_DICTIONARIES = tuple(
    f"DICT_{s}_{n}" for s in ("4X4", "5X5", "6X6", "7X7") for n in (50, 100, 250, 1000)
) + ("DICT_ARUCO_ORIGINAL", "DICT_APRILTAG_16h5", "DICT_APRILTAG_25h9",
     "DICT_APRILTAG_36h10", "DICT_APRILTAG_36h11")


class _Section:
    """Reads one TOML table, remembering which keys were used so the rest are reported."""

    def __init__(self, path: Path, name: str, table: Any, keys: tuple[str, ...]):
        self.path, self.name = path, name
        if not isinstance(table, dict):
            self.fail(None, f"is {_describe(table)}, expected a table", f"write it as [{name}]")
        self.table = table
        self.keys = keys
        self.used: set[str] = set()
        for k in table:  # unknown keys first: a typo must not surface as "missing"
            if k not in keys:
                self.fail(k, "is not a key armtrack knows",
                          did_you_mean(k, keys, what="valid keys"))

    def key(self, key: str | None) -> str:
        return f"[{self.name}]" if key is None else f"[{self.name}] {key}"

    def fail(self, key: str | None, problem: str, hint: str | None = None) -> None:
        raise ConfigError(self.path, f"{self.key(key)} {problem}", hint)

    def get(self, key: str, required: bool = False, default: Any = None) -> Any:
        self.used.add(key)
        if key not in self.table:
            if required:
                self.fail(key, "is missing", f"add `{key} = …` to [{self.name}]")
            return default
        return self.table[key]

    def number(self, key: str, *, required=False, default=None, lo=None, hi=None, unit="",
               hint=None) -> float | None:
        v = self.get(key, required, default)
        if v is None:
            return None
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            self.fail(key, f"= {v!r} is {_describe(v)}, expected a number{unit and ' in ' + unit}")
        v = float(v)
        if not np.isfinite(v):
            self.fail(key, f"= {v} is not a finite number")
        if (lo is not None and v < lo) or (hi is not None and v > hi):
            rng = f"between {lo} and {hi}" if lo is not None and hi is not None else (
                f"at least {lo}" if lo is not None else f"at most {hi}")
            self.fail(key, f"= {v:g} is impossible: it must be {rng}{unit and ' ' + unit}", hint)
        return v

    def string(self, key: str, *, required=False, default=None, choices=None) -> str | None:
        v = self.get(key, required, default)
        if v is None:
            return None
        if not isinstance(v, str):
            self.fail(key, f"= {v!r} is {_describe(v)}, expected a string")
        if choices is not None and v not in choices:
            self.fail(key, f"= {v!r} is not one of {', '.join(map(repr, choices))}",
                      did_you_mean(v, choices))
        return v

    def vector(self, key: str, n: int, *, required=False, integer=False) -> list | None:
        v = self.get(key, required)
        if v is None:
            return None
        ok = isinstance(v, list) and len(v) == n and all(
            isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)
        if ok and integer:
            ok = all(float(x).is_integer() for x in v)
        if not ok:
            what = "integers" if integer else "numbers"
            self.fail(key, f"= {v!r} is not a list of {n} {what}")
        return [int(x) for x in v] if integer else [float(x) for x in v]



def _describe(v: Any) -> str:
    return {str: "a string", bool: "a boolean", int: "an integer", float: "a number",
            list: "a list", dict: "a table"}.get(type(v), type(v).__name__)


# ---------------------------------------------------------------- sections

def _hsv(sec: _Section, key: str) -> HsvRange | None:
    v = sec.get(key)
    if v is None:
        return None
    if not isinstance(v, dict):
        sec.fail(key, f"is {_describe(v)}, expected {{ hsv_low = [H, S, V], hsv_high = [H, S, V] }}")
    sub = _Section(sec.path, f"{sec.name}.{key}", v, ("hsv_low", "hsv_high"))
    low = sub.vector("hsv_low", 3, required=True, integer=True)
    high = sub.vector("hsv_high", 3, required=True, integer=True)
    for name, hsv in (("hsv_low", low), ("hsv_high", high)):
        if not (0 <= hsv[0] <= 180 and 0 <= hsv[1] <= 255 and 0 <= hsv[2] <= 255):
            sub.fail(name, f"= {hsv} is out of OpenCV's HSV range",
                     "H is 0-180 and S, V are 0-255 (OpenCV halves the hue)")
    if low[1] > high[1] or low[2] > high[2]:
        sub.fail("hsv_low", f"= {low} is above hsv_high = {high} in S or V",
                 "only H may wrap (low H > high H goes through red)")
    return HsvRange(tuple(low), tuple(high))


def _meta(path: Path, root: Path, table: Any) -> SessionMeta:
    sec = _Section(path, "session", table, ("id", "subject", "recorded", "task", "side"))
    sid = sec.string("id", default=root.name)
    subject = sec.string("subject")
    recorded = sec.get("recorded")
    if recorded is not None and not isinstance(recorded, (_dt.datetime, _dt.date, str)):
        sec.fail("recorded", f"= {recorded!r} is not a date-time", "write 2026-11-20T10:15:00")
    task = sec.string("task")
    side = sec.string("side", default="right", choices=SIDES)
    return SessionMeta(sid, subject, None if recorded is None else str(recorded), task, side)


def _arm(path: Path, table: Any) -> ArmConfig:
    """[arm]: each of the three a value or "auto" (estimated from the session by fuse: NaN here)."""
    sec = _Section(path, "arm", table, ("upper_arm_m", "forearm_m", "shoulder_m"))
    units = "lengths are in metres (0.31, not 310 or 31)"
    auto = tuple(k for k in ("shoulder_m", "upper_arm_m", "forearm_m") if table.get(k) == "auto")
    for k in auto:
        sec.get(k)
    l1 = np.nan if "upper_arm_m" in auto else sec.number(
        "upper_arm_m", required=True, lo=0.05, hi=1.0, unit="m", hint=units + ', or "auto"')
    l2 = np.nan if "forearm_m" in auto else sec.number(
        "forearm_m", required=True, lo=0.05, hi=1.0, unit="m", hint=units + ', or "auto"')
    sh = [np.nan] * 3 if "shoulder_m" in auto else sec.vector("shoulder_m", 3, required=True)
    if max(abs(x) for x in sh) > 10:
        sec.fail("shoulder_m", f"= {sh} is more than 10 m from the board origin", units)
    return ArmConfig(l1, l2, np.array(sh, float), auto)


def _board(sec: _Section) -> BoardConfig | None:
    v = sec.get("board")
    if v is None:
        return None
    b = _Section(sec.path, "camera.board", v,
                 ("type", "squares", "square_m", "marker_m", "dictionary"))
    btype = b.string("type", required=True, choices=BOARD_TYPES)
    squares = b.vector("squares", 2, required=True, integer=True)
    if min(squares) < 2:
        b.fail("squares", f"= {squares}: a board needs at least 2 x 2 squares")
    if squares[0] * squares[1] > MAX_BOARD_SQUARES:
        b.fail("squares", f"= {squares}: more than {MAX_BOARD_SQUARES:,} squares is not a "
               "printed board", "count the squares along each side, e.g. [7, 5]")
    square = b.number("square_m", required=True, lo=1e-3, hi=1.0, unit="m",
                      hint="board sizes are in metres (0.04, not 40)")
    marker = b.number("marker_m", required=True, lo=1e-3, hi=1.0, unit="m",
                      hint="board sizes are in metres (0.03, not 30)")
    if marker >= square:
        b.fail("marker_m", f"= {marker:g} is not smaller than square_m = {square:g}",
               "the ArUco marker sits inside its square")
    dictionary = b.string("dictionary", required=True, choices=ARUCO_DICTIONARIES)
    return BoardConfig(btype, (squares[0], squares[1]), square, marker, dictionary)


def _camera(path: Path, root: Path, table: Any) -> CameraConfig:
    sec = _Section(path, "camera", table, ("video", "intrinsics", "board", "patch"))
    video = sec.string("video")
    intr = sec.string("intrinsics")
    board = _board(sec)
    patch = _hsv(sec, "patch")
    return CameraConfig(root / video if video else None, root / intr if intr else None, board, patch)


def _imu(path: Path, root: Path, table: Any) -> ImuConfig:
    sec = _Section(path, "imu", table, ("file", "forearm_axis", "rate_hz", "topic", "field"))
    f = sec.string("file", required=True)
    raw = sec.table.get("forearm_axis")
    if isinstance(raw, str) and raw.strip().lower() in ("x", "y", "z"):  # no sign: never guess
        sec.fail("forearm_axis", f"= {raw!r} has no sign", f"write '+{raw.strip().lower()}' or "
                 f"'-{raw.strip().lower()}': the direction from the elbow towards the hand")
    axis = sec.string("forearm_axis", default="+y", choices=AXES)
    rate = sec.number("rate_hz", lo=1.0, hi=10000.0, unit="Hz")
    topic = sec.string("topic")
    field = sec.string("field")
    if field is not None and not all(p.isidentifier() for p in field.split(".")):
        sec.fail("field", f"= {field!r} is not a dotted field path", 'write e.g. "imu" or "data.imu"')
    return ImuConfig(root / f, axis, rate, topic, field)


def _palm(path: Path, table: Any) -> PalmConfig:
    sec = _Section(path, "palm", table, ("markers", "link_m", "colour"))
    markers = sec.get("markers", required=True)
    if not (isinstance(markers, list) and markers and all(isinstance(m, str) for m in markers)):
        sec.fail("markers", f"= {markers!r} is not a list of marker names")
    if len(set(markers)) != len(markers):
        sec.fail("markers", f"= {markers!r} names a marker twice")
    if "WRIST" not in markers:
        sec.fail("markers", f"= {markers!r} has no WRIST marker", "the hand frame H starts at WRIST")
    raw = sec.table.get("link_m")
    if not (isinstance(raw, list) and len(raw) == len(markers)):
        sec.fail("link_m", f"= {raw!r} must give one length in metres per marker "
                 f"({len(markers)} markers)")
    links = sec.vector("link_m", len(markers), required=True)
    if any(x < 0 or x > 0.3 for x in links):
        sec.fail("link_m", f"= {links} has a length outside 0..0.3 m",
                 "wrist-to-marker lengths are in metres")
    colour = _hsv(sec, "colour")
    if colour is None:
        sec.fail("colour", "is missing", "add colour = { hsv_low = [...], hsv_high = [...] }")
    return PalmConfig(tuple(markers), tuple(links), colour)


def _groundtruth(path: Path, root: Path, table: Any, palm: PalmConfig | None) -> GroundTruthConfig:
    sec = _Section(path, "groundtruth", table, ("file", "markers", "to_world", "static",
                                                "clusters", "hand"))
    f = sec.string("file", required=True)
    markers = sec.get("markers", default={})
    roles = ARM_ROLES + (palm.markers if palm else ())
    if not isinstance(markers, dict):
        sec.fail("markers", f"is {_describe(markers)}, expected {{ wrist = \"R_WRI\", … }}")
    for role, name in markers.items():
        if role not in roles:
            sec.fail(f"markers.{role}", "is not a joint armtrack scores",
                     did_you_mean(role, roles, what="joints"))
        if not isinstance(name, str) or not name or point_markers(name) is None:
            sec.fail(f"markers.{role}", f"= {name!r} is not a marker name",
                     'write a marker ("R_WRI") or the midpoint of several ("mid(RLEP, RMEP)")')
    tw = sec.get("to_world", default=np.eye(4).tolist())
    try:
        T = np.array(tw, dtype=float)
    except (TypeError, ValueError):
        T = np.zeros(0)
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        sec.fail("to_world", f"= {tw!r} is not a 4x4 matrix of numbers")
    R = T[:3, :3]
    if not np.allclose(T[3], [0, 0, 0, 1]) or not np.allclose(R @ R.T, np.eye(3), atol=1e-3) \
            or np.linalg.det(R) < 0:
        sec.fail("to_world", "is not a rigid transform",
                 "its 3x3 block must be a rotation (orthonormal, det +1), its last row [0,0,0,1], "
                 "and its translation in metres")
    static = sec.string("static")
    hand = sec.string("hand")
    return GroundTruthConfig(root / f, dict(markers), T, root / static if static else None,
                             _clusters(sec), hand)


def _clusters(sec: _Section) -> dict[str, tuple[str, ...]]:
    """[groundtruth] clusters: landmark -> the markers of the rigid cluster that carries it
    (a list of at least 3 names, or a prefix: "RUAR" = RUAR1, RUAR2, … in the file)."""
    v = sec.get("clusters", default={})
    if not isinstance(v, dict):
        sec.fail("clusters", f"is {_describe(v)}, expected {{ RLEP = \"RUAR\", … }}")
    out = {}
    for landmark, c in v.items():
        if isinstance(c, str) and c:
            out[landmark] = (c + "*",)
        elif isinstance(c, list) and len(c) >= 3 and all(isinstance(x, str) and x for x in c):
            out[landmark] = tuple(c)
        else:
            sec.fail(f"clusters.{landmark}", f"= {c!r} is neither a marker prefix nor a list of "
                     "at least 3 marker names", "a rigid fit needs 3 or more cluster markers")
    if out and sec.table.get("static") is None:
        sec.fail("clusters", "needs [groundtruth] static, the calibration trial holding the "
                 "landmarks", 'add static = "…_static.csv"')
    return out


def _offset(sec: _Section, key: str) -> float | str:
    v = sec.get(key, default=0.0)
    if isinstance(v, str):
        if v != "auto":
            sec.fail(key, f"= {v!r} is neither a number of seconds nor \"auto\"")
        return v
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
        sec.fail(key, f"= {v!r} is neither a number of seconds nor \"auto\"")
    if abs(v) > 3600:
        sec.fail(key, f"= {v:g} s is more than an hour", "offsets are in seconds")
    return float(v)


def _sync(path: Path, table: Any) -> SyncConfig:
    sec = _Section(path, "sync", table, ("imu_offset_s", "groundtruth_offset_s"))
    s = SyncConfig(_offset(sec, "imu_offset_s"), _offset(sec, "groundtruth_offset_s"))
    return s


SECTIONS = ("session", "arm", "camera", "imu", "palm", "groundtruth", "sync")


def load_session(folder: str | Path) -> Session:
    """Read and validate SESSION/session.toml."""
    root = Path(folder)
    path = root / "session.toml"
    if not root.is_dir():
        raise ConfigError(root, "is not a session folder",
                          "give the folder that holds session.toml")
    near = misnamed_session_toml(root) if not path.exists() else None
    if near is not None:
        raise ConfigError(path, f"not found, but the folder holds {near!r}",
                          "rename it session.toml (lower case, no other extension)")
    text = read_small_text(path, ConfigError, "a session.toml", hint="a session folder needs a "
                           "session.toml (see docs/recording-guide.md)")
    if not text.strip():
        raise ConfigError(path, "is empty", "it needs at least [camera]/[imu] or [palm] sections")
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(path, f"is not valid TOML: {exc}") from None
    for name in doc:
        if name not in SECTIONS:
            raise ConfigError(path, f"[{name}] is not a section armtrack knows",
                              did_you_mean(name, SECTIONS, what="sections", form="[{}]"))
    meta = _meta(path, root, doc.get("session", {}))
    arm = _arm(path, doc["arm"]) if "arm" in doc else None
    camera = _camera(path, root, doc["camera"]) if "camera" in doc else None
    imu = _imu(path, root, doc["imu"]) if "imu" in doc else None
    palm = _palm(path, doc["palm"]) if "palm" in doc else None
    gt = _groundtruth(path, root, doc["groundtruth"], palm) if "groundtruth" in doc else None
    sync = _sync(path, doc.get("sync", {}))
    if not any((arm, camera, imu, palm, gt)):
        raise ConfigError(path, "has no data sections",
                          "an arm session needs [arm], [camera], [imu]; a palm session [camera], [palm]")
    return Session(root, path, meta, arm, camera, imu, palm, gt, sync)


def require(session: Session, section: str, *keys: str) -> None:
    """Raise ConfigError if a command needs a section (and keys) the session lacks."""
    obj = getattr(session, section if section != "session" else "meta")
    if obj is None:
        raise ConfigError(session.toml_path, f"has no [{section}] section, which this command needs")
    for k in keys:
        if getattr(obj, k) is None:
            raise ConfigError(session.toml_path, f"[{section}] {k} is missing, "
                              "which this command needs")
