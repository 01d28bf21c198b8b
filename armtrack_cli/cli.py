"""The `armtrack` command line: thin click commands over ``pipeline`` (the only click importer).

Exit codes: 0 success; 1 bad data, printed as one line ``error: FILE: what is wrong`` (no
traceback); 2 bad usage (click's own).
"""

from __future__ import annotations

import json
import os
import sys
import traceback

import click
import numpy as np

from armtrack_cli import __version__, pipeline
from armtrack_cli.core.errors import ArmtrackError


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
            ctx.exit(1)
        except Exception as exc:  # a bug of ours: still one line, traceback on request
            if os.environ.get("ARMTRACK_DEBUG"):
                traceback.print_exc()
            click.echo(f"error: internal error ({type(exc).__name__}: {exc}); rerun with "
                       "ARMTRACK_DEBUG=1 for the traceback and please report it", err=True)
            ctx.exit(1)


CONTEXT = {"help_option_names": ["-h", "--help"], "max_content_width": 100}
out_option = click.option("--out", "out_dir", type=click.Path(file_okay=False),
                          help="Write outputs here instead of SESSION/armtrack/.")
recipe_option = click.option("--recipe", help="Recipe name in recipes/ (e.g. default) or a TOML "
                             "path; settings resolve as defaults < recipe < --set.")
set_option = click.option("--set", "sets", multiple=True, metavar="KEY=VALUE",
                          help="Override one recipe setting, e.g. detect.patch.move_px=15 "
                          "(repeatable).")
json_option = click.option("--json", "as_json", is_flag=True, help="Print a JSON summary for scripts.")


def _emit(result: dict, as_json: bool, lines: list[str]) -> None:
    if as_json:
        click.echo(json.dumps(result, indent=2, sort_keys=True))
    else:
        click.echo("\n".join(lines))


def _parse_pixels(spec: str) -> np.ndarray:
    """'u1,v1;u2,v2;…' -> (k, 2) array."""
    try:
        pts = [tuple(float(x) for x in p.split(",")) for p in spec.replace(" ", "").split(";") if p]
        arr = np.array(pts, float)
        if arr.ndim != 2 or arr.shape[1] != 2:
            raise ValueError
        return arr
    except ValueError:
        raise click.BadParameter(f"{spec!r} is not 'u,v;u,v;…' in the [palm] markers order",
                                 param_hint="--markers") from None


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
@click.option("--imu-rate", "imu_rate", type=click.FloatRange(min=1.0, max=10000.0),
              help="IMU rate in Hz for exports that state none (as [imu] rate_hz does).")
@out_option
def info(session: str, as_json: bool, imu_rate: float | None, out_dir: str | None) -> None:
    """What SESSION holds: streams, rates, spans on the session clock, gaps, markers, and
    what each method still needs.

    SESSION is a session folder, or a single recorded file (IMU export, Qualisys TSV, video).
    """
    result = pipeline.info(session, imu_rate_hz=imu_rate, out_dir=out_dir)
    if as_json:
        click.echo(json.dumps(result, indent=2, sort_keys=True))
    else:
        click.echo(pipeline.format_info(result))


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
    px = _parse_pixels(markers) if markers else None
    for folder in _expand(sessions):
        r = pipeline.calibrate(folder, frame=frame, markers_px=px, out=_out_for(out_dir, folder,
                                                                               sessions),
                               recipe=recipe, sets=sets)
        lines = [f"{folder}: board in frame {r['frame']}: {r['corners']} corners, reprojection "
                 f"error {r['reprojection_error_px']:.3f} px",
                 f"  camera at {r['camera_position_m']} m in W -> {r['camera_yaml']}"]
        if "intrinsics_rms_px" in r:
            lines.insert(0, f"{folder}: intrinsics from {r['views_used']} board images, RMS "
                         f"{r['intrinsics_rms_px']:.3f} px")
        if "palm_toml" in r:
            lines.append(f"  palm model -> {r['palm_toml']} (link residuals "
                         f"{r['palm_link_residual_cm']} cm)")
        _emit(r, as_json, lines)


