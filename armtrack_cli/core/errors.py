"""One root exception, a subclass per concern.

Every error names the file (or the session.toml key) it is about, says what was seen and,
where we can, how to fix it. The CLI prints ``error: FILE: message`` and exits 1.
"""

from __future__ import annotations


class ArmtrackError(Exception):
    """Root of every error armtrack reports to a user (exit code 1)."""

    def __init__(self, path: object, problem: str, hint: str | None = None):
        self.path = str(path)
        self.problem = problem
        self.hint = hint
        super().__init__(self.message)

    @property
    def message(self) -> str:
        text = self.problem
        if self.hint:
            text = f"{text}; {self.hint}"
        return text

    def __str__(self) -> str:
        return f"{self.path}: {self.message}"

    def __reduce__(self):  # pickled whole (a stage's error from its own process, pipeline/apart.py)
        return _rebuilt, (type(self), self.__dict__)


def _rebuilt(cls: type, state: dict) -> ArmtrackError:
    """An ArmtrackError (any subclass, whatever its __init__ takes) from its attributes."""
    exc = cls.__new__(cls)
    exc.__dict__.update(state)
    Exception.__init__(exc, exc.message)
    return exc


class ConfigError(ArmtrackError):
    """session.toml or a recipe is wrong: a key, a type or an impossible value."""


class DataError(ArmtrackError):
    """A data file (IMU, video, ground truth, depth) cannot be read as what it claims to be."""


class ImuFileError(DataError):
    """An IMU export (Xsens, DOT, CSV, MCAP) is malformed."""


class VideoError(DataError):
    """A video, its timestamps or its camera model is unreadable."""


class GroundTruthError(DataError):
    """A Qualisys export is malformed or does not hold the markers asked for."""


class CalibrationError(DataError):
    """The board or the palm markers cannot be found or fitted well enough."""


class DescribedError(ArmtrackError):
    """Problems found while describing a session (`armtrack info`): the first one, and how many
    more; ``described`` holds the whole description, which lists each (info prints it, then
    this one line)."""

    def __init__(self, problems: list[ArmtrackError], described: dict):
        first = problems[0]
        more = f" (and {len(problems) - 1} more, listed above)" if len(problems) > 1 else ""
        super().__init__(first.path, first.problem + more, first.hint)
        self.described = described


class OutputError(ArmtrackError):
    """An output could not be written."""


def did_you_mean(word: str, options, *, what: str | None = None, form: str = "'{}'") -> str | None:
    """The hint for a misspelt name: "did you mean 'x'?" for the closest of ``options``, else
    "WHAT are a, b, c" (None when ``what`` is not given and nothing is close)."""
    import difflib

    options = [str(o) for o in options]
    close = difflib.get_close_matches(str(word), options, n=1)
    if close:
        return f"did you mean {form.format(close[0])}?"
    return f"{what} are {', '.join(options) or 'none'}" if what else None
