"""Running a command over one session or a folder of sessions, and what it prints while it
works: the batch loop, JSON or text summaries, and a progress bar on a terminal."""

from __future__ import annotations

import json
import os
import sys

import click

from armtrack_cli.core.errors import ArmtrackError
from armtrack_cli.session.files import misnamed_session_toml


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
                          if os.path.isfile(os.path.join(item, d, "session.toml"))
                          or misnamed_session_toml(os.path.join(item, d)))  # its error told
            out.extend(subs or [item])
        else:
            out.append(item)
    return out


def out_for(out_dir, folder, sessions) -> str | None:
    """--out DIR: that folder for one session; DIR/SESSION_NAME for several, which must
    differ: two sessions of one folder name (S01/pre and S02/pre) would share a work folder,
    the second taking the first's outputs as its own."""
    if out_dir is None:
        return None
    folders = expand(sessions)
    if len(folders) == 1:
        return out_dir
    seen: dict[str, str] = {}
    for f in folders:
        other = seen.setdefault(_name(f), f)
        if other != f:
            same = os.path.realpath(other) == os.path.realpath(f)
            raise click.BadParameter(
                f"{other} is given twice" if same else
                f"sessions {other} and {f} would share the work folder "
                f"{os.path.join(out_dir, _name(f))}; give them folder names of their own, or "
                "run each with its own --out", param_hint="--out")
    return os.path.join(out_dir, _name(folder))


def _name(folder) -> str:
    return os.path.basename(os.path.abspath(str(folder)))


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




def cohort_run(folders, sessions, out_dir, as_json: bool, run_many, options: dict, *,
               workers: int, scheduler: str | None) -> None:
    """`armtrack run` over many sessions (locally or on Dask): a progress bar over sessions,
    one ``error:`` line per failed session, cohort.csv, and the summary line; exit 1 if any
    failed. cohort.csv goes to --out DIR, else the folder the sessions are in."""
    from armtrack_cli.pipeline.batch import summary, write_cohort

    outs = [out_for(out_dir, f, sessions) for f in folders]
    with progress(len(folders), "sessions", quiet=as_json) as bar:
        def done(rows):
            r = rows[0]
            if r["status"] == "failed":
                click.echo(f"error: {r['error']}", err=True)
            elif not as_json:
                click.echo(f"{r['session']}: {r['status']} ({r.get('stages_run', 0)} stages ran)")
            for w in filter(None, (r.get("warnings") or "").split(" | ")):
                click.echo(f"warning: {w}", err=True)
            bar(bar.done + 1)
        rows = run_many(folders, outs, workers=workers, scheduler=scheduler, on_done=done,
                        **options)
    parents = {os.path.dirname(os.path.abspath(str(f).rstrip("/"))) for f in folders}
    where = out_dir or (parents.pop() if len(parents) == 1 else ".")
    cohort = write_cohort(os.path.join(where, "cohort.csv"), rows)
    line, failed = summary(rows)
    if as_json:
        clean = [{k: None if isinstance(v, float) and v != v else v for k, v in r.items()}
                 for r in rows]  # JSON has no NaN
        click.echo(json.dumps({"sessions": clean, "cohort": str(cohort), "summary": line},
                              indent=2, sort_keys=True, default=str))
    else:
        click.echo(f"-> {cohort}")
        click.echo(line)
    if failed:
        raise click.exceptions.Exit(1)