@main.command()
@click.argument("sessions", nargs=-1, required=True, type=click.Path())
@recipe_option
@set_option
@json_option
@out_option
def detect(sessions, recipe, sets, as_json, out_dir) -> None:
    """The wrist patch in every frame (CamShift), or every palm-marker candidate blob,
    written to detections.csv."""
    for folder in _expand(sessions):
        n = pipeline.frame_count(folder) if not as_json else 0
        with _progress(n, f"detect {os.path.basename(str(folder).rstrip('/'))}",
                       quiet=as_json) as bar:
            r = pipeline.detect(folder, out=_out_for(out_dir, folder, sessions), recipe=recipe,
                                sets=sets, on_frame=bar)
        if r["kind"] == "patch":
            line = (f"{folder}: patch found in {r['ok_frames']} of {r['frames']} frames, "
                    f"{r['lost_spans']} losses (longest {r['longest_loss_s']} s)")
        else:
            line = f"{folder}: {r['blobs']} candidate blobs in {r['frames']} frames"
        _emit(r, as_json, [line + f", {r['frames_per_s']:.0f} frames/s -> {r['detections']}"])


METHOD_CHOICE = click.Choice(["inertial", "ekf", "ukf", "pf", "pf-constraint", "ukf-palm"])


@main.command()
@click.argument("sessions", nargs=-1, required=True, type=click.Path())
@recipe_option
@click.option("--method", type=METHOD_CHOICE, help="Fusion method (overrides the recipe's).")
@click.option("--particles", type=click.IntRange(min=10), help="Particles (PF methods).")
@click.option("--seed", type=int, help="Random seed (same seed, same bytes).")
@set_option
@json_option
@out_option
def fuse(sessions, recipe, method, particles, seed, sets, as_json, out_dir) -> None:
    """IMU and camera detections fused into wrist and elbow trajectories
    (trajectory-METHOD.csv) and their clinical measures (kinematics-METHOD.csv).

    Without --method or --recipe the method is pf-constraint, Tao & Hu's layered particle
    filter with the arm-geometry constraint.
    """
    for folder in _expand(sessions):
        r = pipeline.fuse(folder, method=method, particles=particles, seed=seed, recipe=recipe,
                          sets=sets, out=_out_for(out_dir, folder, sessions))
        _emit(r, as_json, [f"{folder}: {r['method']}: {r['frames']} frames "
                           f"({r['detections_used']} with a detection), "
                           f"{r['frames_per_s']:.0f} frames/s -> {r['trajectory']}"]
              + ([f"  initialised from {r['initialised_from']}: residual "
                  f"{r['init_residual_px']} px, {r['init_residual_mm']} mm"]
                 if "init_residual_px" in r else []))


@main.command()
@click.argument("sessions", nargs=-1, required=True, type=click.Path())
@click.option("--method", "methods", type=METHOD_CHOICE, multiple=True,
              help="Methods to score (repeatable); default: every trajectory present.")
@json_option
@out_option
def compare(sessions, methods, as_json, out_dir) -> None:
    """Trajectories scored against Qualisys: errors.csv (per method, joint and axis: mean,
    SD, RMSE, max, % within ±5 cm) and measures.csv; prints Tao & Hu's Table I."""
    for folder in _expand(sessions):
        r = pipeline.compare(folder, methods=tuple(methods),
                             out=_out_for(out_dir, folder, sessions))
        excl = {k: v for k, v in r["excluded_frames"].items() if v}
        lines = [f"{folder}:", r["table"]]
        if excl:
            lines.append("frames without ground truth (gaps), excluded: " +
                         ", ".join(f"{k} {v}" for k, v in excl.items()))
        lines.append(f"-> {r['errors']}, {r['measures']}")
        r = {k: v for k, v in r.items() if k not in ("rows", "table")}
        _emit(r, as_json, lines)


def _parse_hide(spec: str) -> tuple[int, float, float]:
    try:
        k, a, d = spec.split(":")
        if not 0 <= int(k) <= 5:
            raise ValueError
        return int(k), float(a), float(d)
    except ValueError:
        raise click.BadParameter(f"{spec!r} is not MARKER:START:DURATION (MARKER 0-5)",
                                 param_hint="--hide") from None


