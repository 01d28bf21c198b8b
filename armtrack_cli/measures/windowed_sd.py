"""Posterior SDs of a long trajectory's measures, a window at a time (windowed.py).

The whole span's draws are one seeded stream of errors, smoothed circularly over the whole
session (uncertainty.draw_blocks): no window can have its part. Each window draws its own
errors over its read span instead (seed: the settings' own plus twice the window's number),
as table.measure_rows draws them, so each SD below is that of the same measure over draws of
the same posterior, and differs from the whole span's by Monte Carlo noise (s.draws draws):
- a segment's measures: the draws of the window that owns it (where it starts), on its
  samples, as today; a segment that reaches past that window's read span (a rest of more
  than the 20 s margins before or after it) has no SD (NaN);
- the session's peak speed and the angles' least, greatest and range: each draw's greatest
  (least) over the windows' draws, the SD of those;
- the session's other path measures and the angles' 5th-95th percentile ranges: no SD in a
  session of several windows (NaN): their draws would need each draw's onset, offset and
  percentiles over the whole session (not done yet, docs/measures.md)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from armtrack_cli.core.windows import Window
from armtrack_cli.measures.angle_rows import UNWRAPPED, series, turns
from armtrack_cli.measures.base import Settings
from armtrack_cli.measures.table import draw_values
from armtrack_cli.measures.uncertainty import spread, spread_rows

EXTREMES = ("min", "max", "rom")
BLOCK = 1 << 14  # draws × frames at a time: one draw of a window (10,200 frames) a block;
#                  the whole span's 1 << 16 held ~21 MB of a window's draws at once, as fast


def _session_keys(keys) -> tuple[list, dict]:
    """The session keys whose draws combine by greatest or least: the draws' keys to ask
    each window, and key -> how its draws are made of them."""
    want, how = [], {}
    for m, seg in keys:
        if seg != "session":
            continue
        if m == "wrist_peak_speed":
            want.append((m, seg))
            how[(m, seg)] = ("max", (m, seg))
        elif m.rsplit("_", 1)[-1] in EXTREMES and not m.endswith("p5_p95"):
            name = m.rsplit("_", 1)[0]
            lo, hi = (f"{name}_min", "session"), (f"{name}_max", "session")
            want += [k for k in (lo, hi) if k not in want]
            how[(m, seg)] = ("rom", (lo, hi)) if m.endswith("_rom") else \
                ("min" if m.endswith("_min") else "max", (m, seg))
    return want, how


def sds_windowed(read: Callable, wins: list[Window], keys, windows: list,
                 s: Settings) -> dict[tuple[str, str], float]:
    """{key: SD} for the measures ``keys`` (those with a value) on the segment ``windows``."""
    want, how = _session_keys(keys)
    hi = {k: np.full(s.draws, np.nan) for k in want}
    lo = {k: np.full(s.draws, np.nan) for k in want}
    out: dict[tuple[str, str], float] = {}
    carry: dict[str, float] = {}
    for i, w in enumerate(wins):
        own = [j for j, (a, b) in enumerate(windows) if w.inner(np.array([a]))[0]
               and a >= w.start and b <= w.stop]
        local = [windows[j] for j in own]
        seg_keys = [((m, str(n)), (m, seg)) for n, j in enumerate(own, 1)
                    for m, seg in keys if seg == str(j + 1)]
        asked = [k for k, _ in seg_keys] + want
        inp = read(w)
        got = draw_values(inp, asked, local if len(local) != 1 else local * 2,
                          replace(s, seed=s.seed + 2 * i), block_samples=BLOCK)
        _align_turns(got[len(seg_keys):], want, inp, w, carry, s)
        sd = spread_rows(got[:len(seg_keys)])
        out.update({g: float(x) for (_, g), x in zip(seg_keys, sd)})
        for r, k in enumerate(want, len(seg_keys)):
            hi[k], lo[k] = np.fmax(hi[k], got[r]), np.fmin(lo[k], got[r])
    for key, (op, src) in how.items():
        if op == "rom":
            out[key] = spread(hi[src[1]] - lo[src[0]])
        else:
            out[key] = spread(hi[src] if op == "max" else lo[src])
    return out


def _align_turns(got: np.ndarray, want: list, inp, w: Window, carry: dict, s: Settings) -> None:
    """Each draw's least and greatest of an unwrapped angle (the plane of elevation) in this
    window, its own unwrap, moved by the whole turns that put the estimate's on the whole
    span's branch (angle_rows.turns), and by those between the draw's and the estimate's own
    unwraps (a draw whose first frame falls across ±180° from the estimate's)."""
    names = {m.rsplit("_", 1)[0] for m, _ in want} & set(UNWRAPPED)
    if not names:
        return
    est = series(inp, s, None)
    inner = w.inner(np.asarray(inp.t, float))
    for name in names:
        x = est.get(name)
        if x is None or isinstance(x, str) or not np.isfinite(x).any():
            continue
        own = x[inner]
        k = turns(name, own[np.isfinite(own)], carry)
        lo_row = want.index((f"{name}_min", "session"))
        hi_row = want.index((f"{name}_max", "session"))
        shift = 360.0 * (k + np.round((got[lo_row] - np.nanmin(x)) / 360.0))
        got[lo_row] -= shift
        got[hi_row] -= shift
