"""The `armtrack` program (and `python -m armtrack_cli`).

The command line is imported here, inside the guard, so that Ctrl-C at any moment, even
while Python is still importing, ends with one line and exit code 130, never a traceback;
and every Python warning (numpy's among them) is printed as one line of armtrack's own.
"""

import sys


def _one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    text = " ".join(str(message).split())
    (file or sys.stderr).write(f"warning: {text}\n")


def main() -> int:
    import warnings

    warnings.showwarning = _one_line_warning
    try:
        import click

        from armtrack_cli.cli import main as commands

        return commands.main(standalone_mode=False) or 0
    except KeyboardInterrupt:
        sys.stderr.write("error: interrupted\n")
        return 130
    except click.exceptions.Abort:
        sys.stderr.write("error: interrupted\n")
        return 130
    except click.exceptions.Exit as exc:
        return exc.exit_code
    except click.ClickException as exc:
        exc.show()
        return exc.exit_code


if __name__ == "__main__":
    sys.exit(main())
