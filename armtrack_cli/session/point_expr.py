"""A ground-truth point named in session.toml: a marker ("R_WRI") or the midpoint of several
("mid(RLEP, RMEP)", e.g. the elbow centre between the epicondyles)."""

from __future__ import annotations

import re

_MID = re.compile(r"^\s*mid\s*\((.*)\)\s*$")
_NAME = re.compile(r"^[^\s(),]+$")


def point_markers(expr: str) -> tuple[str, ...] | None:
    """The markers a point is the mean of; None when the text is not a valid point."""
    m = _MID.match(expr)
    names = [n.strip() for n in m.group(1).split(",")] if m else [expr.strip()]
    if not names or not all(_NAME.match(n) for n in names) or (m and len(names) < 2):
        return None
    return tuple(names)
