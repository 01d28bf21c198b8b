"""The rows of kinematics-METHOD.csv: every measure of one trajectory, per segment and over
the session, with its unit (and convention) and its uncertainty where the filter gives one."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from armtrack_cli.measures import angles, path, smoothness
from armtrack_cli.measures.angle_draws import WRIST, angle_draws, angle_series_rows
from armtrack_cli.measures.base import DEFAULT, ONE_MOVEMENT, NotComputable, Settings
from armtrack_cli.measures.draws import PathDraws
from armtrack_cli.measures.segments import segments
from armtrack_cli.measures.signal import speed_profile
from armtrack_cli.measures.uncertainty import BLOCK_SAMPLES, draw_blocks, spread_rows

REACH_TASKS = ("reach", "reach-grasp")
ANGLES = {  # name: unit with its convention
    "elbow_flexion": "deg (0 = full extension)",
    "shoulder_elevation": "deg (ISB Y-X-Y, trunk = W; 0 = arm down)",
    "shoulder_plane": "deg (ISB Y-X-Y, trunk = W; 0 = abduction, 90 = flexion)",
    "forearm_pronation": "deg (IMU, from the first second; + pronation)",
    "wrist_flexion": "deg (+ palmar flexion)",
    "wrist_deviation": "deg (+ radial deviation)",
    "wrist_pronation": "deg (+ pronation)",
}
PATH = {  # name: unit
    "wrist_peak_speed": "m/s", "wrist_mean_speed": "m/s", "time_to_peak_speed": "s",
    "movement_time": "s (onset/offset at 2 % of peak speed)", "wrist_path_length": "m",
    "movement_units": "count (rise > 20 mm/s, peaks >= 150 ms apart)",
    "sparc": "1 (SPARC, 10 Hz, threshold 0.05; 0 = smoothest)",
    "ldlj": "1 (log dimensionless jerk, speed form T^3/v_peak^2)",
    "straightness": "1 (path length / straight-line distance)",
}
CATALOGUE = {**PATH, "segments": "count",
             **{f"{a}_{k}": u for a, u in ANGLES.items() for k in ("rom", "rom_p5_p95", "min", "max")}}


@dataclass(frozen=True)
class Inputs:
    """One trajectory on the session clock. Positions (N, 3) m in W; angles (N, 3) deg."""

    t: np.ndarray
    wrist: np.ndarray
    task: str = ""
    side: str = "right"
    elbow: np.ndarray | None = None
    shoulder: np.ndarray | None = None  # (3,) fixed, or (N, 3)
    q_WB: np.ndarray | None = None  # (N, 4) IMU orientation, for forearm pronation
    forearm_axis: np.ndarray | None = None  # (3,) in B
    wrist_angles: np.ndarray | None = None  # (N, 3) flexion, deviation, pronation
    wrist_sd: np.ndarray | None = None  # (N, 3) posterior SD of the wrist, m
    angles_sd: np.ndarray | None = None  # (N, 3) posterior SD of wrist_angles, deg


Value = float | str  # a number, or "not computable: why"


def _try(f: Callable[[], float]) -> Value:
    try:
        v = f()
    except NotComputable as exc:
        return f"not computable: {exc}"
    return float(v) if np.isfinite(v) else "not computable: no finite value"


def _path_values(t, p, v, fs: float, reach: bool, s: Settings, *,
                 skip: tuple[str, ...] = ()) -> dict[str, Value]:
    """Every path measure of one window but those named in ``skip`` (not computed)."""
    try:  # onset and offset once for every measure that needs them
        span: tuple[int, int] | None = path.onset_offset(v, s)
    except NotComputable:
        span = None  # each measure below says why

    def moving() -> np.ndarray:
        a, b = span or path.onset_offset(v, s)
        return v[a:b + 1]

    measures = {
        "wrist_peak_speed": lambda: v[path.peak(v, s)],
        "wrist_mean_speed": lambda: path.mean_speed(v, s, span=span),
        "time_to_peak_speed": lambda: path.time_to_peak(t, v, s, span=span),
        "movement_time": lambda: path.movement_time(t, v, s, span=span),
        "wrist_path_length": lambda: path.path_length(p, v, s, span=span),
        "movement_units": lambda: smoothness.movement_units(t, moving(), s)[0],
        "sparc": lambda: smoothness.sparc(moving(), fs, s),
        "ldlj": lambda: smoothness.ldlj(moving(), fs),
    }
    if reach:
        measures["straightness"] = lambda: path.straightness(p, v, s, span=span)
    return {k: _try(f) for k, f in measures.items() if k not in skip}


def path_values(inp: Inputs, s: Settings, windows: list | None = None
                ) -> tuple[dict[tuple[str, str], Value], list]:
    """({(measure, segment): value}, segment windows); segment "session" or "1", "2", …
    Given windows (from the estimate), posterior draws are measured on the same segments."""
    reach = inp.task in REACH_TASKS
    try:
        t, p, v = speed_profile(inp.t, inp.wrist, s)
    except NotComputable as exc:
        why = f"not computable: {exc}"
        return {(k, "session"): why for k in PATH if k != "straightness" or reach}, []
    fs = 1.0 / (t[1] - t[0])
    own = segments(t, v, s)
    if windows is None:  # windows in session time, so other samplings use the same segments
        windows = [(t[a], t[b - 1]) for a, b in own]
    segs = [(int(np.searchsorted(t, a - 1e-9)), int(np.searchsorted(t, b + 1e-9)))
            for a, b in windows]
    several = ONE_MOVEMENT if len(segs) > 1 else ()
    out = {(k, "session"): x for k, x in _path_values(t, p, v, fs, False, s, skip=several).items()}
    out.update({(k, "session"): f"not computable: {len(segs)} movements (see each segment)"
                for k in several})
    out[("segments", "session")] = float(len(own))  # always this signal's own count
    for n, (a, b) in enumerate(segs if len(segs) > 1 else [], 1):
        for k, x in _path_values(t[a:b], p[a:b], v[a:b], fs, reach, s).items():
            out[(k, str(n))] = x
    return out, windows


def cut_values(inp: Inputs, vals: dict, windows: list, s: Settings) -> None:
    """_cut on the measures of one trajectory (the estimate's, or the truth's on its windows):
    not on the posterior draws, whose SD is only taken of values that stand (measure_rows),
    and whose noise at the data's edges must not judge the estimate's movement."""
    try:
        t, _, v = speed_profile(inp.t, inp.wrist, s)
    except NotComputable:
        return
    segs = [(int(np.searchsorted(t, a - 1e-9)), int(np.searchsorted(t, b + 1e-9)))
            for a, b in windows]
    _cut(vals, t, v, s, segs if len(segs) > 1 else [])


def _cut(out: dict, t, v, s: Settings, segs: list) -> None:
    """A movement cut by the start or the end of the data has no onset or offset: its
    measures that need them (path.EDGE_MEASURES), in the session's row and in the first or
    last segment's, become not computable, and so does a peak speed at the cut sample. A
    value not computable already keeps its reason."""
    start, end = path.cut_edges(t, v, s)
    windows = [("session", 0, v.size)] + [(str(n), a, b) for n, (a, b) in enumerate(segs, 1)]
    for why, edge in ((start, 0), (end, v.size)):
        if why is None:
            continue
        for seg, a, b in windows:
            if edge not in (a, b) or b - a < 1:
                continue
            k = a + int(np.argmax(v[a:b]))
            for key in [x for x in out if x[1] == seg and not isinstance(out[x], str)]:
                if key[0] in path.EDGE_MEASURES or (key[0] == "wrist_peak_speed" and
                                                    k in (edge, edge - 1)):
                    out[key] = f"not computable: {why}"


def angle_series(inp: Inputs, s: Settings) -> dict[str, np.ndarray | str]:
    """Each angle over time (deg), or why it cannot be had from these inputs: the posterior
    draws' angles (angle_draws.angle_series_rows) of this one trajectory, with the IMU's
    forearm pronation before the wrist's."""
    rows = angle_series_rows(inp.wrist, inp.elbow, inp.shoulder, inp.wrist_angles, inp.side, s)
    out: dict[str, np.ndarray | str] = {k: v for k, v in rows.items() if k not in WRIST}
    if inp.q_WB is not None and inp.forearm_axis is not None:
        try:
            out["forearm_pronation"] = angles.forearm_pronation_deg(inp.t, inp.q_WB,
                                                                    inp.forearm_axis, inp.side, s)
        except NotComputable as exc:
            out["forearm_pronation"] = str(exc)
    out.update((k, v) for k, v in rows.items() if k in WRIST)
    return out


