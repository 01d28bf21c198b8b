"""Command-line values that click's own types do not check: finite numbers, pixel lists,
marker-hiding spans."""

from __future__ import annotations

import click


class Finite(click.FloatRange):
    """A float in a range, with NaN and infinities refused (click's FloatRange lets NaN by)."""

    def convert(self, value, param, ctx):
        import math

        v = super().convert(value, param, ctx)
        if not math.isfinite(v):
            self.fail(f"{value!r} is not a finite number", param, ctx)
        return v


def parse_pixels(spec: str):
    """'u1,v1;u2,v2;…' -> (k, 2) array."""
    import numpy as np

    try:
        pts = [tuple(float(x) for x in p.split(",")) for p in spec.replace(" ", "").split(";") if p]
        arr = np.array(pts, float)
        if arr.ndim != 2 or arr.shape[1] != 2 or not np.isfinite(arr).all():
            raise ValueError
        return arr
    except ValueError:
        raise click.BadParameter(f"{spec!r} is not 'u,v;u,v;…' in the [palm] markers order",
                                 param_hint="--markers") from None


def parse_hide(spec: str) -> tuple[int, float, float]:
    try:
        k, a, d = spec.split(":")
        if not (0 <= int(k) <= 5 and 0 <= float(a) <= 3600 and 0 < float(d) <= 3600):
            raise ValueError
        return int(k), float(a), float(d)
    except ValueError:
        raise click.BadParameter(f"{spec!r} is not MARKER:START:DURATION (MARKER 0-5)",
                                 param_hint="--hide") from None
