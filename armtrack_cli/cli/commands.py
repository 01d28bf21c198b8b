"""The `armtrack` commands: thin click wrappers over ``pipeline``.

Exit codes: 0 success; 1 bad data, printed as one line ``error: FILE: what is wrong`` (no
traceback); 2 bad usage (click's own); 130 interrupted.
"""

from __future__ import annotations

import json
import os
import traceback

import click

from armtrack_cli import __version__
from armtrack_cli.cli import text
from armtrack_cli.cli.batch import cohort_run, each, emit, expand, out_for, progress
from armtrack_cli.cli.params import Finite, parse_hide, parse_pixels
from armtrack_cli.core.errors import ArmtrackError, DescribedError
from armtrack_cli.core.limits import MAX_PARTICLES
from armtrack_cli.core.methods import BUILT, METHODS
from armtrack_cli.simulate.tasks import ARM_TASKS, HAND_TASKS

# Heavy libraries (OpenCV, SciPy, pandas, matplotlib) are imported by the pipeline, which each
# command imports when it runs: `armtrack --help` and a shell script's calls start at once.


class _Group(click.Group):
    """Turns armtrack's errors into one line on stderr and exit code 1."""

    def invoke(self, ctx: click.Context):
        try:
            return super().invoke(ctx)
        except ArmtrackError as exc:
            click.echo(f"error: {exc}", err=True)
            ctx.exit(1)
        except (click.exceptions.Exit, click.exceptions.Abort, click.ClickException):
            raise
        except KeyboardInterrupt:
            click.echo("error: interrupted", err=True)
            ctx.exit(130)
        except Exception as exc:  # a bug of ours: still one line, traceback on request
            if _interrupted(exc):  # Ctrl-C inside a compiled kernel: numba's SystemError
                click.echo("error: interrupted", err=True)
                ctx.exit(130)
            if os.environ.get("ARMTRACK_DEBUG"):
                traceback.print_exc()
            click.echo(f"error: internal error ({type(exc).__name__}: {exc}); rerun with "
                       "ARMTRACK_DEBUG=1 for the traceback and please report it", err=True)
            ctx.exit(1)


def _interrupted(exc: BaseException) -> bool:
    """Whether ``exc`` was caused by a Ctrl-C: numba turns a KeyboardInterrupt raised while a
    compiled function runs into ``SystemError: CPUDispatcher(…) returned a result with an
    exception set``, the interrupt its cause."""
    seen: set[int] = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


CONTEXT = {"help_option_names": ["-h", "--help"], "max_content_width": 100}
out_option = click.option("--out", "out_dir", type=click.Path(file_okay=False),
                          help="Work folder: read earlier stages' outputs from it and write this "
                          "stage's outputs to it; default SESSION/armtrack/ (with several "
                          "sessions, DIR/SESSION_NAME/).")
recipe_option = click.option("--recipe", help="Recipe name in recipes/ (e.g. default) or a TOML "
                             "path; settings resolve as defaults < recipe < --set.")
set_option = click.option("--set", "sets", multiple=True, metavar="KEY=VALUE",
                          help="Override one recipe setting, e.g. detect.patch.move_px=15 "
                          "(repeatable).")
json_option = click.option("--json", "as_json", is_flag=True, help="Print a JSON summary for scripts.")


@click.group(cls=_Group, context_settings=CONTEXT)
@click.version_option(__version__, prog_name="armtrack")
def main() -> None:
    """Arm and wrist trajectories from a wrist IMU and one camera.

    A session folder holds session.toml, the video, the IMU export and optionally a Qualisys
    TSV (see docs/recording-guide.md). Commands run in the order of the data flow:
    calibrate -> detect -> fuse -> compare -> report; `info` tells what a session holds.
    """


@main.command()
@click.argument("session", type=click.Path(exists=False))
@click.option("--json", "as_json", is_flag=True, help="Print a JSON summary for scripts.")
@click.option("--imu-rate", "imu_rate", type=Finite(min=1.0, max=10000.0),
              help="IMU rate in Hz for exports that state none (as [imu] rate_hz does).")
