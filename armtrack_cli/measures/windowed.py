"""measure_rows of a long trajectory read a window at a time (issue 15: memory flat in the
session's length): ``read(w)`` gives the Inputs of the frames in [w.start, w.stop] of each
core/windows.Window. One window: measure_rows itself. Several: the same rows from passes
over the windows, each window's arrays dropped before the next is read (docs/measures.md,
"Long sessions", says how each value is made):

- the speed profile of each window's read span on the session's uniform clock (clock.py),
  kept on the window's inner span: the whole span's to round-off;
- the session's peak, onset and offset, the segments' runs and the movement units' peaks
  found over the inner spans in order (stream.py); sums and maxima added up;
- each segment's samples gathered from the windows' inner spans (however many it spans) and
  measured as measure_rows measures them;
- the angles (angle_rows.py); the posterior SDs (windowed_sd.py).
A session whose path gives one segment or none (one long movement, no movement) is measured
whole: its single-movement measures (SPARC, LDLJ) need the whole signal at once."""

from __future__ import annotations

from collections.abc import Callable, Iterator

import numpy as np

from armtrack_cli.core.windows import Window
from armtrack_cli.measures import path
from armtrack_cli.measures.angle_rows import angle_values_windowed
from armtrack_cli.measures.base import DEFAULT, ONE_MOVEMENT, NotComputable, Settings
from armtrack_cli.measures.clock import Clock, IntervalCounter, Profile, find_clock, window_profile
from armtrack_cli.measures.stream import OnsetOffset, PeakSketch, Runs, interior_maxima
from armtrack_cli.measures.table import CATALOGUE, PATH, REACH_TASKS, Inputs, _path_values, _try, measure_rows
from armtrack_cli.measures.vec3 import norm3
from armtrack_cli.measures.windowed_sd import sds_windowed

Reader = Callable[[Window], Inputs]


def measure_rows_windowed(read: Reader, wins: list[Window], s: Settings = DEFAULT,
                          windows: list | None = None) -> list[dict]:
    """measure_rows of the trajectory that ``read`` gives a window of ``wins`` at a time;
    ``windows`` as measure_rows' (the estimate's segments, for the ground truth)."""
    whole = Window(-np.inf, np.inf, wins[0].start, wins[-1].stop)
    if len(wins) == 1:
        return measure_rows(read(whole), s, windows)
    got = path_windowed(read, wins, s, windows)
    if got is None:  # one movement or none: measured whole (see the module's docstring)
        return measure_rows(read(whole), s, windows)
    vals, windows, clock = got
    first = read(wins[0])
    vals.update(angle_values_windowed(read, wins, s))
    fixed = ("segments",) + tuple(f"forearm_pronation_{k}" for k in ("rom", "rom_p5_p95", "min", "max"))
    keys = [k for k, v in vals.items() if not isinstance(v, str) and k[0] not in fixed]
    sds = (sds_windowed(read, wins, keys, windows, s)
           if first.wrist_sd is not None or first.angles_sd is not None else {})
    order = {k: i for i, k in enumerate(CATALOGUE)}
    keys = sorted(vals, key=lambda k: (k[1] != "session", int(k[1]) if k[1].isdigit() else 0,
                                       order[k[0]]))
    span = {str(n): w for n, w in enumerate(windows, 1)}
    span["session"] = (clock.t0, clock.t_end)
    return [{"measure": m, "segment": seg, "value": vals.pop((m, seg)),  # (popped: the
             "sd": sds.pop((m, seg), float("nan")), "unit": CATALOGUE[m],  # rows replace them)
             "t_start": float(span[seg][0]), "t_end": float(span[seg][1])} for m, seg in keys]


def profiles(read: Reader, wins: list[Window], clock: Clock, s: Settings) -> Iterator[Profile]:
    """Each window's speed profile (clock.window_profile), in order; those without an own
    sample left out."""
    for i, w in enumerate(wins):
        inp = read(w)
        prof = window_profile(clock, np.asarray(inp.t, float), inp.wrist, w.inner, s,
                              last=i == len(wins) - 1)
        del inp
        if prof is not None and prof.b > prof.a:
            yield prof


