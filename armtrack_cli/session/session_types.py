"""What a session.toml says, as frozen dataclasses (SESSION_FORMAT.md, "session.toml");
session/config.py reads and validates the file into them."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from armtrack_cli.core.errors import ConfigError


@dataclass(frozen=True)
class SessionMeta:
    id: str
    subject: str | None
    recorded: str | None
    task: str | None
    side: str


@dataclass(frozen=True)
class ArmConfig:
    upper_arm_m: float  # L1, shoulder to elbow
    forearm_m: float  # L2, elbow to wrist joint (IMU origin)
    shoulder_m: np.ndarray  # (3,) fixed shoulder joint in W, m
    auto: tuple[str, ...] = ()  # the keys given as "auto" (NaN above until fuse estimates them)


@dataclass(frozen=True)
class BoardConfig:
    type: str
    squares: tuple[int, int]  # (columns, rows) of squares, OpenCV's CharucoBoard size
    square_m: float
    marker_m: float
    dictionary: str


@dataclass(frozen=True)
class HsvRange:
    low: tuple[int, int, int]  # OpenCV HSV: H 0-180, S and V 0-255
    high: tuple[int, int, int]

    @property
    def wraps(self) -> bool:
        """Low H above high H wraps through red (e.g. 170..10)."""
        return self.low[0] > self.high[0]


@dataclass(frozen=True)
class CameraConfig:
    video: Path | None
    intrinsics: Path | None
    board: BoardConfig | None
    patch: HsvRange | None

    @property
    def intrinsics_from_images(self) -> bool:
        """True when intrinsics names a folder of board images (calib/) to compute them from."""
        return self.intrinsics is not None and self.intrinsics.is_dir()


@dataclass(frozen=True)
class ImuConfig:
    file: Path
    forearm_axis: str
    rate_hz: float | None
    topic: str | None
    field: str | None = None  # MCAP: dotted path of the sensor_msgs/Imu inside the message

    @property
    def forearm_unit(self) -> np.ndarray:
        """Unit vector in B from the elbow towards the hand."""
        v = np.zeros(3)
        v["xyz".index(self.forearm_axis[1])] = 1.0 if self.forearm_axis[0] == "+" else -1.0
        return v


@dataclass(frozen=True)
class PalmConfig:
    markers: tuple[str, ...]
    link_m: tuple[float, ...]
    colour: HsvRange


@dataclass(frozen=True)
class GroundTruthConfig:
    file: Path
    markers: dict[str, str]  # role (shoulder/elbow/wrist or a palm marker) -> QTM marker name
    to_world: np.ndarray  # (4, 4) Qualisys frame (m) -> W
    static: Path | None = None  # Vicon/C3D static calibration trial holding the landmarks
    clusters: dict[str, tuple[str, ...]] = field(default_factory=dict)  # landmark -> cluster
    hand: str | None = None  # QTM 6DOF rigid body whose rotation is the hand frame H


@dataclass(frozen=True)
class SyncConfig:
    imu_offset_s: float | str  # float, or "auto"
    groundtruth_offset_s: float | str


@dataclass(frozen=True)
class Session:
    root: Path
    toml_path: Path
    meta: SessionMeta
    arm: ArmConfig | None
    camera: CameraConfig | None
    imu: ImuConfig | None
    palm: PalmConfig | None
    groundtruth: GroundTruthConfig | None
    sync: SyncConfig

    def offset_s(self, key: str) -> float:
        """[sync] ``key`` (imu_offset_s or groundtruth_offset_s) in seconds: session time =
        stream time + offset. "auto" is estimated from the data by the stage that uses the
        stream (fuse for the IMU, compare for the ground truth), never here."""
        value = getattr(self.sync, key)
        if isinstance(value, str):
            raise ConfigError(self.toml_path, f'[sync] {key} = "auto" has no value until '
                              "estimated from the data",
                              "write the offset in seconds (session time = stream time + offset)")
        return value

    @property
    def kind(self) -> str:
        """'palm' for Cordella marker sessions, 'arm' with an arm model, else 'object'."""
        if self.palm is not None:
            return "palm"
        return "arm" if self.arm is not None else "object"

    @property
    def out_dir(self) -> Path:
        return self.root / "armtrack"


# ---------------------------------------------------------------- key checking helpers
