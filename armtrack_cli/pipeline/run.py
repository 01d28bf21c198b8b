"""The whole chain for one session: calibrate -> detect -> fuse -> compare (-> report), each
stage only when its inputs exist and are newer than its outputs, as make does; --force reruns.
A recipe file counts as an input of the stages that read it; --set values always rerun them."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from armtrack_cli.calibrate.board_pose import CalibrateSettings
from armtrack_cli.core.errors import ConfigError
from armtrack_cli.core.methods import BUILT, METHODS, PALM_METHODS
from armtrack_cli.detect.palm_blobs import PalmBlobSettings
from armtrack_cli.detect.patch_tracker import PatchSettings
from armtrack_cli.pipeline.apart import call_apart
from armtrack_cli.pipeline.calibrate import calibrate
from armtrack_cli.pipeline.common import out_dir, release_memory, resolve_recipe, settings_for
from armtrack_cli.session.config import Session, load_session
from armtrack_cli.session.depth import depth_path
from armtrack_cli.session.recipe import recipe_file, section
from armtrack_cli.session.workfolder import WorkFolder, newest

STAGES = ("calibrate", "detect", "fuse", "compare", "report")


@dataclass(frozen=True)
class Step:
    name: str  # "fuse ekf" for one method's fuse
    inputs: tuple  # session files and earlier outputs (None = not declared: always run)
    outputs: tuple[str, ...]  # in the work folder
    call: Callable[[], dict[str, Any]]
    settings: bool = False  # reads the recipe and --set
    apart: bool = False  # runs in a child process: nothing of its own to free in this one


def _methods(session: Session, methods, recipe, sets) -> tuple[str, ...]:
    if methods:
        unknown = [m for m in methods if m not in METHODS]
        if unknown:
            raise ConfigError("--method", f"{unknown[0]!r} is not a method",
                              f"methods are {', '.join(METHODS)}")
        return tuple(methods)
    return (settings_for(recipe, sets, kind=session.kind)[0].method,)


def plan(session: Session, work: WorkFolder, *, methods: tuple[str, ...], recipe, sets,
         seed: int | None) -> list[Step]:
    """The steps for this session, in order; a stage whose section is absent is left out."""
    cam = session.camera
    toml, rec = session.toml_path, recipe_file(recipe)
    video = cam.video if cam is not None else None
    steps = [Step("calibrate", (toml, video, cam.intrinsics if cam else None,
                                depth_path(session.root, 0) if session.palm else toml),
                  ("camera.yaml",) + (("palm.toml",) if session.palm else ()),
                  lambda: calibrate(session.root, out=work.path, recipe=recipe, sets=sets), True),
             Step("detect", (toml, video), ("detections.csv",),  # in a process of its own:
                  # its kernels and decoder do not stay for fuse (pipeline/apart.py)
                  lambda: call_apart("armtrack_cli.pipeline.detect", "detect", session.root,
                                     out=work.path, recipe=recipe, sets=sets), True, True)]
    for m in methods:
        reads = (work / "palm.toml",) if m in PALM_METHODS else (
            session.imu.file if session.imu is not None else None,)
        steps.append(Step(f"fuse {m}", (toml, *reads, work / "camera.yaml", work / "detections.csv"),
                          (f"trajectory-{m}.csv", f"kinematics-{m}.csv"),
                          lambda m=m: _stage("fuse")(session.root, method=m, seed=seed,
                                                     recipe=recipe, sets=sets, out=work.path),
                          True))
    if session.groundtruth is not None and methods:
        traj = tuple(work / f"{k}-{m}.csv" for m in methods for k in ("trajectory", "kinematics"))
        steps.append(Step("compare", (toml, session.groundtruth.file, *traj),
                          ("errors.csv", "measures.csv"),
                          lambda: _stage("compare")(session.root, methods=methods,
                                                    out=work.path)))
    made = tuple(work / n for st in steps[2:] for n in st.outputs)  # fuse's and compare's
    steps.append(Step("report", (toml, *made), ("report.pdf",),
                      lambda: _report([(session.root, work.path)])))
    return [s if not (s.settings and rec) else Step(s.name, (*s.inputs, rec), s.outputs, s.call,
                                                    s.settings, s.apart) for s in steps]


def _stage(name: str) -> Callable[..., dict[str, Any]]:
    """fuse or compare, imported when its step runs: numba and scipy are not in this process
    while detect runs beside it in its own (pipeline/apart.py; about 25 MB of anonymous
    memory held meanwhile, issue 15)."""
    import importlib

    return getattr(importlib.import_module(f"armtrack_cli.pipeline.{name}"), name)


def _report(pairs) -> dict[str, Any]:
    from armtrack_cli.pipeline.report import report  # matplotlib: only when a report is made

    return report(pairs)


def check_settings(recipe: str | None, sets: tuple[str, ...]) -> None:
    """Every stage's settings from the recipe and --set, checked before any stage runs, so a
    bad value stops the run before it has rewritten anything."""
    doc, where = resolve_recipe(recipe, sets)
    for name, cls in (("calibrate", CalibrateSettings), ("detect.patch", PatchSettings),
                      ("detect.palm", PalmBlobSettings)):
        section(doc, name, cls, where)
    settings_for(recipe, sets)


def _stale(step: Step, work: WorkFolder, *, force: bool, sets) -> bool:
    if force or (step.settings and sets) or any(p is None for p in step.inputs):
        return True
    made, needed = work.oldest(step.outputs), newest(step.inputs)
    return made is None or needed is None or needed > made


def run(session: str | Path, *, through: str = "report", methods: tuple[str, ...] = (),
        recipe: str | None = None, sets: tuple[str, ...] = (), out: str | Path | None = None,
        force: bool = False, seed: int | None = None) -> dict[str, Any]:
    """Every stage of one session through ``through``; returns what each stage did."""
    if through not in STAGES:
        raise ConfigError("--through", f"{through!r} is not a stage", f"stages are {', '.join(STAGES)}")
    s = load_session(session)
    check_settings(recipe, sets)
    work = WorkFolder(out_dir(s, out))
    chosen = _methods(s, methods, recipe, sets)
    last = STAGES.index(through)
    stages, results = {}, {}
    for step in plan(s, work, methods=tuple(m for m in chosen if m in BUILT), recipe=recipe,
                     sets=sets, seed=seed):
        if STAGES.index(step.name.split()[0]) > last:
            break
        if _stale(step, work, force=force, sets=sets):
            results[step.name] = step.call()
            stages[step.name] = "ran"
            if not step.apart:  # a full collection costs 40-100 ms with numba's objects
                release_memory()
        else:
            stages[step.name] = "up to date"
    for m in chosen:
        if m not in BUILT:
            stages[f"fuse {m}"] = "not in this version yet"
    return {"session": str(s.root), "out": str(work.path), "methods": list(chosen),
            "stages": stages, "results": results}