@out_option
def info(session: str, as_json: bool, imu_rate: float | None, out_dir: str | None) -> None:
    """What SESSION holds: streams, rates, spans on the session clock, gaps, markers, and
    what each method still needs.

    SESSION is a session folder, or a single recorded file (IMU export, Qualisys TSV, video).
    """
    from armtrack_cli import pipeline

    def show(result: dict) -> None:
        click.echo(json.dumps(result, indent=2, sort_keys=True) if as_json else
                   text.info_text(result))

    try:
        result = pipeline.info(session, imu_rate_hz=imu_rate, out_dir=out_dir)
    except DescribedError as exc:  # info describes, lists each problem, then fails as compare would
        show(exc.described)
        raise
    show(result)


@main.command()
@click.argument("sessions", nargs=-1, required=True, type=click.Path())
@click.option("--frame", type=click.IntRange(min=0), default=0, show_default=True,
              help="Video frame in which the board lies on the table (and the hand is neutral).")
@click.option("--markers", "markers", help="Palm sessions: the six markers' pixels 'u,v;u,v;…' in "
              "the [palm] markers order, when automatic labelling is unsure.")
@recipe_option
@set_option
@json_option
@out_option
def calibrate(sessions, frame, markers, recipe, sets, as_json, out_dir) -> None:
    """The camera's pose in W from the ChArUco board in frame N (intrinsics from
    intrinsics.yaml or from board images in calib/), written to camera.yaml; for palm sessions
    also the palm model (palm.toml)."""
    px = parse_pixels(markers) if markers else None

    from armtrack_cli import pipeline

    def work(folder, out):
        r = pipeline.calibrate(folder, frame=frame, markers_px=px, out=out, recipe=recipe,
                               sets=sets)
        return r, text.calibrate_lines(folder, r)

    each(sessions, out_dir, as_json, work)


@main.command()
@click.argument("sessions", nargs=-1, required=True, type=click.Path())
@recipe_option
@set_option
@json_option
@out_option
def detect(sessions, recipe, sets, as_json, out_dir) -> None:
    """The wrist patch in every frame (CamShift), or every palm-marker candidate blob,
    written to detections.csv."""
    from armtrack_cli import pipeline

    def work(folder, out):
        n = pipeline.frame_count(folder) if not as_json else 0
        with progress(n, f"detect {os.path.basename(str(folder).rstrip('/'))}",
                      quiet=as_json) as bar:
            r = pipeline.detect(folder, out=out, recipe=recipe, sets=sets, on_frame=bar)
        return r, text.detect_lines(folder, r)

    each(sessions, out_dir, as_json, work)


METHOD_CHOICE = click.Choice(list(BUILT))


@main.command()
@click.argument("sessions", nargs=-1, required=True, type=click.Path())
@recipe_option
@click.option("--method", type=METHOD_CHOICE, help="Fusion method (overrides the recipe's).")
@click.option("--particles", type=click.IntRange(min=10, max=MAX_PARTICLES),
              help=f"Particles (PF methods), 10 to {MAX_PARTICLES:,}.")
@click.option("--seed", type=click.IntRange(min=0), help="Random seed (same seed, same bytes).")
@set_option
@json_option
@out_option
def fuse(sessions, recipe, method, particles, seed, sets, as_json, out_dir) -> None:
    """IMU and camera detections fused into wrist and elbow trajectories
    (trajectory-METHOD.csv) and their clinical measures (kinematics-METHOD.csv).

    Without --method or --recipe the method is arm-smoother: Tao & Hu's models and arm
    constraint over the whole session, with the IMU's orientation error and accelerometer
    bias estimated (docs/fusion.md); --recipe tao2008-pf-constraint is the paper's filter.
    """
    from armtrack_cli import pipeline

    def work(folder, out):
        r = pipeline.fuse(folder, method=method, particles=particles, seed=seed, recipe=recipe,
                          sets=sets, out=out)
        return r, text.fuse_lines(folder, r)

    each(sessions, out_dir, as_json, work)


@main.command()
@click.argument("sessions", nargs=-1, required=True, type=click.Path())
@click.option("--method", "methods", type=METHOD_CHOICE, multiple=True,
              help="Methods to score (repeatable); default: every trajectory present.")
@json_option
@out_option
def compare(sessions, methods, as_json, out_dir) -> None:
    """Trajectories scored against Qualisys: errors.csv (per method, joint and axis: mean,
    SD, RMSE, max, % within ±5 cm) and measures.csv; prints Tao & Hu's Table I."""
    from armtrack_cli import pipeline

    def work(folder, out):
        r = pipeline.compare(folder, methods=tuple(methods), out=out)
        return text.compare_summary(r), text.compare_lines(folder, r)

    each(sessions, out_dir, as_json, work)


