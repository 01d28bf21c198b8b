"""Page 1: who and what, the key measures in plain words, the data quality and the verdict."""

from __future__ import annotations

import math

from armtrack_cli.report import layout, words
from armtrack_cli.report.data import SessionReport
from armtrack_cli.report.quality import coverage, coverage_text, verdict

ARM_ANGLES = ("elbow_flexion", "shoulder_elevation", "shoulder_plane", "forearm_pronation")
PALM_ANGLES = ("wrist_flexion", "wrist_deviation", "wrist_pronation")
PLAIN = {"movement_units": "movement units (sub-movements; fewer = smoother)",
         "sparc": "smoothness, SPARC (nearer 0 = smoother)",
         "segments": "separate movements found"}
KEY_WIDTH = 100  # characters of a key-measure line at its size on page 1
PATH = ("wrist_peak_speed", "wrist_mean_speed", "movement_time", "wrist_path_length",
        "movement_units", "sparc", "segments")


def lookup(r: SessionReport, measure: str, segment: str = "session") -> tuple[str | None, float]:
    """(value cell, sd) of a measure in kinematics-METHOD.csv; (None, nan) if absent."""
    k = r.kinematics
    if k is None:
        return None, float("nan")
    row = k[(k["measure"] == measure) & (k["segment"] == segment)]
    if not len(row):
        return None, float("nan")
    return str(row["value"].iloc[0]), float(row["sd"].iloc[0])


def over_movements(r: SessionReport, measure: str) -> tuple[float, int, float, float] | None:
    """(median, count, lowest, highest) of a measure over the session's movements (its numbered
    segments with a value), for the measures of one movement (SPARC, LDLJ) whose session row
    is not computable when the session holds several (measures/base.ONE_MOVEMENT); None
    without a segment value."""
    import numpy as np

    k = r.kinematics
    if k is None:
        return None
    rows = k[(k["measure"] == measure) & (k["segment"] != "session")]
    vals = np.array([as_number(v) for v in rows["value"]])
    vals = vals[np.isfinite(vals)]
    if not vals.size:
        return None
    return float(np.median(vals)), int(vals.size), float(vals.min()), float(vals.max())


def as_number(cell) -> float:
    """A kinematics value cell as a number; NaN for 'not computable: …' and empty cells."""
    try:
        return float(cell)
    except (TypeError, ValueError):
        return float("nan")


def value_text(r: SessionReport, measure: str, segment: str = "session") -> str | None:
    """'50.2° ± 2.2°' / '0.214 m/s ± 0.026 m/s' / 'not computable: why'; None if absent."""
    v, sd = lookup(r, measure, segment)
    if v is None:
        return None
    if v.startswith("not computable"):
        many = over_movements(r, measure) if segment == "session" else None
        if many is None or many[1] < 2:
            return v
        med, n, lo, hi = many
        return (f"median {words.with_unit(med, measure)} over {n} movements (from "
                f"{words.with_unit(lo, measure)} to {words.with_unit(hi, measure)})")
    out = words.with_unit(v, measure)
    if math.isfinite(sd):
        out += f" ± {words.sd_with_unit(sd, measure)}"
    return out


def angle_line(r: SessionReport, angle: str) -> str | None:
    rom = value_text(r, f"{angle}_rom")
    if rom is None:
        return None
    if rom.startswith("not computable"):
        return f"{words.ANGLES[angle]}: {rom}"
    lo, _ = lookup(r, f"{angle}_min")
    hi, _ = lookup(r, f"{angle}_max")
    return (f"{words.ANGLES[angle]}: range {rom}, from {words.with_unit(lo, f'{angle}_min')} "
            f"to {words.with_unit(hi, f'{angle}_max')}")


def key_lines(r: SessionReport) -> list[str]:
    out = []
    for a in (PALM_ANGLES if r.kind == "palm" else ARM_ANGLES):
        line = angle_line(r, a)
        if line:
            out.append(line)
    still = barely_moved(r)
    if still:
        out += words.lines_of(still, KEY_WIDTH)
    for m in () if still else PATH:
        v = value_text(r, m)
        if v is not None:
            out.append(f"{PLAIN.get(m, words.name(m))}: {v}")
    return out or ["no measures: " + ("; ".join(r.notes) or "no movement estimate")]


def barely_moved(r: SessionReport) -> str | None:
    """The words for a wrist whose peak speed is within 2 SD of the speed below which the
    measures call it still (measures/base.Settings.min_moving_speed): its path measures
    (speeds, movements, smoothness) are the estimate's noise, not movement (a palm session's
    still forearm: 0.010 ± 0.002 m/s, nine "movements"), so page 1 does not list them; the
    measures' table keeps them. None when the wrist moved clearly, or without a value."""
    from armtrack_cli.measures.base import DEFAULT

    v, sd = lookup(r, "wrist_peak_speed")
    peak = as_number(v)
    if not math.isfinite(peak) or peak - 2 * (sd if math.isfinite(sd) else 0.0) \
            >= DEFAULT.min_moving_speed:
        return None
    return (f"wrist path: no clear movement (peak speed {value_text(r, 'wrist_peak_speed')}, "
            f"within 2 SD of the {DEFAULT.min_moving_speed:g} m/s below which a wrist is still); "
            "its speeds and movements are not listed here (see the measures' table)")


