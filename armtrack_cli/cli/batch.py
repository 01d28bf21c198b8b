"""Running a command over one session or a folder of sessions, and what it prints while it
works: the batch loop, JSON or text summaries, and a progress bar on a terminal."""

from __future__ import annotations

import json
import os
import sys

import click

from armtrack_cli.core.errors import ArmtrackError


def emit(result: dict, as_json: bool, lines: list[str]) -> None:
    if as_json:
        click.echo(json.dumps(result, indent=2, sort_keys=True))
    else:
        click.echo("\n".join(lines))


def each(sessions, out_dir, as_json: bool, work) -> None:
    """Run ``work(folder, out) -> (result, lines)`` on every session. One session: its error
    propagates (one line, exit 1). Several: a failure is one ``error:`` line and the others go
    on; a summary line at the end; exit 1 if any failed."""
    folders = expand(sessions)
    if len(folders) == 1:
        result, lines = work(folders[0], out_for(out_dir, folders[0], sessions))
        emit(result, as_json, lines)
        return
    outcomes, failed = [], 0
    for folder in folders:
        try:
            result, lines = work(folder, out_for(out_dir, folder, sessions))
        except ArmtrackError as exc:
            failed += 1
            click.echo(f"error: {exc}", err=True)
            outcomes.append({"session": folder, "status": "failed", "error": str(exc)})
            continue
        if not as_json:
            click.echo("\n".join(lines))
        outcomes.append({"session": folder, "status": "done", **result})
    summary = f"{len(folders)} sessions: {len(folders) - failed} done, {failed} failed"
    if as_json:
        click.echo(json.dumps({"sessions": outcomes, "summary": summary}, indent=2, sort_keys=True))
    else:
        click.echo(summary)
    if failed:
        raise click.exceptions.Exit(1)


def expand(items) -> list[str]:
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


def out_for(out_dir, folder, sessions) -> str | None:
    """--out DIR: that folder for one session; DIR/SESSION_NAME for several."""
    if out_dir is None:
        return None
    if len(expand(sessions)) == 1:
        return out_dir
    return os.path.join(out_dir, os.path.basename(str(folder).rstrip("/")))


class progress:
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


