"""The `armtrack` program (and `python -m armtrack_cli`).

The command line is imported here, inside the guard, so that Ctrl-C at any moment, even
while Python is still importing, ends with one line and exit code 130, never a traceback;
and every Python warning (numpy's among them) is printed as one line of armtrack's own.
"""

import sys


def _one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    text = " ".join(str(message).split())
    (file or sys.stderr).write(f"warning: {text}\n")


def _interrupted() -> int:
    """The one line of an interrupt, and exit code 130. Objects the interrupt left half-built
    (llvmlite's, when it fell inside numba's set-up) may fail in their finalisers at exit and
    print "Exception ignored in …" tracebacks: those are silenced, for the user has been told."""
    sys.stderr.write("error: interrupted\n")
    _quiet_finalisers()
    return 130


def _quiet_finalisers() -> None:
    sys.unraisablehook = lambda _unraisable: None


def main() -> int:
    import warnings

    warnings.showwarning = _one_line_warning
    try:
        import click

        from armtrack_cli.cli import main as commands

        code = commands.main(standalone_mode=False) or 0
    except KeyboardInterrupt:  # before click is imported too
        return _interrupted()
    except click.exceptions.Abort:
        return _interrupted()
    except click.exceptions.Exit as exc:
        return exc.exit_code
    except click.ClickException as exc:
        exc.show()
        return exc.exit_code
    if code == 130:  # the command's own interrupt line is written (cli/commands._Group)
        _quiet_finalisers()
    return code


if __name__ == "__main__":
    sys.exit(main())
