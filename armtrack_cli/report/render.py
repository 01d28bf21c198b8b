"""Pages in order, numbered, into one PDF (bytes; pipeline/report.py writes the file)."""

from __future__ import annotations

import io

from armtrack_cli.report import layout, words
from armtrack_cli.report.data import SessionReport


def session_pages(r: SessionReport) -> list:
    """The page-drawing functions of one session, each fig -> None."""
    from armtrack_cli.report import palm, summary, tables, trajectory, truth

    pages = [summary.page_one(r)]
    if r.trajectory is not None:
        pages += trajectory.pages(r)
    if r.kind == "palm":
        pages.append(palm.page(r))
    if r.truth_wrist is not None or r.errors is not None:
        pages += truth.pages(r)
    if r.kinematics is not None:
        pages += tables.pages(r)
    return pages


def plan(reports: list[SessionReport]) -> list[tuple[str, str, object]]:
    """The pages of one session's PDF, or of several of one subject's (progress first, then
    the first page of each), in order: (header text, title, draw)."""
    from armtrack_cli.report import progress, summary

    reports = sorted(reports, key=lambda r: (r.date or "", r.session_id))
    planned = []
    if len(reports) > 1:
        span = f"{reports[0].day} to {reports[-1].day}"
        left = f"Subject {words.clip(reports[0].subject, 40)} · {len(reports)} sessions, {span}"
        planned += [(left, t, d) for t, d in progress.pages(reports)]
    for r in reports:  # several sessions: each one's first page (its own report has the rest)
        left = (f"Subject {words.clip(r.subject, 40)} · session of {r.day} "
                f"({words.clip(r.session_id, 24)})")
        pages = session_pages(r) if len(reports) == 1 else [summary.page_one(r)]
        planned += [(left, t, d) for t, d in pages]
    return planned


def render(reports: list[SessionReport]) -> bytes:
    """The PDF of plan(reports)."""
    plt = layout.setup()
    import matplotlib
    from matplotlib.backends.backend_pdf import PdfPages

    from armtrack_cli.report import fonts

    family, unknown = fonts.families(r.text() for r in reports)
    matplotlib.rcParams["font.family"] = family  # fallbacks for a name DejaVu Sans lacks
    planned = plan(reports)
    buf = io.BytesIO()
    meta = {"Title": f"Movement report, subject {reports[0].subject}", "Creator": "armtrack",
            "CreationDate": None, "ModDate": None}  # no clock: same inputs, same bytes
    with fonts.one_glyph_warning(unknown), PdfPages(buf, metadata=meta) as pdf:
        for n, (left, title, draw) in enumerate(planned, 1):
            fig = layout.page(plt, title)
            layout.header(fig, left, n, len(planned))
            draw(fig)
            pdf.savefig(fig)
            plt.close(fig)
    return buf.getvalue()
