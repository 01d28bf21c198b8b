"""The angles' session rows (range of motion, 5th-95th percentile range, least and greatest)
of a long trajectory read a window at a time (windowed.py): each window's angle series on its
own frames, the least and greatest and the count in one pass, the percentiles' order
statistics in a few more (stream.OrderStats): exactly table.angle_values' numbers.

Two angles are unwrapped (continuous through ±180°): the plane of elevation and the forearm's
pronation. A window's series, unwrapped over its own frames, differs from the whole span's by
a whole number of turns; it is shifted so that its first value lies within 180° of the last
one before it, as the whole span's unwrap puts it. The forearm's pronation is relative to its
pose in the session's first second, taken from the first window with an orientation."""

from __future__ import annotations

from collections.abc import Callable, Iterator

import numpy as np

from armtrack_cli.core.windows import Window
from armtrack_cli.measures import angles
from armtrack_cli.measures.angle_draws import WRIST, angle_series_rows
from armtrack_cli.measures.base import NotComputable, Settings
from armtrack_cli.measures.stream import OrderStats, lerp, percentile_index

UNWRAPPED = ("shoulder_plane", "forearm_pronation")


def neutral_pose(read: Callable, wins: list[Window], s: Settings) -> np.ndarray | None:
    """The forearm's mean orientation over the session's first second (angles.neutral_quaternion)."""
    for w in wins:
        inp = read(w)
        if inp.q_WB is None or inp.forearm_axis is None:
            return None
        if np.isfinite(inp.q_WB).all(axis=1).any():
            return angles.neutral_quaternion(np.asarray(inp.t, float), inp.q_WB, s)
    return None


def series(inp, s: Settings, neutral: np.ndarray | None) -> dict[str, np.ndarray | str]:
    """table.angle_series of one window, the forearm's pronation from ``neutral``."""
    rows = angle_series_rows(inp.wrist, inp.elbow, inp.shoulder, inp.wrist_angles, inp.side, s)
    out: dict[str, np.ndarray | str] = {k: v for k, v in rows.items() if k not in WRIST}
    if inp.q_WB is not None and inp.forearm_axis is not None:
        out["forearm_pronation"] = ("no orientation samples" if neutral is None else
                                    angles.forearm_pronation_deg(
                                        np.asarray(inp.t, float), inp.q_WB, inp.forearm_axis,
                                        inp.side, s, neutral=neutral))
    out.update((k, v) for k, v in rows.items() if k in WRIST)
    return out


def turns(name: str, x: np.ndarray, carry: dict[str, float]) -> float:
    """The whole turns a window's own unwrap of an angle (its own finite values x, in order)
    is ahead of the whole span's: its first value within 180° of the last before it
    (``carry``, updated)."""
    if x.size == 0:
        return 0.0
    k = float(np.round((x[0] - carry[name]) / 360.0)) if name in carry else 0.0
    carry[name] = float(x[-1]) - 360.0 * k
    return k


def pieces(read: Callable, wins: list[Window], s: Settings, neutral) -> Iterator[dict]:
    """Each window's angles on its own frames (finite values only), in order."""
    carry: dict[str, float] = {}
    for w in wins:
        inp = read(w)
        inner = w.inner(np.asarray(inp.t, float))
        out = {}
        for name, x in series(inp, s, neutral).items():
            if not isinstance(x, str):
                x = x[inner]
                x = x[np.isfinite(x)]
                if name in UNWRAPPED:
                    x = x - 360.0 * turns(name, x, carry)
            out[name] = x
        yield out


def angle_values_windowed(read: Callable, wins: list[Window], s: Settings) -> dict:
    """{(ANGLE_rom…, "session"): value} as table.angle_values gives them."""
    neutral = neutral_pose(read, wins, s)
    stats: dict[str, list] = {}
    why: dict[str, str] = {}
    for piece in pieces(read, wins, s, neutral):
        for name, x in piece.items():
            st = stats.setdefault(name, [0, np.inf, -np.inf])
            if isinstance(x, str):
                why.setdefault(name, x)
            elif x.size:
                st[0] += x.size
                st[1], st[2] = min(st[1], float(x.min())), max(st[2], float(x.max()))
    ranks = {name: [percentile_index(n, q) for q in (5, 95)] for name, (n, _, _) in stats.items()
             if n >= 10}
    order = {name: OrderStats(stats[name][1], stats[name][2], [r for a, b, _ in rk for r in (a, b)])
             for name, rk in ranks.items()}
    while order and not all([o.end() for o in _pass(order, read, wins, s, neutral)]):
        pass  # (a list: every angle's pass ends, not only up to the first still open)
    out = {}
    for name, (n, lo, hi) in stats.items():
        if n == 0 and name in why:
            vals: dict = dict.fromkeys(("rom", "rom_p5_p95", "min", "max"), f"not computable: {why[name]}")
        elif n < 10:
            vals = dict.fromkeys(("rom", "rom_p5_p95", "min", "max"),
                                 f"not computable: {NotComputable(f'only {n} frames with this angle')}")
        else:
            o = order[name]
            p5, p95 = (lerp(o.value(a), o.value(b), g) for a, b, g in ranks[name])
            vals = {"min": lo, "max": hi, "rom": hi - lo, "rom_p5_p95": p95 - p5}
        out.update({(f"{name}_{k}", "session"): vals[k] for k in ("rom", "rom_p5_p95", "min", "max")})
    return out


def _pass(order: dict, read, wins, s, neutral) -> list[OrderStats]:
    """One pass over the windows for every angle's open order statistics."""
    for o in order.values():
        o.begin()
    for piece in pieces(read, wins, s, neutral):
        for name, o in order.items():
            x = piece.get(name)
            if x is not None and not isinstance(x, str) and o.pending():
                o.add(x)
    return list(order.values())