def angle_values(inp: Inputs, s: Settings) -> dict[tuple[str, str], Value]:
    out: dict[tuple[str, str], Value] = {}
    for name, x in angle_series(inp, s).items():
        try:
            r = angles.rom(x) if not isinstance(x, str) else None
        except NotComputable as exc:
            x = str(exc)
        for k in ("rom", "rom_p5_p95", "min", "max"):
            out[(f"{name}_{k}", "session")] = r[k] if not isinstance(x, str) else f"not computable: {x}"
    return out


def values(inp: Inputs, s: Settings, windows: list | None = None
           ) -> tuple[dict[tuple[str, str], Value], list]:
    vals, segs = path_values(inp, s, windows)
    return {**vals, **angle_values(inp, s)}, segs


def _uncertainty(inp: Inputs, keys, windows: list, s: Settings) -> dict[tuple[str, str], float]:
    """SD of every measure over draws from the posterior (uncertainty.py), a block of draws
    at a time: the path measures of a block at once (draws.py), and its angles (angle_draws.py)."""
    if inp.wrist_sd is None and inp.angles_sd is None:
        return {}
    return dict(zip(keys, spread_rows(draw_values(inp, keys, windows, s)).tolist()))


def draw_values(inp: Inputs, keys, windows: list, s: Settings,
                block_samples: int = BLOCK_SAMPLES) -> np.ndarray:
    """(len(keys), s.draws): each measure's value in each draw (NaN: none); the posterior as
    _uncertainty samples it (inp has wrist_sd or angles_sd), block_samples draws × frames
    at a time (the same draws however grouped: uncertainty.draw_blocks)."""
    none = iter(lambda: None, 0)  # no posterior for this input: None for every block
    e_w = draw_blocks(inp.t, inp.wrist_sd, s, block_samples) if inp.wrist_sd is not None else none
    e_a = (draw_blocks(inp.t, inp.angles_sd, replace(s, seed=s.seed + 1), block_samples)
           if inp.angles_sd is not None else none)
    got = np.full((len(keys), s.draws), np.nan)  # a measure's draws a row: no small array
    #                          per measure and block (60 minutes: 430,000 of them, 23 MB)
    path_draws = PathDraws(inp.t, windows, inp.task in REACH_TASKS, s)
    done = 0
    while done < s.draws:
        ew, ea = next(e_w), next(e_a)
        c = (ew if ew is not None else ea).shape[0]
        by_path = {}
        if inp.wrist is not None:  # the elbow is the wrist moved by a known vector: its error
            wrist = inp.wrist[None] + (0.0 if ew is None else ew)
            by_path = path_draws(np.broadcast_to(wrist, (c, *inp.wrist.shape)))
        by_angle = angle_draws(inp, ew, ea, s)
        for i, k in enumerate(keys):
            got[i, done:done + c] = by_path.get(k, by_angle.get(k, np.nan))
        done += c
    return got