class Peak:
    """The first sample of the greatest speed, the ends' speeds and the clock's intervals."""

    def __init__(self, prof_iter: Iterator[Profile], n: int):
        self.v, self.k, self.finite = -np.inf, -1, True
        self.ticks = IntervalCounter()
        for pr in prof_iter:
            v = pr.v[pr.a:pr.b]
            self.finite &= bool(np.isfinite(v).all())
            j = int(np.argmax(v))
            if v[j] > self.v:
                self.v, self.k = float(v[j]), pr.k0 + pr.a + j
            if pr.k0 + pr.a == 0:
                self.v0 = float(v[0])
            if pr.k0 + pr.b == n:
                self.v_end = float(v[-1])
            self.ticks.add(pr.t[pr.a:pr.b])


def own_segments(runs: list, clock: Clock, vk: float, s: Settings) -> list[tuple[int, int]]:
    """segments.segments from the runs above 10 % of the peak: the same rules and windows."""
    t = clock.at
    runs = [(a, b) for a, b, pk in runs
            if t(np.array([b - 1]))[0] - t(np.array([a]))[0] >= s.min_segment_s
            and pk >= s.min_segment_peak * vk]
    out = []
    for k, (a, b) in enumerate(runs):
        lo = 0 if k == 0 else (runs[k - 1][1] + a) // 2
        hi = clock.n if k == len(runs) - 1 else (b + runs[k + 1][0]) // 2 + 1
        out.append((lo, hi))
    return out


def path_windowed(read: Reader, wins: list[Window], s: Settings, windows: list | None):
    """(values, segment windows, clock) as table.path_values gives them, or None when the
    path has fewer than two segments (or no movement, or no speed profile)."""
    first = read(wins[0])
    reach = first.task in REACH_TASKS
    try:
        clock = find_clock(_own_frames(read, wins), s)
    except NotComputable:
        return None  # measured whole: it says why
    pk = Peak(profiles(read, wins, clock, s), clock.n)
    if not (pk.finite and pk.v >= s.min_moving_speed and clock.n >= 3):
        return None
    oo = OnsetOffset(s.onset_fraction * pk.v, s.min_segment_peak * pk.v, clock.n)
    runs = Runs(s.segment_fraction * pk.v)
    for pr in profiles(read, wins, clock, s):
        oo.add(pr.k0 + pr.a, pr.v[pr.a:pr.b])
        runs.add(pr.k0 + pr.a, pr.v[pr.a:pr.b])
    own = own_segments(runs.finish(clock.n), clock, pk.v, s)
    if windows is None:
        windows = [(float(clock.at(np.array([a]))[0]), float(clock.at(np.array([b - 1]))[0]))
                   for a, b in own]
    if len(windows) < 2:
        return None
    segs = [(clock.searchsorted(a - 1e-9), clock.searchsorted(b + 1e-9)) for a, b in windows]
    vals, peaks = _session_and_segments(read, wins, clock, s, oo.span(), pk, segs, reach)
    vals[("segments", "session")] = float(len(own))
    _cut_windowed(vals, clock, pk, segs, peaks, s)
    return vals, windows, clock


def _own_frames(read: Reader, wins: list[Window]):
    for w in wins:
        inp = read(w)
        t = np.asarray(inp.t, float)
        inner = w.inner(t)
        yield t[inner], inp.wrist[inner]


class Gather:
    """Each segment's samples (sample ranges [a, b) of the clock, in order, overlapping by a
    sample at most) gathered from the windows' inner spans, however many it spans."""

    def __init__(self, segs: list[tuple[int, int]]):
        self.segs, self.j = segs, 0
        self.k0, self.buf = 0, None

    def add(self, k0: int, *cols: np.ndarray) -> Iterator[tuple[int, tuple]]:
        """(segment number from 0, its columns) of each segment complete with these samples
        (k0: the first's clock index)."""
        if self.buf is None:
            self.k0, self.buf = k0, cols
        else:
            self.buf = tuple(np.concatenate([b, c]) for b, c in zip(self.buf, cols))
        end = k0 + len(cols[0])
        while self.j < len(self.segs) and self.segs[self.j][1] <= end:
            a, b = self.segs[self.j]
            lo, hi = max(a - self.k0, 0), max(b - self.k0, 0)
            yield self.j, tuple(c[lo:hi] for c in self.buf)
            self.j += 1
        if self.j < len(self.segs):  # keep from the next segment's first sample on
            cut = max(0, min(self.segs[self.j][0] - self.k0, len(self.buf[0])))
            self.buf = tuple(c[cut:].copy() for c in self.buf)
            self.k0 += cut
        else:
            self.buf = tuple(c[:0] for c in self.buf)
            self.k0 = end


