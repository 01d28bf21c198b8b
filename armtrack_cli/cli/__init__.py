"""The `armtrack` command line (the only package that imports click)."""

from armtrack_cli.cli.commands import main
from armtrack_cli.cli.reference import render_reference

__all__ = ["main", "render_reference"]