@main.command()
@click.argument("sessions", nargs=-1, required=True, type=click.Path())
@click.option("-o", "--output", type=click.Path(dir_okay=False), help="The PDF to write "
              "(default: report.pdf in the work folder of the latest session).")
@json_option
@out_option
def report(sessions, output, as_json, out_dir) -> None:
    """The clinician PDF (A4): page 1 in plain words, trajectories, accuracy against the
    reference, wrist angles; several sessions of one subject make one report with their
    progress."""
    from armtrack_cli import pipeline

    folders = expand(sessions)
    r = pipeline.report([(f, out_for(out_dir, f, sessions)) for f in folders], output=output)
    emit(r, as_json, [f"{', '.join(r['sessions'])} -> {r['report']}"])


@main.command()
@click.argument("sessions", nargs=-1, required=True, type=click.Path())
@click.option("--through", type=click.Choice(["calibrate", "detect", "fuse", "compare", "report"]),
              default="report", show_default=True, help="The last stage to run.")
@click.option("--method", "methods", type=click.Choice(list(METHODS)), multiple=True,
              help="Fusion methods (repeatable); default: the recipe's, else the session "
              "kind's (arm-smoother for arm sessions, ukf-palm for palm sessions).")
@recipe_option
@click.option("--seed", type=click.IntRange(min=0), help="Random seed (same seed, same bytes).")
@set_option
@click.option("--force", is_flag=True, help="Rerun every stage, even those up to date.")
@click.option("--workers", type=click.IntRange(min=1), default=1, show_default=True,
              help="Sessions run at once, each a task on a local Dask cluster of N processes "
              "(needs armtrack[cluster] when N > 1).")
@click.option("--scheduler", metavar="ADDRESS", help="Run the sessions on this running "
              "dask.distributed scheduler (e.g. tcp://10.0.0.5:8786) instead.")
@json_option
@out_option
def run(sessions, through, methods, recipe, seed, sets, force, workers, scheduler, as_json,
        out_dir) -> None:
    """Every stage of each session in order: calibrate -> detect -> fuse -> compare (when
    the session has ground truth). A stage runs only when its inputs are newer than its
    outputs (as make does), so a rerun after a crash or an edit does only what is needed.
    Several sessions (or a folder of them) also write cohort.csv, one row per session."""
    from armtrack_cli import pipeline

    if scheduler is not None and workers != 1:
        raise click.UsageError("give --workers or --scheduler, not both")
    folders = expand(sessions)
    if len(folders) > 1 or workers > 1 or scheduler is not None:
        from armtrack_cli.pipeline.batch import run_many
        opts = {"through": through, "methods": tuple(methods), "recipe": recipe, "sets": sets,
                "force": force, "seed": seed}
        return cohort_run(folders, sessions, out_dir, as_json, run_many, opts, workers=workers,
                          scheduler=scheduler)

    def work(folder, out):
        r = pipeline.run(folder, through=through, methods=tuple(methods), recipe=recipe,
                         sets=sets, out=out, force=force, seed=seed)
        summary = {k: v for k, v in r.items() if k != "results"}
        return summary, text.run_lines(folder, r)

    each(sessions, out_dir, as_json, work)


@main.command()
@click.argument("sessions", nargs=-1, required=True, type=click.Path())
@click.option("--format", "fmt", type=click.Choice(["tum", "csv", "c3d"]), required=True,
              help="tum: `t x y z qx qy qz qw` for evo (estimate, and truth at the same frame "
              "times); csv: the same with a header; c3d: the estimated joints as markers.")
@click.option("--method", "methods", type=METHOD_CHOICE, multiple=True,
              help="Methods to export (repeatable); default: every trajectory present.")
@json_option
@out_option
def export(sessions, fmt, methods, as_json, out_dir) -> None:
    """Trajectories for other tools, into WORK/export/: TUM for evo_ape/evo_traj (check
    armtrack's errors with `evo_ape tum ekf-wrist.truth.tum ekf-wrist.tum`), CSV, or C3D."""
    from armtrack_cli.pipeline.export import export as export_session

    def work(folder, out):
        r = export_session(folder, fmt=fmt, methods=tuple(methods), out=out)
        return r, [f"{folder}: " + ", ".join(os.path.basename(w) for w in r["written"])]

    each(sessions, out_dir, as_json, work)


