"""A4 pages with a header (subject, session date, page number) and greyscale-safe styles."""

from __future__ import annotations

A4 = (8.27, 11.69)  # inches, portrait
# lines that stay apart in greyscale: black solid, grey dashed, dark grey dotted
ESTIMATE = {"color": "black", "linestyle": "-", "linewidth": 1.2}
TRUTH = {"color": "0.45", "linestyle": "--", "linewidth": 1.2}
THIRD = {"color": "0.25", "linestyle": ":", "linewidth": 1.4}
BAND = {"color": "0.80", "linewidth": 0}
LIMIT = {"color": "0.35", "linestyle": "-.", "linewidth": 0.9}
STYLES = (ESTIMATE, TRUTH, THIRD)


def setup():
    """matplotlib with the Agg backend and TrueType fonts (searchable text in the PDF)."""
    import matplotlib

    matplotlib.use("Agg", force=True)
    matplotlib.rcParams.update({"pdf.fonttype": 42, "font.size": 9, "axes.titlesize": 10,
                                "axes.labelsize": 9, "legend.fontsize": 8,
                                "font.family": "DejaVu Sans", "axes.grid": True,
                                "grid.color": "0.88", "grid.linewidth": 0.6})
    import matplotlib.pyplot as plt

    return plt


def page(plt, title: str):
    """A new A4 figure with its title; the header is added by ``header`` once pages are counted."""
    fig = plt.figure(figsize=A4)
    fig.text(0.07, 0.935, title, fontsize=14, weight="bold", va="top")
    return fig


def header(fig, left: str, number: int, total: int) -> None:
    fig.text(0.07, 0.972, left, fontsize=8.5, va="top")
    fig.text(0.93, 0.972, f"page {number} of {total}", fontsize=8.5, va="top", ha="right")
    fig.add_artist(_rule(fig, 0.958))


def _rule(fig, y):
    from matplotlib.lines import Line2D

    return Line2D([0.07, 0.93], [y, y], transform=fig.transFigure, color="0.3", linewidth=0.6)


def text_block(fig, x: float, y: float, lines: list[str], *, size: float = 9.5,
               step: float = 0.018, **kw) -> float:
    """Lines of text from (x, y) downwards (figure fraction); returns the y below the last."""
    for line in lines:
        fig.text(x, y, line, fontsize=size, va="top", **kw)
        y -= step
    return y


def table(fig, rect, rows: list[list[str]], header: list[str], *, widths=None, size=8.0):
    """A plain table in an axes at rect (figure fraction); header row in bold."""
    ax = fig.add_axes(rect)
    ax.axis("off")
    t = ax.table(cellText=rows, colLabels=header, bbox=[0, 0, 1, 1], cellLoc="left",
                 colLoc="left", colWidths=widths)  # the table fills rect exactly
    t.auto_set_font_size(False)
    t.set_fontsize(size)
    for (r, _c), cell in t.get_celld().items():
        cell.set_edgecolor("0.7")
        cell.set_linewidth(0.4)
        if r == 0:
            cell.set_text_props(weight="bold")
            cell.set_facecolor("0.92")
    return ax
