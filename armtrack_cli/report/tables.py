"""Every measure of the session, and each movement's measures side by side, with their
uncertainty; a cell that cannot be computed points to a numbered note saying why."""

from __future__ import annotations

import math

from armtrack_cli.report import layout, words
from armtrack_cli.report.data import SessionReport

PER_BLOCK = 6  # movements per block of columns


class Notes:
    """Numbered reasons for "not computable" cells, each reason once."""

    def __init__(self):
        self.items: list[str] = []

    def cell(self, value: str, measure: str) -> str:
        if not value.startswith("not computable"):
            return words.number(value, measure)
        why = value.split(":", 1)[1].strip() if ":" in value else "no reason given"
        if why not in self.items:
            self.items.append(why)
        return f"not computable ({self.items.index(why) + 1})"

    def lines(self) -> list[str]:
        return [f"({n}) not computable: {why}" for n, why in enumerate(self.items, 1)]


def _sd(x: float, measure: str) -> str:
    return words.sd_number(x, measure) if math.isfinite(x) else "—"


def session_rows(r: SessionReport, notes: Notes) -> list[list[str]]:
    k = r.kinematics[r.kinematics["segment"] == "session"]
    return [[words.name(x.measure), notes.cell(str(x.value), x.measure), _sd(x.sd, x.measure),
             words.MEASURES.get(x.measure, ("", "", 3))[1] or "—"] for x in k.itertuples(index=False)]


def movement_blocks(r: SessionReport, notes: Notes) -> list[tuple[list[str], list[list[str]]]]:
    """[(header, rows)]: measures down, movements across (value ± SD), PER_BLOCK at a time."""
    k = r.kinematics[r.kinematics["segment"] != "session"]
    segs = list(dict.fromkeys(k["segment"]))
    measures = list(dict.fromkeys(k["measure"]))
    cell = {(x.measure, x.segment): (str(x.value), x.sd) for x in k.itertuples(index=False)}
    out = []
    for i in range(0, len(segs), PER_BLOCK):
        block = segs[i:i + PER_BLOCK]
        rows = []
        for m in measures:
            row = [words.name(m) + (f" ({words.MEASURES[m][1]})" if words.MEASURES.get(m, ("", ""))[1]
                                    else "")]
            for sgm in block:
                v, sd = cell.get((m, sgm), ("not computable: not measured", float("nan")))
                shown = notes.cell(v, m)
                row.append(shown + (f" ± {_sd(sd, m)}" if math.isfinite(sd) and
                                    not shown.startswith("not") else ""))
            rows.append(row)
        # the number alone: "movement 100" did not fit a column of six
        out.append((["measure / movement no."] + [str(sgm) for sgm in block], rows))
    return out


def pages(r: SessionReport) -> list:
    notes, m_notes = Notes(), Notes()
    srows = session_rows(r, notes)
    blocks = movement_blocks(r, m_notes)

    def draw_session(fig):
        fig.text(0.07, 0.905, "± is the spread over draws from the tracking's uncertainty "
                 "(— where it gives none).", fontsize=8.5)
        h = 0.0165 * (len(srows) + 1)
        layout.table(fig, [0.07, 0.885 - h, 0.86, h], srows, ["measure", "value", "±", "unit"],
                     widths=[0.52, 0.22, 0.13, 0.13], size=7.5)
        layout.text_block(fig, 0.07, 0.885 - h - 0.015, notes.lines(), size=7.5, step=0.014)

    out = [("Measures of the whole session", draw_session)]
    return out + movement_pages(blocks, m_notes)


def movement_pages(blocks, notes: Notes) -> list:
    """The movements' blocks, as many a page as fit (a 10-minute session has dozens of
    movements: one page drew them far below its foot); the notes after the last."""
    plan: list[list] = [[]]
    y = 0.885
    for head, rows in blocks:
        h = 0.0165 * (len(rows) + 1)
        if y - h < 0.05 and plan[-1]:
            plan.append([])
            y = 0.885
        plan[-1].append((y, h, head, rows))
        y -= h + 0.03
    foot = 0.014 * len(notes.lines())
    if blocks and y - foot < 0.04:
        plan.append([])  # the notes on a page of their own

    def drawer(mine, last):
        def draw(fig):
            fig.text(0.07, 0.905, "Each movement found (lap, reach or return), in time order; "
                     "value ± the tracking's uncertainty.", fontsize=8.5)
            y = 0.885
            for y, h, head, rows in mine:
                w0 = 0.31
                layout.table(fig, [0.07, y - h, 0.86, h], rows, head,
                             widths=[w0] + [(1 - w0) / (len(head) - 1)] * (len(head) - 1),
                             size=6.8)
                y -= h + 0.03
            if last:
                layout.text_block(fig, 0.07, y, notes.lines(), size=7.5, step=0.014)
        return draw

    if not blocks:
        return []
    return [("Measures of each movement", drawer(mine, k == len(plan) - 1))
            for k, mine in enumerate(plan)]