@main.command()
@click.argument("out", type=click.Path(file_okay=False))
@click.option("--task", type=click.Choice([*ARM_TASKS, *HAND_TASKS]),
              default="circle", show_default=True,
              help="Task: the first four are arm sessions (IMU + patch), the others "
              "palm-marker sessions with depth (wrist-deviation: ±25° radial/ulnar deviation, "
              "wrist-flexion: ±45° flexion-extension, each twice).")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True,
              help="Random seed (same seed, same bytes).")
@click.option("--duration", type=Finite(min=4.0, max=3600.0),
              help="Length of the video, s  [default: 20; with --from-mocap the recording's].")
@click.option("--imu-format", type=click.Choice(["xsens", "csv", "mcap"]), default="xsens",
              show_default=True, help="IMU file written: Xsens MT Manager export, generic CSV, "
              "ROS 2 MCAP.")
@click.option("--imu-preset", type=click.Choice(["mtw", "consumer", "ideal"]), default="mtw",
              show_default=True, help="IMU error levels: MTw-class, consumer-grade, or none.")
@click.option("--acc-noise", type=Finite(0.0, 10.0),
              help="Override: accelerometer white noise, m/s².")
@click.option("--acc-bias", type=Finite(0.0, 10.0),
              help="Override: accelerometer bias per axis, m/s².")
@click.option("--gyro-noise", type=Finite(0.0, 1.0), help="Override: gyro white noise, rad/s.")
@click.option("--gyro-bias", type=Finite(0.0, 1.0), help="Override: gyro bias per axis, rad/s.")
@click.option("--orientation-error", "orientation_rms_deg", type=Finite(0.0, 45.0),
              help="Override: RMS error of the output orientation, degrees.")
@click.option("--drop-rate", type=Finite(0.0, 0.5), default=0.0, show_default=True,
              help="Fraction of IMU packets dropped, in bursts.")
@click.option("--fps", type=Finite(min=1.0, max=240.0), default=30.0, show_default=True)
@click.option("--imu-rate", type=Finite(min=20.0, max=1000.0), default=100.0,
              show_default=True, help="IMU rate, Hz.")
@click.option("--qualisys-hz", type=click.Choice(["100", "200"]), default="100", show_default=True)
@click.option("--gt-gaps", type=click.IntRange(0, 50), default=0, show_default=True,
              help="Gaps of 0.1-0.4 s in the Qualisys wrist marker.")
@click.option("--distractor", is_flag=True, help="A disc of the patch's hue on the table.")
@click.option("--moving-distractor", is_flag=True,
              help="Arm tasks: the other arm, in a sleeve of the patch's hue, crossing over and "
              "near the patch from 3 s on.")
@click.option("--clutter", is_flag=True, help="Arm tasks: objects of many colours on the table.")
@click.option("--calibration-movement", "calibration_s", type=Finite(0.0, 60.0), default=0.0,
              metavar="SECONDS", help="Arm tasks: SECONDS of the calibration movement for "
              "[arm] \"auto\" (docs/recording-guide.md) after the first rest, then the task, "
              "all within --duration (e.g. --duration 28 --calibration-movement 8).")
@click.option("--occlusion", "occlusions", multiple=True, metavar="START:DURATION",
              help="A card hides the patch from START for DURATION seconds (repeatable).")
@click.option("--no-distortion", is_flag=True, help="An ideal pinhole lens.")
@click.option("--calib-images", type=click.IntRange(0, 60), default=0, show_default=True,
              help="Also film the board from N angles into calib/ (intrinsics = \"calib/\").")
@click.option("--recorded", type=click.DateTime(["%Y-%m-%dT%H:%M:%S", "%Y-%m-%d"]),
              help="When the session was recorded (arm tasks), e.g. 2026-11-27T10:15:00.")
@click.option("--undeclared-imu-offset", is_flag=True,
              help="Write imu_offset_s = \"auto\" (the truth file keeps the real offset).")
@click.option("--hide", "hides", multiple=True, metavar="MARKER:START:DURATION",
              help="Palm tasks: hide palm marker MARKER (index 0-5) from START for DURATION s.")
@click.option("--clutter2", type=Finite(0.0, 3600.0), metavar="START",
              help="Palm tasks: a second clutter blob appears beside the hand at START s.")
