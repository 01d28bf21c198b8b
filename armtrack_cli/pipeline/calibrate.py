"""`armtrack calibrate`: intrinsics (intrinsics.yaml or calib/ images), the camera's pose in W
from the board in frame N, and for palm sessions the user-specific palm model."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from armtrack_cli.calibrate.board_pose import CORNERS, CalibrateSettings, board_pose
from armtrack_cli.calibrate.intrinsics import MIN_VIEWS, calibrate_intrinsics
from armtrack_cli.calibrate.lift import lift_pixels
from armtrack_cli.calibrate.palm_model import PalmFit, label_palm
from armtrack_cli.core.errors import CalibrationError, ConfigError, did_you_mean
from armtrack_cli.core.streams import CameraModel
from armtrack_cli.detect.palm_blobs import PalmBlobDetector
from armtrack_cli.pipeline.common import out_dir, resolve_recipe
from armtrack_cli.session.camera_yaml import read_camera_yaml, write_camera_yaml
from armtrack_cli.session.config import Session, load_session, require
from armtrack_cli.session.depth import count_depth_frames, read_depth_frame
from armtrack_cli.session.images import read_images
from armtrack_cli.session.outputs import output_set
from armtrack_cli.session.palm_toml import write_palm_toml
from armtrack_cli.session.recipe import section
from armtrack_cli.session.video import probe_video, read_frame
from armtrack_cli.vision.charuco import MIN_CORNERS, make_board


def _intrinsics(session: Session) -> tuple[CameraModel, dict[str, Any]]:
    src = session.camera.intrinsics
    if not session.camera.intrinsics_from_images:
        return read_camera_yaml(src), {"intrinsics": str(src)}
    b = session.camera.board
    images = read_images(src)
    fit = calibrate_intrinsics([img for _, img in images], make_board(
        b.squares, b.square_m, b.marker_m, b.dictionary))
    if fit is None:
        raise CalibrationError(src, f"fewer than {MIN_VIEWS} of its {len(images)} images show "
                               f"at least {MIN_CORNERS} board corners",
                               "film the board whole, from 10-25 angles")
    return fit.camera, {"intrinsics": str(src), "intrinsics_rms_px": round(fit.rms_px, 4),
                        "views_used": fit.views_used,
                        "views_rejected": [images[k][0].name for k in fit.views_rejected]}


def _palm(session: Session, cam: CameraModel, image: np.ndarray, frame: int,
          markers_px: np.ndarray | None) -> tuple[PalmFit, np.ndarray]:
    p = session.palm
    if markers_px is None:
        blobs = PalmBlobDetector(p.colour.low, p.colour.high).detect(image)
        px = blobs[:, :2]
        if len(px) < len(p.markers):
            raise CalibrationError(session.camera.video, f"frame {frame}: {len(px)} marker blobs "
                                   f"found, {len(p.markers)} needed",
                                   "give their pixels with --markers, or try another --frame")
    else:
        px = markers_px
    count_depth_frames(session.root)  # PNGs misnamed: an error, not a palm model without depth
    depth = read_depth_frame(session.root, frame, (cam.width, cam.height))
    pts = lift_pixels(cam, px, depth)
    fit = label_palm(pts, p.markers, p.link_m, side=session.meta.side, camera_W=cam.centre_W)
    if fit is None or np.abs(fit.link_residual_m).max() > 0.02:
        worst = "" if fit is None else f" (a link is off by {np.abs(fit.link_residual_m).max() * 100:.1f} cm)"
        raise CalibrationError(session.camera.video, f"frame {frame}: the blobs do not fit the palm "
                               f"model of [palm] link_m{worst}",
                               "check link_m, or give the markers' pixels with --markers")
    return fit, px[fit.blob_index]


def calibrate(path: str | Path, *, frame: int = 0, markers_px: np.ndarray | None = None,
              out: str | Path | None = None, recipe: str | None = None,
              sets: tuple[str, ...] = ()) -> dict[str, Any]:
    session = load_session(path)
    require(session, "camera", "video", "intrinsics", "board")
    doc, where = resolve_recipe(recipe, sets)
    settings = section(doc, "calibrate", CalibrateSettings, where)
    if settings.corners not in CORNERS:
        raise ConfigError(where, f"[calibrate] corners = {settings.corners!r} is not one of "
                          f"{', '.join(CORNERS)}", did_you_mean(settings.corners, CORNERS,
                                                                what="choices"))
    cam, info = _intrinsics(session)
    video = probe_video(session.camera.video)
    if (video.width, video.height) != (cam.width, cam.height):
        raise CalibrationError(session.camera.intrinsics, f"is for {cam.width}x{cam.height} images "
                               f"but the video is {video.width}x{video.height}")
    image = read_frame(video, frame)
    b = session.camera.board
    pose = board_pose(image, make_board(b.squares, b.square_m, b.marker_m, b.dictionary), cam,
                      corners=settings.corners)
    if pose is None:
        raise CalibrationError(video.path, f"frame {frame}: no ChArUco board found",
                               "try another --frame where the board lies whole and unoccluded")
    if pose.n_corners < MIN_CORNERS:
        raise CalibrationError(video.path, f"frame {frame}: only {pose.n_corners} board corners "
                               f"found, {MIN_CORNERS} needed", "try another --frame")
    if not pose.rms_px <= settings.max_error_px:  # NaN too
        raise CalibrationError(video.path, f"frame {frame}: board reprojection error "
                               f"{pose.rms_px:.2f} px is above {settings.max_error_px} px",
                               "check the intrinsics and the board sizes, or try another --frame")
    cam = CameraModel(cam.K, cam.dist, cam.width, cam.height, pose.R_WC, pose.T_WC, pose.rms_px)
    dest = out_dir(session, out)
    result = {"camera_yaml": str(dest / "camera.yaml"), "frame": frame,
              "reprojection_error_px": round(pose.rms_px, 4), "corners": pose.n_corners,
              "camera_position_m": [round(float(v), 4) for v in pose.camera_position_W], **info}
    palm = _palm(session, cam, image, frame, markers_px) if session.palm is not None else None
    with output_set():
        if palm is not None:
            fit, px = palm
            write_palm_toml(dest / "palm.toml", side=session.meta.side, names=fit.names,
                            link_m=session.palm.link_m, angle_deg=fit.angle_deg,
                            position_H=fit.position_H, pixels=px,
                            link_residual_m=fit.link_residual_m, frame=frame,
                            depth=read_depth_frame(session.root, frame) is not None)
            result["palm_toml"] = str(dest / "palm.toml")
            result["palm_link_residual_cm"] = [round(float(v) * 100, 2)
                                               for v in fit.link_residual_m]
        write_camera_yaml(dest / "camera.yaml", cam)
    return result
