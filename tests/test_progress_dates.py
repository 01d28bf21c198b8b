"""The progress charts put sessions where they fall in time: two sessions a day apart and one
two months later are not drawn evenly spaced (ux13's finding); without every date, the order."""

from __future__ import annotations

import pytest

from armtrack_cli.report import progress

from .test_ux13_report import kin, report


def _sessions(dates: list[str]):
    return [report(session_id=f"s{i}", date=d,
                   kinematics=kin([(m, 40.0 + i, 0.5) for m in progress.KEY[:4]]))
            for i, d in enumerate(dates)]


def test_sessions_sit_at_their_days_since_the_first():
    rs = _sessions(["2026-10-01T10:00:00", "2026-10-02T10:00:00", "2026-12-01T16:00:00"])
    x, words = progress.positions(rs)
    assert x == pytest.approx([0.0, 1.0, 61.25])
    assert words == "days since the first session"
    at, labels = progress._ticks(x, rs)
    assert labels[0] == "2026-10-01" and labels[-1] == "2026-12-01"
    assert "2026-10-02" not in labels  # a day from the first on a 61-day axis: would overlap


def test_the_chart_draws_the_points_at_those_days():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rs = _sessions(["2026-10-01", "2026-10-02", "2026-10-31"])
    (title, draw), = progress.chart_pages(rs)
    fig = plt.figure()
    draw(fig)
    xs = {tuple(line.get_xdata()) for ax in fig.axes for line in ax.get_lines()
          if len(line.get_xdata()) == 3}
    plt.close(fig)
    assert xs == {(0.0, 1.0, 30.0)}


@pytest.mark.parametrize("dates", [["2026-10-01", ""], ["2026-10-01", "last Tuesday"],
                                   ["2026-10-01T10:00:00+02:00", "2026-10-02T10:00:00"]])
def test_without_every_date_the_sessions_are_in_order(dates):
    rs = _sessions(dates)
    x, words = progress.positions(rs)
    assert x == [1.0, 2.0] and words == "sessions in date order"


def test_at_most_four_dates_the_last_always_among_them():
    rs = _sessions([f"2026-{m:02d}-{d:02d}" for m in range(1, 13) for d in (1, 15)])
    x, _ = progress.positions(rs)
    at, labels = progress._ticks(x, rs)
    assert 2 <= len(labels) <= 4 and labels[0] == "2026-01-01" and labels[-1] == "2026-12-15"
    assert all(b - a >= (x[-1] - x[0]) / 6 for a, b in zip(at, at[1:]))
