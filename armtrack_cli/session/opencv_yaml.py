"""OpenCV FileStorage YAML, read without OpenCV: its parser aborts the whole process on some
damaged files (found by fuzzing), so camera models are parsed here, strictly.

The subset OpenCV writes: `%YAML:1.0` or `%YAML 1.2`, `---`, then top-level `key: value`
lines where a value is a number, a string, or `!!opencv-matrix` followed by indented
`rows`, `cols`, `dt` and `data: [ … ]` (the list may run over several lines).
"""

from __future__ import annotations

import re

import numpy as np

_KEY = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*):\s*(.*?)\s*$")
_FIELD = re.compile(r"^\s+(rows|cols|dt|data):\s*(.*?)\s*$")
_SPECIAL = {".nan": np.nan, ".NaN": np.nan, ".inf": np.inf, "-.inf": -np.inf, ".Inf": np.inf,
            "-.Inf": -np.inf}


class YamlError(ValueError):
    """Not the FileStorage YAML subset; the message names the line."""


def _number(text: str, line: int) -> float:
    text = text.strip()
    if text in _SPECIAL:
        return _SPECIAL[text]
    try:
        return float(text)
    except ValueError:
        raise YamlError(f"line {line}: {text[:40]!r} is not a number") from None


def _scalar(text: str, line: int) -> float | str:
    if text.startswith('"') and text.endswith('"') and len(text) >= 2:
        return text[1:-1]
    try:
        return _number(text, line)
    except YamlError:
        return text


def _matrix(lines: list[str], i: int, key: str) -> tuple[np.ndarray, int]:
    """The !!opencv-matrix whose fields start at lines[i]; (array, next line index)."""
    fields: dict[str, str] = {}
    while i < len(lines) and (m := _FIELD.match(lines[i])):
        name, value = m.groups()
        if name == "data":
            while "]" not in value:
                i += 1
                if i >= len(lines):
                    raise YamlError(f"{key}: its data list is never closed")
                value += " " + lines[i].strip()
        fields[name] = value
        i += 1
    if set(fields) != {"rows", "cols", "dt", "data"}:
        raise YamlError(f"{key}: a matrix needs rows, cols, dt and data")
    rows, cols = (_number(fields[k], i) for k in ("rows", "cols"))
    if not (rows.is_integer() and cols.is_integer() and 0 < rows <= 1000 and 0 < cols <= 1000):
        raise YamlError(f"{key}: rows and cols must be whole numbers from 1 to 1000")
    body = fields["data"].strip()
    if not (body.startswith("[") and body.endswith("]")):
        raise YamlError(f"{key}: data must be a list [ … ]")
    items = [x for x in body[1:-1].split(",") if x.strip()]
    values = np.array([_number(x, i) for x in items], dtype=float)
    if values.size != rows * cols:
        raise YamlError(f"{key}: {values.size} values for a {rows:g}x{cols:g} matrix")
    return values.reshape(int(rows), int(cols)), i


def parse(text: str) -> dict[str, np.ndarray | float | str]:
    """name -> matrix (2-D float array), number or string."""
    lines = text.replace("\r\n", "\n").split("\n")
    out: dict[str, np.ndarray | float | str] = {}
    if not lines or not lines[0].startswith("%YAML"):
        raise YamlError("line 1: does not start with %YAML")
    i = 1
    while i < len(lines):
        raw = lines[i]
        if not raw.strip() or raw.strip() == "---" or raw.lstrip().startswith("#"):
            i += 1
            continue
        m = _KEY.match(raw)
        if m is None:
            raise YamlError(f"line {i + 1}: {raw.strip()[:40]!r} is not `name: value`")
        key, value = m.groups()
        if key in out:
            raise YamlError(f"line {i + 1}: {key} appears twice")
        if value == "!!opencv-matrix":
            out[key], i = _matrix(lines, i + 1, key)
            continue
        out[key] = _scalar(value, i + 1)
        i += 1
    return out