@click.option("--from-mocap", "mocap", type=click.Path(dir_okay=False), metavar="FILE",
              help="Follow a real recording (Vicon CSV, QTM TSV or C3D with technical "
              "clusters) instead of a task; --duration caps its length.")
@click.option("--static", type=click.Path(dir_okay=False), metavar="FILE",
              help="With --from-mocap: the static calibration trial (default: the one "
              "*static*.csv beside FILE).")
@click.option("--force", is_flag=True, help="Replace OUT if it exists.")
@click.option("--json", "as_json", is_flag=True, help="Print a JSON summary for scripts.")
@out_option
def simulate(out, task, seed, duration, imu_format, imu_preset, acc_noise, acc_bias, gyro_noise,
             gyro_bias, orientation_rms_deg, drop_rate, fps, imu_rate, qualisys_hz, gt_gaps,
             distractor, moving_distractor, clutter, calibration_s, occlusions, no_distortion,
             calib_images, recorded, undeclared_imu_offset, hides, clutter2, mocap, static, force,
             as_json, out_dir) -> None:
    """Write a simulated session folder OUT (session.toml, video, IMU or depth frames,
    Qualisys, intrinsics) and its exact truth beside it as OUT.truth.npz."""
    occ = []
    for spec in occlusions:
        try:
            start, dur = (float(x) for x in spec.split(":"))
            if not (0 <= start <= 3600 and 0 < dur <= 3600):
                raise ValueError
        except ValueError:
            raise click.BadParameter(f"{spec!r} is not START:DURATION (seconds, finite)",
                                     param_hint="--occlusion") from None
        occ.append((start, dur))
    from armtrack_cli import pipeline

    errors = {"acc_noise": acc_noise, "acc_bias": acc_bias, "gyro_noise": gyro_noise,
              "gyro_bias": gyro_bias, "orientation_rms_deg": orientation_rms_deg}
    target = os.path.join(out_dir, os.path.basename(out)) if out_dir else out
    if calibration_s and (mocap or task in HAND_TASKS):
        raise click.UsageError("--calibration-movement is for the arm tasks")
    if static and not mocap:
        raise click.UsageError("--static is the static trial of a --from-mocap recording")
    if mocap:
        ms = pipeline.MocapSimSettings(seed=seed, imu_preset=imu_preset, imu_errors={
            k: v for k, v in errors.items() if v is not None}, distortion=not no_distortion,
            **({"duration_s": duration} if duration else {}))
        result = pipeline.simulate_from_mocap(target, mocap, ms, static_path=static,
                                              imu_format=imu_format, force=force)
        emit(result, as_json, text.simulate_lines(result))
        return
    duration = duration or 20.0
    if task in HAND_TASKS:
        settings = pipeline.PalmSimSettings(task=task, seed=seed, duration_s=duration, fps=fps,
                                   qualisys_hz=float(qualisys_hz), gt_gaps=gt_gaps,
                                   distortion=not no_distortion, calib_images=calib_images,
                                   hide=tuple(parse_hide(h) for h in hides), clutter2_s=clutter2)
    else:
        settings = pipeline.ArmSimSettings(
            task=task, seed=seed, duration_s=duration, fps=fps, imu_rate_hz=imu_rate,
            imu_preset=imu_preset, imu_errors={k: v for k, v in errors.items() if v is not None},
            drop_rate=drop_rate, qualisys_hz=float(qualisys_hz), gt_gaps=gt_gaps,
            distractor=distractor, moving_distractor=moving_distractor, clutter=clutter,
            calibration_s=calibration_s, occlusions=tuple(occ), distortion=not no_distortion,
            declare_imu_offset=not undeclared_imu_offset, calib_images=calib_images,
            **({"recorded": recorded.strftime("%Y-%m-%dT%H:%M:%S")} if recorded else {}))
    if calibration_s and duration - calibration_s < 4.0:
        raise click.BadParameter(f"leaves the task under 4 s of the {duration:g} s session",
                                 param_hint="--calibration-movement")
    n_frames = int(round(duration * fps))
    with progress(n_frames, "rendering", quiet=as_json) as bar:
        result = pipeline.simulate(target, settings, imu_format=imu_format, force=force,
                                   on_frame=bar)
    emit(result, as_json, text.simulate_lines(result))