def _measured_span(inp: Inputs) -> tuple[float, float]:
    """The session row's window: from the first to the last frame with a wrist, which the
    measures are taken over (measures/signal.uniform), not the trajectory's empty frames
    before or after it (a filter that left the arm's reach: its rows left empty)."""
    seen = np.isfinite(inp.wrist).all(axis=1) & np.isfinite(inp.t)
    t = inp.t[seen] if seen.any() else inp.t
    return float(np.nanmin(t)), float(np.nanmax(t))


def measure_rows(inp: Inputs, s: Settings = DEFAULT, windows: list | None = None) -> list[dict]:
    """[{measure, segment, value, sd, unit, t_start, t_end}]: value a float or "not computable:
    why"; sd the posterior uncertainty (NaN where the filter gives no SD or the draws do not
    support one); t_start, t_end the segment's window in session time (s). Given windows
    (e.g. the estimate's, for the ground truth), the segments are those."""
    vals, windows = values(inp, s, windows)
    cut_values(inp, vals, windows, s)
    fixed = ("segments",) + tuple(f"forearm_pronation_{k}" for k in ("rom", "rom_p5_p95", "min", "max"))
    sds = _uncertainty(inp, [k for k, v in vals.items() if not isinstance(v, str)
                             and k[0] not in fixed], windows, s)  # no posterior for these
    order = {k: i for i, k in enumerate(CATALOGUE)}
    keys = sorted(vals, key=lambda k: (k[1] != "session", int(k[1]) if k[1].isdigit() else 0,
                                       order[k[0]]))
    span = {str(n): w for n, w in enumerate(windows, 1)}
    span["session"] = _measured_span(inp)
    return [{"measure": m, "segment": seg, "value": vals[(m, seg)],
             "sd": sds.get((m, seg), float("nan")), "unit": CATALOGUE[m],
             "t_start": float(span[seg][0]), "t_end": float(span[seg][1])} for m, seg in keys]
