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


def change(prev: tuple[float, float], cur: tuple[float, float]) -> tuple[float, str]:
    """(Δ, judgement) between two (value, sd)."""
    d = cur[0] - prev[0]
    if not math.isfinite(d):
        return d, "—"
    if not (math.isfinite(prev[1]) and math.isfinite(cur[1])):
        return d, "no uncertainty"
    limit = 1.96 * math.hypot(prev[1], cur[1])
    return d, "yes" if abs(d) > limit else "no"


def table_rows(reports: list[SessionReport]) -> list[list[str]]:
    out = []
    for m in KEY:
        s = series(reports, m)
        if all(not math.isfinite(v) for v, _ in s):
            continue
        d, verdict = change(s[-2], s[-1])
        unit = words.MEASURES[m][1]
        cells = [words.number(v, m) for v, _ in s]
        out.append([words.name(m)] + cells + [words.number(d, m), verdict, unit or "—"])
    return out


def pages(reports: list[SessionReport]) -> list:
    tasks = {r.task for r in reports}

    def draw_table(fig):
        lines = [f"{len(reports)} sessions in date order: " +
                 ", ".join(f"{r.day} ({r.session_id}, {words.task_name(r.task)})" for r in reports)]
        if len(tasks) > 1:
            lines.append("Note: the sessions are of different tasks; compare like with like.")
        lines += ["Change: last session minus the one before. Exceeds uncertainty: the change is",
                  "larger than 1.96 × the combined SD of the two sessions (beyond uncertainty, 95 %).",
                  "The SD covers the tracking's uncertainty only, not every error of a measure."]
        layout.text_block(fig, 0.07, 0.905, lines, size=8.5, step=0.016)
        rows = table_rows(reports)
        n = len(reports)
        head = ["measure"] + [r.day + "\n" + r.session_id for r in reports] + \
               ["change", "exceeds uncertainty?", "unit"]
        w = [0.30] + [0.34 / n] * n + [0.1, 0.19, 0.07]
        h = 0.022 * (len(rows) + 2)
        layout.table(fig, [0.07, 0.83 - h, 0.86, h], rows, head, widths=w, size=7.5)

    def draw_plots(fig):
        shown = [m for m in KEY if any(math.isfinite(v) for v, _ in series(reports, m))][:8]
        for k, m in enumerate(shown):
            ax = fig.add_axes([0.10 + 0.45 * (k % 2), 0.70 - 0.205 * (k // 2), 0.36, 0.14])
            s = series(reports, m)
            x = list(range(1, len(s) + 1))
            ax.errorbar(x, [v for v, _ in s], yerr=[2 * sd if math.isfinite(sd) else 0 for _, sd in s],
                        color="black", marker="o", markerfacecolor="white", capsize=3, linewidth=1)
            ax.set_xticks(x, [r.day for r in reports], fontsize=7)
            unit = words.MEASURES[m][1]
            ax.set_title(words.name(m) + (f" ({unit})" if unit else ""), fontsize=8)
        fig.text(0.07, 0.9, "Each measure by session date; bars show ± 2 SD of the tracking's "
                 "uncertainty (none where it gives none).", fontsize=8.5)

    return [("Progress over sessions", draw_table), ("Progress over sessions: charts", draw_plots)]