def quality_lines(r: SessionReport) -> list[str]:
    q = r.quality
    out = []
    c = coverage(r)
    if c is not None:
        out.append(f"measures taken over {coverage_text(c)}")
    if math.isfinite(q.tracked_pct):
        out.append(f"frames in which the camera found the {'hand markers' if r.kind == 'palm' else 'wrist'}: "
                   f"{q.tracked_pct:.1f} % of {q.frames}")
    if q.imu_samples is not None:
        out.append(f"motion sensor: {q.imu_samples} samples, {q.imu_dropped or 0} lost, "
                   f"{q.imu_gaps or 0} gaps, longest interval {q.imu_longest_gap_s:.3f} s")
    if math.isfinite(q.reprojection_px):
        out.append(f"camera calibration reprojection error: {q.reprojection_px:.2f} px")
    offs = []
    for what, off in (("motion sensor", q.imu_offset_s), ("reference system", q.groundtruth_offset_s)):
        if off is not None:
            offs.append(f"{what} {off}" if isinstance(off, str)
                        else f"{what} {off:+.3f} s".replace("-", "−"))
    if offs:
        out.append("time offsets used: " + ", ".join(offs))
    if r.errors is not None and r.method is not None:
        e = r.errors[(r.errors["method"] == r.method) & (r.errors["joint"] == "wrist")
                     & (r.errors["axis"] == "3d")]
        n = int(e["n"].iloc[0]) if len(e) and "n" in e else None
        if len(e) and n != 0:
            out.append(f"wrist error against the reference motion capture: "
                       f"{e['rmse_cm'].iloc[0]:.2f} cm RMS, {e['within_5cm_pct'].iloc[0]:.1f} % "
                       f"of {'' if n is None else f'{n} '}frames within 5 cm")
        elif len(e):
            out.append("wrist error against the reference motion capture: no frame where both "
                       "the estimate and the reference have the wrist")
    elif r.method is not None and r.errors is None and r.truth_wrist is None:
        out.append("no reference motion capture compared with this session: its accuracy "
                   "is not measured here")
    return out


WIDTH = 90  # characters of 10 pt text across the page


def who_lines(r: SessionReport) -> list[str]:
    """Subject, session and date on one line; a long name or id on lines of their own, broken
    to the page's width (never cut: page 1 is where the full name is)."""
    when = f"Date: {r.date or 'not recorded'}"
    one = f"Subject: {r.subject}        Session: {r.session_id}        {when}"
    if len(one) <= WIDTH:
        return [one]
    return [*words.lines_of(f"Subject: {r.subject}", WIDTH),
            *words.lines_of(f"Session: {r.session_id}", WIDTH), when]


def page_one(r: SessionReport):
    def draw(fig):
        y = layout.text_block(fig, 0.07, 0.90, [
            *who_lines(r),
            f"Task: {words.task_name(r.task)}        Side: {r.side} {'hand' if r.kind == 'palm' else 'arm'}",
            f"Tracking method: {words.method_name(r.method, source=True)}",
            *([f"    (named {r.method} in the tables)"] if r.method else []),
        ], size=10, step=0.022)
        fig.text(0.07, y - 0.01, "Key measures (± the uncertainty the tracking gives)",
                 fontsize=11.5, weight="bold", va="top")
        y = layout.text_block(fig, 0.09, y - 0.04, key_lines(r), size=9.5, step=0.02)
        fig.text(0.07, y - 0.015, "Data quality", fontsize=11.5, weight="bold", va="top")
        y = layout.text_block(fig, 0.09, y - 0.045, quality_lines(r), size=9.5, step=0.02)
        v, reasons = verdict(r)
        fig.text(0.07, y - 0.02, f"Verdict: {v}", fontsize=13, weight="bold", va="top")
        lines = [("• " if i == 0 else "   ") + x for why in reasons
                 for i, x in enumerate(words.lines_of(why, WIDTH))]
        y = layout.text_block(fig, 0.09, y - 0.055, lines, size=9.5, step=0.02)
        layout.text_block(fig, 0.07, 0.10, [
            "How to read this: ranges of motion are the largest minus the smallest angle seen; the",
            "5th-95th percentile range ignores brief extremes. Movement time starts and ends where the",
            "hand speed crosses 2 % of its peak. Fewer movement units and smoothness values nearer 0",
            "mean smoother movement. Verdict thresholds: under 90 % of frames tracked, calibration",
            "error over 1 px, motion-sensor gaps over 0.1 s or wrist error over 5 cm ask for care.",
        ], size=8, step=0.015, color="0.25")

    return "Movement report", draw