def _expand(items) -> list[str]:
    """Session folders: each argument, or the session folders inside a folder of sessions."""
    out = []
    for item in items:
        if os.path.isdir(item) and not os.path.exists(os.path.join(item, "session.toml")):
            subs = sorted(os.path.join(item, d) for d in os.listdir(item)
                          if os.path.isfile(os.path.join(item, d, "session.toml")))
            out.extend(subs or [item])
        else:
            out.append(item)
    return out


def _out_for(out_dir, folder, sessions) -> str | None:
    """--out DIR: that folder for one session; DIR/SESSION_NAME for several."""
    if out_dir is None:
        return None
    if len(_expand(sessions)) == 1:
        return out_dir
    return os.path.join(out_dir, os.path.basename(str(folder).rstrip("/")))


@main.command()
@click.argument("out", type=click.Path(file_okay=False))
@click.option("--task", type=click.Choice(["circle", "rectangle", "reach", "figure8", "wrist-rom",
                                           "reach-grasp"]),
              default="circle", show_default=True,
              help="Task: the first four are arm sessions (IMU + patch), wrist-rom and reach-grasp "
              "palm-marker sessions with depth.")
@click.option("--seed", type=int, default=0, show_default=True, help="Random seed (same seed, "
              "same bytes).")
@click.option("--duration", type=click.FloatRange(min=4.0, max=3600.0), default=20.0,
              show_default=True, help="Length of the video, s.")
@click.option("--imu-format", type=click.Choice(["xsens", "csv", "mcap"]), default="xsens",
              show_default=True, help="IMU file written: Xsens MT Manager export, generic CSV, "
              "ROS 2 MCAP.")
@click.option("--imu-preset", type=click.Choice(["mtw", "consumer", "ideal"]), default="mtw",
              show_default=True, help="IMU error levels: MTw-class, consumer-grade, or none.")
@click.option("--acc-noise", type=float, help="Override: accelerometer white noise, m/s².")
@click.option("--acc-bias", type=float, help="Override: accelerometer bias per axis, m/s².")
@click.option("--gyro-noise", type=float, help="Override: gyro white noise, rad/s.")
@click.option("--gyro-bias", type=float, help="Override: gyro bias per axis, rad/s.")
@click.option("--orientation-error", "orientation_rms_deg", type=float,
              help="Override: RMS error of the output orientation, degrees.")
@click.option("--drop-rate", type=click.FloatRange(0.0, 0.5), default=0.0, show_default=True,
              help="Fraction of IMU packets dropped, in bursts.")
@click.option("--fps", type=click.FloatRange(min=1.0, max=240.0), default=30.0, show_default=True)
@click.option("--imu-rate", type=click.FloatRange(min=20.0, max=1000.0), default=100.0,
              show_default=True, help="IMU rate, Hz.")
@click.option("--qualisys-hz", type=click.Choice(["100", "200"]), default="100", show_default=True)
@click.option("--gt-gaps", type=click.IntRange(0, 50), default=0, show_default=True,
              help="Gaps of 0.1-0.4 s in the Qualisys wrist marker.")
@click.option("--distractor", is_flag=True, help="A disc of the patch's hue on the table.")
@click.option("--occlusion", "occlusions", multiple=True, metavar="START:DURATION",
              help="A card hides the patch from START for DURATION seconds (repeatable).")
@click.option("--no-distortion", is_flag=True, help="An ideal pinhole lens.")
@click.option("--calib-images", type=click.IntRange(0, 60), default=0, show_default=True,
              help="Also film the board from N angles into calib/ (intrinsics = \"calib/\").")
@click.option("--undeclared-imu-offset", is_flag=True,
              help="Write imu_offset_s = \"auto\" (the truth file keeps the real offset).")
@click.option("--hide", "hides", multiple=True, metavar="MARKER:START:DURATION",
              help="Palm tasks: hide palm marker MARKER (index 0-5) from START for DURATION s.")
@click.option("--clutter2", type=click.FloatRange(min=0.0), metavar="START",
              help="Palm tasks: a second clutter blob appears beside the hand at START s.")
