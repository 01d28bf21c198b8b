"""The clinician report: an A4 PDF of one session, or of several sessions of one subject.

    data.py        what a page may show, gathered by pipeline/report.py (no file access here)
    words.py       plain names, units and number formats (one rule for every page and test)
    quality.py     the data-quality verdict and its reasons
    layout.py      A4 pages with the subject, date and page number; greyscale-safe styles
    fonts.py       fallback fonts for a name DejaVu Sans lacks (CJK, …); one warning if none
    summary.py     page 1: who and what, the key measures in words, data quality, verdict
    trajectory.py  wrist position with its uncertainty band, top and side views, elbow angle,
                   speed with the movement units
    truth.py       against ground truth: error over time with the ±5 cm band, Table I,
                   each measure's error
    palm.py        the three wrist angles over time with their ranges
    tables.py      every measure with its uncertainty, per segment
    progress.py    several sessions: each measure by date, the change and whether it exceeds
                   the uncertainty (not judged across tracking methods), four sessions a table

matplotlib is imported only when a report is drawn (Agg backend, real text in the PDF).
"""

from armtrack_cli.report.data import Quality, SessionReport
from armtrack_cli.report.render import render

__all__ = ["Quality", "SessionReport", "render"]
