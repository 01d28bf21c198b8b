"""Several sessions of one subject: each measure over the sessions in date order, the change
from the session before and whether it exceeds the uncertainty of that change.

A change counts as beyond the uncertainty when |Δ| > 1.96 · √(SD₁² + SD₂²), the 95 % limit of
the difference of two independent estimates; without an SD on either side it is not judged."""

from __future__ import annotations

import math

from armtrack_cli.report import layout, words
from armtrack_cli.report.data import SessionReport
from armtrack_cli.report.summary import as_number, lookup, over_movements

KEY = ("elbow_flexion_rom", "shoulder_elevation_rom", "forearm_pronation_rom", "wrist_flexion_rom",
       "wrist_deviation_rom", "wrist_pronation_rom", "wrist_peak_speed", "wrist_mean_speed",
       "movement_time", "wrist_path_length", "movement_units", "sparc", "ldlj")


def series(reports: list[SessionReport], measure: str) -> list[tuple[float, float]]:
    """(value, sd) of each session; a measure of one movement in a session of several: the
    median over its movements, without an SD (summary.over_movements)."""
    out = []
    for r in reports:
        v, sd = lookup(r, measure)
        many = over_movements(r, measure) if not math.isfinite(as_number(v)) else None
        out.append((many[0], float("nan")) if many else (as_number(v), sd))
    return out


def change(prev: tuple[float, float], cur: tuple[float, float], *, same_method: bool = True
           ) -> tuple[float, str]:
    """(Δ, judgement) between two (value, sd); not judged across two tracking methods (their
    difference is partly the methods')."""
    d = cur[0] - prev[0]
    if not math.isfinite(d):
        return d, "—"
    if not same_method:
        return d, "not judged: other method"
    if not (math.isfinite(prev[1]) and math.isfinite(cur[1])):
        return d, "no uncertainty"
    limit = 1.96 * math.hypot(prev[1], cur[1])
    return d, "yes" if abs(d) > limit else "no"


def table_rows(reports: list[SessionReport]) -> list[list[str]]:
    """[measure, a value per session…, change, judgement, unit] of each measure some session has."""
    out = []
    same = reports[-2].method == reports[-1].method
    for m in KEY:
        s = series(reports, m)
        if all(not math.isfinite(v) for v, _ in s):
            continue
        d, verdict = change(s[-2], s[-1], same_method=same)
        unit = words.MEASURES[m][1]
        cells = [words.number(v, m) for v, _ in s]
        out.append([words.name(m)] + cells + [words.number(d, m), verdict, unit or "—"])
    return out


PER_TABLE = 4  # sessions side by side in one table: wider ones are unreadable on A4
LISTED = 6  # up to this many sessions are named in the text; more are named in the tables


def intro_lines(reports: list[SessionReport]) -> list[str]:
    """Which sessions (with each one's method when they differ), and how to read the change."""
    methods = list(dict.fromkeys(r.method for r in reports))
    if len(reports) <= LISTED:
        each = ", ".join(f"{r.day} ({r.session_id}, {words.task_name(r.task)}"
                         + (f", {r.method or 'no estimate'}" if len(methods) > 1 else "") + ")"
                         for r in reports)
        lines = words.lines_of(f"{len(reports)} sessions in date order: {each}", 105)
    else:
        lines = [f"{len(reports)} sessions in date order, from {reports[0].day} to {reports[-1].day}"
                 ", each named in the tables' headings."]
    if len({r.task for r in reports}) > 1:
        lines.append("Note: the sessions are of different tasks; compare like with like.")
    if len(methods) > 1:
        by = "; ".join(f"{m or 'no estimate'}: " + ", ".join(r.session_id for r in reports
                                                             if r.method == m) for m in methods)
        lines += words.lines_of(
            f"Note: the sessions were tracked by different methods ({by}); a difference between "
            "two of them is partly the methods', and the change between two such sessions is "
            "not judged.", 105)
    return lines + ["Change: last session minus the one before. Exceeds uncertainty: the change is",
                    "larger than 1.96 × the combined SD of the two sessions (beyond uncertainty, 95 %).",
                    "The SD covers the tracking's uncertainty only, not every error of a measure."]


def _table(fig, y: float, reports: list[SessionReport], rows: list[list[str]], lo: int, hi: int,
           last: bool) -> None:
    """Sessions lo..hi-1 of the rows as one table from y down (the change columns only in the
    last table)."""
    head = ["measure"] + [r.day + "\n" + words.clip(r.session_id, 14) for r in reports[lo:hi]]
    body = [[row[0]] + row[1 + lo:1 + hi] for row in rows]
    w = [0.31] + [0.11] * (hi - lo)
    if last:
        head += ["change", "exceeds uncertainty?", "unit"]
        body = [b + row[-3:] for b, row in zip(body, rows)]
        w += [0.08, 0.2, 0.05]
    h = _height(rows)
    layout.table(fig, [0.07, y - h, min(sum(w), 1.0) * 0.86, h], body, head,
                 widths=[x / sum(w) for x in w], size=7.5)


