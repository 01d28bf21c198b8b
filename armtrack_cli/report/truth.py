"""Against the reference motion capture: error over time with the ±5 cm band (Tao & Hu 2008,
Fig. 7), their Table I (mean/SD per axis, cm) for every method, and each measure's error."""

from __future__ import annotations

import numpy as np

from armtrack_cli.report import layout, words
from armtrack_cli.report.data import SessionReport

XYZ = ("x", "y", "z")


def error_page(r: SessionReport):
    def draw(fig):
        d = r.trajectory
        t = d["t"].to_numpy()
        e = (d[[f"wrist_{a}" for a in XYZ]].to_numpy() - r.truth_wrist) * 100
        for k, a in enumerate(XYZ):
            ax = fig.add_axes([0.11, 0.66 - 0.28 * k, 0.82, 0.22])
            ax.axhspan(-5, 5, **layout.BAND, label="± 5 cm")
            ax.axhline(5, **layout.LIMIT)
            ax.axhline(-5, **layout.LIMIT)
            ax.plot(t, e[:, k], **layout.ESTIMATE, label=f"error of the {words.method_name(r.method)}")
            ax.set_ylabel(f"{a} error (cm)")
            lim = max(8.0, float(np.nanmax(np.abs(e[:, k]))) * 1.1) if np.isfinite(e[:, k]).any() else 8
            ax.set_ylim(-lim, lim)
            if k == 0:
                ax.legend(loc="upper right")
            if k == 2:
                ax.set_xlabel("time (s)")
        fig.text(0.07, 0.90, "Estimate minus reference motion capture, per axis; gaps in the "
                 "reference are left empty.", fontsize=9)

    return "Wrist error against the reference", draw


def _cm(x, decimals: int = 2) -> str:
    """A Table I cell: "—" where errors.csv has none (no frame with both the estimate and the
    reference: n = 0), never "nan"."""
    x = float(x)
    return f"{x:.{decimals}f}".replace("-", "−") if np.isfinite(x) else "—"


def table_one_rows(errors, joint: str) -> list[list[str]]:
    out = []
    for m in dict.fromkeys(errors["method"]):
        by = errors[(errors["method"] == m) & (errors["joint"] == joint)].set_index("axis")
        if not len(by):
            continue
        cells = [f"{_cm(by.loc[a, 'mean_cm'])}/{_cm(by.loc[a, 'std_cm'])}" for a in XYZ]
        out.append([f"{words.method_name(m)} ({m})"] + cells +
                   [_cm(by.loc["3d", "rmse_cm"]), _cm(by.loc["3d", "within_5cm_pct"], 1)])
    return out


def table_page(r: SessionReport):
    def draw(fig):
        y = 0.88
        for joint in ("wrist", "elbow"):
            rows = table_one_rows(r.errors, joint)
            if not rows:
                continue
            fig.text(0.07, y, f"{joint.capitalize()} error, mean/SD of each axis (cm), as Tao & Hu's "
                     "Table I", fontsize=10, weight="bold", va="top")
            layout.table(fig, [0.07, y - 0.05 - 0.03 * len(rows), 0.86, 0.03 * (len(rows) + 1)],
                         rows, ["method", "x (cm)", "y (cm)", "z (cm)", "3-D RMS",
                                "% in ±5 cm"], widths=[0.44, 0.12, 0.12, 0.12, 0.10, 0.10],
                         size=7.2)
            y -= 0.10 + 0.035 * len(rows)
        layout.text_block(fig, 0.07, y, [
            "Mean/SD: the mean and standard deviation of the error (estimate − reference) along each",
            "axis of the table's frame; 3-D RMS: root-mean-square distance (cm); % in ±5 cm: the share",
            "of frames whose 3-D error is 5 cm or less (Tao & Hu's acceptance band).",
            "Frames where the reference lost the marker are left out."], size=8.5, step=0.016)
    return "Accuracy against the reference", draw


def measures_page(r: SessionReport):
    return "Measures against the reference", lambda fig: measure_table(fig, r, 0.90)


def measure_table(fig, r: SessionReport, y: float) -> None:
    from armtrack_cli.report.tables import Notes

    notes = Notes()
    m = r.measures[r.measures["segment"] == "session"]
    rows = []
    for x in m.itertuples(index=False):
        unit = words.MEASURES.get(x.measure, ("", "", 3))[1]
        err = words.number(x.error, x.measure).replace("not computable", "—")
        pct = "—" if not np.isfinite(x.error_pct) else f"{x.error_pct:.1f} %".replace("-", "−")
        rows.append([words.name(x.measure), notes.cell(str(x.estimate), x.measure),
                     notes.cell(str(x.truth), x.measure), err, pct, unit or "—"])
    fig.text(0.07, y, "Each measure over the whole session: estimate, reference motion capture "
             "and error (estimate − reference)", fontsize=9, va="top")
    h = 0.0165 * (len(rows) + 1)
    layout.table(fig, [0.07, y - 0.02 - h, 0.86, h], rows,
                 ["measure", "estimate", "reference", "error", "error, %", "unit"],
                 widths=[0.34, 0.16, 0.16, 0.12, 0.12, 0.10], size=7)
    layout.text_block(fig, 0.07, y - 0.035 - h, notes.lines(), size=7.5, step=0.014)


def pages(r: SessionReport) -> list:
    out = []
    if r.truth_wrist is not None and np.isfinite(r.truth_wrist).any():
        out.append(error_page(r))
    if r.errors is not None:
        out.append(table_page(r))
    if r.measures is not None:
        out.append(measures_page(r))
    return out
