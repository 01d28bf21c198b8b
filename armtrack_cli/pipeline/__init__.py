"""The data flow on one screen: session -> calibrate -> detect -> fuse -> compare -> report.

    info(SESSION)        session/        read and validate every stream; say what is missing
    calibrate(SESSION)   calibrate/      intrinsics, the camera's pose in W from the board in
                                         frame N, the palm model -> camera.yaml, palm.toml
    detect(SESSION)      detect/         the wrist patch (CamShift) or the palm-marker blobs
                                         in every frame -> detections.csv
    fuse(SESSION)        fuse/, filters/ IMU + detections through the chosen filter
                                         -> trajectory-METHOD.csv, kinematics-METHOD.csv
    compare(SESSION)     compare/        against Qualisys -> errors.csv (Table I)
    report(SESSION…)     report/        the clinician PDF -> report.pdf
    simulate(OUT)        simulate/       sessions with exact truth, for tests and lab checks

Each stage reads its inputs through ``session`` (the I/O layer), calls pure functions of
arrays and writes its outputs atomically into SESSION/armtrack/ (or --out); stages exchange
files, so each can be run alone.
"""

from armtrack_cli.pipeline.calibrate import calibrate
from armtrack_cli.pipeline.compare import compare
from armtrack_cli.pipeline.detect import detect
from armtrack_cli.pipeline.fuse import fuse
from armtrack_cli.pipeline.info import format_info, frame_count, info
from armtrack_cli.pipeline.report import report
from armtrack_cli.pipeline.simulate import simulate, simulate_command
from armtrack_cli.simulate.arm_session import ArmSimSettings
from armtrack_cli.simulate.palm_session import PalmSimSettings

__all__ = ["info", "format_info", "frame_count", "calibrate", "detect", "fuse", "compare",
           "report", "simulate", "simulate_command", "ArmSimSettings", "PalmSimSettings"]