def _height(rows) -> float:
    return 0.022 * (len(rows) + 2)


def table_pages(reports: list[SessionReport]) -> list:
    """The progress table, PER_TABLE sessions a table, as many tables a page as fit."""
    rows = table_rows(reports)
    blocks = [(a, min(a + PER_TABLE, len(reports))) for a in range(0, len(reports), PER_TABLE)]
    intro = intro_lines(reports)
    plan, y, top = [[]], 0.905 - 0.016 * len(intro) - 0.01, 0.905
    for lo, hi in blocks:  # (y of the table, lo, hi) on each page
        if y - _height(rows) < 0.05 and plan[-1]:
            plan.append([])
            y = top
        plan[-1].append((y, lo, hi))
        y -= _height(rows) + 0.03

    def drawer(mine, first):
        def draw(fig):
            if first:
                layout.text_block(fig, 0.07, top, intro, size=8.5, step=0.016)
            for y0, lo, hi in mine:
                _table(fig, y0, reports, rows, lo, hi, hi == len(reports))
        return draw

    return [("Progress over sessions", drawer(mine, k == 0)) for k, mine in enumerate(plan)]


def _limits(values: list[float]) -> tuple[float, float] | None:
    """A y-axis at least 20 % of the largest |value| tall (a change of 0.4° in 17° must not
    fill the chart), about the values' middle."""
    v = [x for x in values if math.isfinite(x)]
    if not v:
        return None
    lo, hi = min(v), max(v)
    need = 0.2 * max(abs(lo), abs(hi))
    if hi - lo >= need:
        return None
    mid = (lo + hi) / 2
    return mid - need / 2, mid + need / 2


def positions(reports: list[SessionReport]) -> tuple[list[float], str]:
    """Each session's place on the charts' x-axis and the axis's words: days since the first
    session when every session's date is known (sessions a day and two months apart are not
    drawn the same distance apart), else the order the sessions are in."""
    from datetime import datetime

    try:
        when = [datetime.fromisoformat(r.date) for r in reports]
        days = [(d - when[0]).total_seconds() / 86400 for d in when]
    except (TypeError, ValueError):  # a date not recorded or not ISO; naive beside aware
        return [float(k) for k in range(1, len(reports) + 1)], "sessions in date order"
    return days, "days since the first session"


def _ticks(x: list[float], reports: list[SessionReport]) -> tuple[list[float], list[str]]:
    """At most four dates under a chart: the sessions nearest to 0, 1/3, 2/3 and all of the
    axis, none within 1/6 of the axis of the one before (more would overlap)."""
    span = (x[-1] - x[0]) or 1.0
    keep: list[int] = []
    for f in (0.0, 1 / 3, 2 / 3, 1.0):
        k = min(range(len(x)), key=lambda i: abs(x[i] - x[0] - f * span))
        if not keep or x[k] - x[keep[-1]] >= span / 6:
            keep.append(k)
        elif f == 1.0 and len(keep) > 1:
            keep[-1] = k  # the last session's date over its near neighbour's
    return [x[k] for k in keep], [reports[k].day for k in keep]


def chart_pages(reports: list[SessionReport]) -> list:
    shown = [m for m in KEY if any(math.isfinite(v) for v, _ in series(reports, m))]
    x, axis = positions(reports)

    def charts(these):
        def draw(fig):
            for k, m in enumerate(these):
                ax = fig.add_axes([0.10 + 0.45 * (k % 2), 0.70 - 0.205 * (k // 2), 0.36, 0.14])
                s = series(reports, m)
                ax.errorbar(x, [v for v, _ in s], yerr=[2 * sd if math.isfinite(sd) else 0 for _, sd in s],
                            color="black", marker="o", markerfacecolor="white", capsize=3, linewidth=1)
                ax.set_xticks(*_ticks(x, reports), fontsize=7)
                lim = _limits([v + e * sd for v, sd in s for e in (-2, 0, 2) if math.isfinite(sd)]
                              + [v for v, _ in s])
                if lim:
                    ax.set_ylim(*lim)
                unit = words.MEASURES[m][1]
                ax.set_title(words.name(m) + (f" ({unit})" if unit else ""), fontsize=8)
            for k, line in enumerate((  # one sentence a line: the page is 8.27 in wide
                    f"Each measure by session date (across: {axis}).",
                    "Bars show ± 2 SD of the tracking's uncertainty (none where it gives none).",
                    "The y-axes do not start at 0; each is at least 20 % of its largest value "
                    "tall, so a small change looks small.")):
                fig.text(0.07, 0.9 - 0.016 * k, line, fontsize=8.5)
        return draw

    return [("Progress over sessions: charts", charts(shown[i:i + 8]))
            for i in range(0, len(shown), 8)]


def pages(reports: list[SessionReport]) -> list:
    return table_pages(reports) + chart_pages(reports)
