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