@click.option("--force", is_flag=True, help="Replace OUT if it exists.")
@click.option("--json", "as_json", is_flag=True, help="Print a JSON summary for scripts.")
@out_option
def simulate(out, task, seed, duration, imu_format, imu_preset, acc_noise, acc_bias, gyro_noise,
             gyro_bias, orientation_rms_deg, drop_rate, fps, imu_rate, qualisys_hz, gt_gaps,
             distractor, occlusions, no_distortion, calib_images, undeclared_imu_offset, hides,
             clutter2, force, as_json, out_dir) -> None:
    """Write a simulated session folder OUT (session.toml, video, IMU or depth frames,
    Qualisys, intrinsics) and its exact truth beside it as OUT.truth.npz."""
    occ = []
    for spec in occlusions:
        try:
            start, dur = (float(x) for x in spec.split(":"))
        except ValueError:
            raise click.BadParameter(f"{spec!r} is not START:DURATION",
                                     param_hint="--occlusion") from None
        occ.append((start, dur))
    errors = {"acc_noise": acc_noise, "acc_bias": acc_bias, "gyro_noise": gyro_noise,
              "gyro_bias": gyro_bias, "orientation_rms_deg": orientation_rms_deg}
    if task in ("wrist-rom", "reach-grasp"):
        settings = pipeline.PalmSimSettings(task=task, seed=seed, duration_s=duration, fps=fps,
                                   qualisys_hz=float(qualisys_hz), gt_gaps=gt_gaps,
                                   distortion=not no_distortion, calib_images=calib_images,
                                   hide=tuple(_parse_hide(h) for h in hides), clutter2_s=clutter2)
    else:
        settings = pipeline.ArmSimSettings(
            task=task, seed=seed, duration_s=duration, fps=fps, imu_rate_hz=imu_rate,
            imu_preset=imu_preset, imu_errors={k: v for k, v in errors.items() if v is not None},
            drop_rate=drop_rate, qualisys_hz=float(qualisys_hz), gt_gaps=gt_gaps,
            distractor=distractor, occlusions=tuple(occ), distortion=not no_distortion,
            declare_imu_offset=not undeclared_imu_offset, calib_images=calib_images)
    target = os.path.join(out_dir, os.path.basename(out)) if out_dir else out
    n_frames = int(round(duration * fps))
    with _progress(n_frames, "rendering", quiet=as_json) as bar:
        result = pipeline.simulate(target, settings, imu_format=imu_format, force=force,
                                   on_frame=bar)
    if as_json:
        click.echo(json.dumps(result, indent=2, sort_keys=True))
    else:
        extra = (f"{result['imu_samples']} IMU samples" if "imu_samples" in result else
                 f"{result['depth_frames']} depth frames")
        click.echo(f"wrote {result['session']} ({result['frames']} frames, {extra}, "
                   f"{result['qualisys_frames']} Qualisys frames) and {result['truth']}")


class _progress:
    """A progress bar on stderr when it is a terminal (quiet in CI, pipes and --json)."""

    def __init__(self, total: int, label: str, *, quiet: bool = False):
        self.total, self.label = total, label
        self.enabled = not quiet and sys.stderr.isatty() and not os.environ.get("CI")
        self.bar = None
        self.done = 0

    def __enter__(self):
        if self.enabled:
            self.bar = click.progressbar(length=self.total, label=self.label, file=sys.stderr)
            self.bar.__enter__()
        return self

    def __call__(self, n: int) -> None:
        if self.bar is not None:
            self.bar.update(n - self.done)
        self.done = n

    def __exit__(self, *exc):
        if self.bar is not None:
            self.bar.__exit__(*exc)
        return False


def render_reference() -> str:
    """docs/cli.md: every command's --help, generated (a test keeps it in step)."""
    parts = ["# armtrack command-line reference", "",
             "Generated from `--help` by `make docs`; do not edit by hand.", ""]
    root = click.Context(main, info_name="armtrack", terminal_width=100, **CONTEXT)
    parts += ["## armtrack", "", "```", main.get_help(root), "```", ""]
    for name in sorted(main.commands):
        cmd = main.commands[name]
        ctx = click.Context(cmd, info_name=name, parent=root, terminal_width=100, **CONTEXT)
        parts += [f"## armtrack {name}", "", "```", cmd.get_help(ctx), "```", ""]
    return "\n".join(parts)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
