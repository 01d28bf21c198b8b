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

import importlib
import sys
import types

# Each name is imported from its module when first used (PEP 562): a stage run in its own
# process (a shell script, `make bench`, a Dask worker) loads what that stage needs, not every
# stage's libraries (scipy.signal, pandas, numba, matplotlib: about 350 MB and seconds of
# import together).
_WHERE = {"run_many": "batch", "calibrate": "calibrate", "compare": "compare",
          "detect": "detect", "export": "export", "fuse": "fuse", "frame_count": "info",
          "info": "info", "simulate_from_mocap": "mocap", "report": "report", "STAGES": "run",
          "run": "run", "simulate": "simulate", "simulate_command": "simulate"}
_SETTINGS = {"ArmSimSettings": "armtrack_cli.simulate.arm_session",
             "MocapSimSettings": "armtrack_cli.simulate.from_mocap",
             "PalmSimSettings": "armtrack_cli.simulate.palm_session"}


def __getattr__(name: str):
    if name in _WHERE:
        module = importlib.import_module(f"armtrack_cli.pipeline.{_WHERE[name]}")
    elif name in _SETTINGS:
        module = importlib.import_module(_SETTINGS[name])
    else:
        raise AttributeError(f"module 'armtrack_cli.pipeline' has no attribute {name!r}")
    value = getattr(module, name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(__all__)


class _Package(types.ModuleType):
    """Binding a submodule whose name is also a function's here (pipeline.fuse, the module,
    and pipeline.fuse, the stage) binds the function: the import system sets the submodule
    on its package when it is first imported, wherever from."""

    def __setattr__(self, name, value):
        if isinstance(value, types.ModuleType) and _WHERE.get(name) == name:
            value = getattr(value, name)
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package


__all__ = ["info", "frame_count", "calibrate", "detect", "fuse", "compare", "report", "run",
           "run_many", "export",
           "STAGES", "simulate", "simulate_command", "ArmSimSettings", "PalmSimSettings",
           "MocapSimSettings", "simulate_from_mocap"]
