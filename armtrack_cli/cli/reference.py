"""docs/cli.md, generated from every command's --help."""

from __future__ import annotations

import click

from armtrack_cli.cli.commands import CONTEXT, main


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

