"""The data flow on one screen: session -> calibrate -> detect -> fuse -> compare -> report.

    info(SESSION)        session/          read and validate every stream; say what is missing
    calibrate(SESSION)   calibrate/        intrinsics, the camera's pose in W from the board in
                                           frame N, the palm model -> camera.yaml, palm.toml
    detect(SESSION)      detect/           the wrist patch (CamShift) or the palm-marker blobs
                                           in every frame -> detections.csv
    fuse(SESSION)        fuse/, filters/   IMU + detections through the chosen filter
                                           -> trajectory-METHOD.csv, kinematics-METHOD.csv
    compare(SESSION)     compare/          against Qualisys -> errors.csv (Table I), measures.csv
    report(SESSION…)     report/           the clinician PDF -> report.pdf (several sessions of
                                           one subject: their progress)
    run(SESSION)         (this package)    every stage above, in order, each only when its
                                           inputs are newer than its outputs
    run_many(FOLDERS)    (this package)    run over many sessions, on Dask when asked -> cohort.csv
    export(SESSION)      session/export/   trajectories and truth for other tools (TUM, CSV, C3D)
    simulate(OUT)        simulate/         sessions with exact truth, for tests and lab checks

Each stage reads its inputs through ``session`` (the I/O layer), calls pure functions of
arrays and writes its outputs atomically into the work folder (SESSION/armtrack/ or --out);
stages exchange files, so each can be run alone. Shared below the stages: vision/ (the
ChArUco board), measures/ (the clinical measures, pure functions; fuse computes them,
compare measures the truth beside them), filters/ (Kalman, unscented, particle), core/ (types,
quaternions, errors, the method list).
"""

from armtrack_cli.pipeline.batch import run_many
from armtrack_cli.pipeline.calibrate import calibrate
from armtrack_cli.pipeline.compare import compare
from armtrack_cli.pipeline.detect import detect
from armtrack_cli.pipeline.export import export
from armtrack_cli.pipeline.fuse import fuse
from armtrack_cli.pipeline.info import frame_count, info
from armtrack_cli.pipeline.mocap import simulate_from_mocap
from armtrack_cli.pipeline.report import report
from armtrack_cli.pipeline.run import STAGES, run
from armtrack_cli.pipeline.simulate import simulate, simulate_command
from armtrack_cli.simulate.arm_session import ArmSimSettings
from armtrack_cli.simulate.from_mocap import MocapSimSettings
from armtrack_cli.simulate.palm_session import PalmSimSettings

__all__ = ["info", "frame_count", "calibrate", "detect", "fuse", "compare", "report", "run",
           "run_many", "export",
           "STAGES", "simulate", "simulate_command", "ArmSimSettings", "PalmSimSettings",
           "MocapSimSettings", "simulate_from_mocap"]