def _session_and_segments(read, wins, clock, s, span, pk, segs, reach):
    """The session row's path values over [onset, offset] (sums and maxima over the
    windows, the movement units' peaks from their sketch) and each segment's."""
    a, b = span
    sketch, gather = PeakSketch(a, b), Gather(segs)
    tot = {"v": 0.0, "len": 0.0, "lo": np.inf, "hi": -np.inf, "finite": True}
    out, peaks = {}, {}
    for pr in profiles(read, wins, clock, s):
        i0, i1 = max(pr.a, a - pr.k0), min(pr.b, b + 1 - pr.k0)
        if i1 > i0:
            x = pr.v[i0:i1]
            tot["v"] += float(np.sum(x))
            tot["lo"], tot["hi"] = min(tot["lo"], float(x.min())), max(tot["hi"], float(x.max()))
            tot["finite"] &= bool(np.isfinite(x).all())
            j1 = min(i1, b - pr.k0)  # steps from samples i0 … j1 − 1 to the next
            if j1 > i0:
                tot["len"] += float(np.sum(norm3(np.diff(pr.p[i0:j1 + 1], axis=0))))
            m = interior_maxima(pr.v, i0, i1)
            sketch.add(pr.k0 + i0, x, m[(m + pr.k0 > a) & (m + pr.k0 < b)] - i0)
        for j, (t, p, v) in gather.add(pr.k0 + pr.a, pr.t[pr.a:pr.b], pr.p[pr.a:pr.b],
                                       pr.v[pr.a:pr.b]):
            for k, x in _path_values(t, p, v, clock.fs, reach, s).items():
                out[(k, str(j + 1))] = x
            peaks[str(j + 1)] = segs[j][0] + (int(np.argmax(v)) if v.size else 0)
    session = _session_values(clock, s, span, pk, tot, sketch, len(segs))
    return {**{(k, "session"): x for k, x in session.items()}, **out}, peaks


def _session_values(clock, s, span, pk, tot, sketch, n_segs) -> dict:
    a, b = span
    t = clock.at(np.array([a, b]))

    def units() -> float:
        n = b - a + 1
        if n < 10 or not tot["finite"]:
            raise NotComputable("fewer than 10 finite speed samples")
        if max(abs(tot["lo"]), abs(tot["hi"])) == 0 or tot["hi"] - tot["lo"] == 0:
            raise NotComputable("the speed is constant")
        gap = max(1, int(np.ceil(s.mu_min_gap_s / pk.ticks.median() - 1e-9)))
        return sketch.count(s.mu_rise, gap)

    def movement_time() -> float:
        if b - a < 2:
            raise NotComputable("the movement is shorter than 3 samples")
        return float(t[1] - t[0])

    measures = {"wrist_peak_speed": lambda: pk.v, "wrist_mean_speed": lambda: tot["v"] / (b - a + 1),
                "movement_time": movement_time, "wrist_path_length": lambda: tot["len"],
                "movement_units": units}
    out = {k: _try(f) for k, f in measures.items()}
    out.update({k: f"not computable: {n_segs} movements (see each segment)" for k in ONE_MOVEMENT})
    return {k: out[k] for k in PATH if k in out}


def _cut_windowed(vals: dict, clock: Clock, pk: Peak, segs: list, peaks: dict, s: Settings) -> None:
    """table._cut from the ends' speeds, the peak and each segment's peak sample."""
    n = clock.n
    te = clock.at(np.array([0, n - 1]))
    start, end = path.cut_edges(np.array([te[0], te[0], te[1]]),
                                np.array([pk.v0, pk.v, pk.v_end]), s)
    parts = [("session", 0, n, pk.k)] + [(str(j), a, b, peaks.get(str(j), a))
                                         for j, (a, b) in enumerate(segs, 1)]
    for why, edge in ((start, 0), (end, n)):
        if why is None:
            continue
        for seg, a, b, k in parts:
            if edge not in (a, b) or b - a < 1:
                continue
            for key in [x for x in vals if x[1] == seg and not isinstance(vals[x], str)]:
                if key[0] in path.EDGE_MEASURES or (key[0] == "wrist_peak_speed" and
                                                    k in (edge, edge - 1)):
                    vals[key] = f"not computable: {why}"
