"""ux13: what the clinician's report says, checked on small hand-made reports (no pipeline run).

Each test failed before its fix: a subject's name in Chinese printed boxes with a warning per
glyph per page; a long name ran off page 1 and over the page number; the measures of a session
whose tracking had the wrist for 4 s of 20 were printed without saying so; a session without a
reference said nothing of it; Table I printed "nan"; a progress report of 22 sessions squeezed
them into one unreadable table and judged changes across tracking methods; its charts cut the
y-axis to the values; a palm session's tracked share counted only up to its last blob; the
wrist angular speeds had no unit; `report --json` gave no verdict."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest

from armtrack_cli.pipeline.coverage import tracked as _tracked
from armtrack_cli.pipeline.report import _verdict
from armtrack_cli.report import SessionReport, fonts, progress, quality, render, summary, truth, words
from armtrack_cli.session.workfolder import WorkFolder

pypdf = pytest.importorskip("pypdf")


def kin(rows, t0=0.0, t1=19.966667) -> pd.DataFrame:
    """kinematics rows (measure, value, sd) of the session segment over [t0, t1]."""
    return pd.DataFrame([{"measure": m, "segment": "session", "value": str(v), "sd": sd,
                          "unit": "", "t_start": t0, "t_end": t1} for m, v, sd in rows])


def report(**kw) -> SessionReport:
    t = np.arange(600) / 30.0
    base = dict(session_id="s1", subject="AB", date="2026-11-20T10:15:00", task="circle",
                side="right", kind="arm", method="arm-smoother",
                trajectory=pd.DataFrame({"t": t, "wrist_x": 0.1, "wrist_y": 0.2, "wrist_z": 0.0}),
                kinematics=kin([("wrist_peak_speed", 0.2, 0.01)]))
    base.update(kw)
    return SessionReport(**base)


def pdf_text(pdf: bytes, tmp_path) -> str:
    p = tmp_path / "r.pdf"
    p.write_bytes(pdf)
    return "\n".join(pg.extract_text() for pg in pypdf.PdfReader(str(p)).pages)


def test_a_name_in_chinese_gives_one_warning_at_most_and_its_characters_where_a_font_has_them(tmp_path):
    name = "王小明"
    r = report(subject=name, trajectory=None, kinematics=None)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        pdf = render([r])
    said = [str(w.message) for w in caught]
    assert not [w for w in said if "Glyph" in w], said  # matplotlib's one per glyph per page
    family, unknown = fonts.families([name])
    if unknown:  # no installed font has them (e.g. CI): one line that says so and what to do
        assert len(said) == 1 and "no installed font has the characters" in said[0], said
        assert all(c in said[0] for c in unknown)
    else:  # a font with them is installed: the fallback prints them, no warning
        assert len(family) > 1 and not said, said
        assert name in pdf_text(pdf, tmp_path)


def test_a_name_dejavu_has_needs_no_fallback_font():
    """ASCII and European names keep DejaVu Sans alone (the PDF's bytes as before)."""
    assert fonts.families(["Müller-Łukasiewicz Ωmega", "SIM"]) == (["DejaVu Sans"], "")


def test_a_long_name_is_broken_on_page_one_and_cut_in_the_header(tmp_path):
    name = ("Maria-Concepción Fernández de la Santísima Trinidad y Villanueva-Rodríguez "
            "(study ID 2026-REHAB-00417)")
    r = report(subject=name)
    lines = summary.who_lines(r)
    assert all(len(x) <= summary.WIDTH for x in lines)
    assert " ".join(lines).startswith("Subject: " + name[:60])
    assert any(x.startswith("Date: 2026-11-20") for x in lines)
    assert len(words.clip(name, 40)) == 40 and words.clip("SIM", 40) == "SIM"
    text = pdf_text(render([r]), tmp_path)
    assert "Date: 2026-11-20" in text and "page 1 of" in text
    assert summary.who_lines(report()) == [
        "Subject: AB        Session: s1        Date: 2026-11-20T10:15:00"]  # short: one line


def test_measures_over_part_of_the_recording_say_over_which_and_ask_for_care():
    r = report(kinematics=kin([("wrist_peak_speed", 0.18, 0.01)], t0=16.0, t1=19.966667))
    a, b, total = quality.coverage(r)
    assert (round(a, 3), round(b, 3), round(total, 3)) == (16.0, 20.0, 20.0)
    v, reasons = quality.verdict(r)
    assert v == "usable with care"
    assert any("cover only 4.0 s of the 20.0 s recorded (16.0 to 20.0 s)" in x for x in reasons)
    assert "measures taken over 4.0 s of the 20.0 s recorded (16.0 to 20.0 s)" in \
        summary.quality_lines(r)
    assert quality.verdict(report())[0] == "good"  # the whole recording: nothing to say
    j = _verdict(r)
    assert j["verdict"] == "usable with care" and j["measured_s"] == 4.0 and j["recorded_s"] == 20.0
    assert j["reasons"] == reasons


def test_a_session_without_a_reference_says_its_accuracy_is_not_measured():
    lines = summary.quality_lines(report())
    assert any("no reference motion capture" in x for x in lines)
    e = pd.DataFrame([{"method": "arm-smoother", "joint": "wrist", "axis": "3d", "rmse_cm": 0.5,
                       "within_5cm_pct": 100.0, "n": 120}])
    lines = summary.quality_lines(report(errors=e))
    assert "0.50 cm RMS, 100.0 % of 120 frames within 5 cm" in " ".join(lines)
    assert not any("no reference" in x for x in lines)


def test_table_one_prints_a_dash_not_nan_where_no_frame_was_compared():
    nan = float("nan")
    e = pd.DataFrame([{"method": "pf", "joint": "elbow", "axis": a, "mean_cm": nan, "std_cm": nan,
                       "rmse_cm": nan, "within_5cm_pct": nan, "n": 0}
                      for a in ("x", "y", "z", "3d")])
    row = truth.table_one_rows(e, "elbow")[0]
    assert row[1:] == ["—/—", "—/—", "—/—", "—", "—"]
    assert "nan" not in " ".join(row).lower()


def sessions(n: int, odd: int | None = None) -> list[SessionReport]:
    return [report(session_id=f"circle-{i:02d}", date=f"2026-10-{i:02d}T10:00:00",
                   method="pf-constraint" if i == odd else "arm-smoother",
                   kinematics=kin([(m, 48.6 + 0.1 * i, 0.5) for m in progress.KEY[:10]]))
            for i in range(1, n + 1)]


def test_a_change_across_two_tracking_methods_is_not_judged_and_the_mix_is_said():
    rs = sessions(3, odd=3)
    row = progress.table_rows(rs)[0]
    assert row[-2] == "not judged: other method"
    intro = " ".join(progress.intro_lines(rs))
    assert "different methods" in intro and "pf-constraint: circle-03" in intro
    assert progress.table_rows(sessions(3))[0][-2] in ("yes", "no")


def test_twenty_two_sessions_make_readable_tables_over_pages(tmp_path):
    rs = sessions(22, odd=5)
    pages = progress.table_pages(rs)
    assert len(pages) >= 2  # six tables of at most four sessions, not one of 22 columns
    assert len(progress.intro_lines(rs)) < 12  # the sessions are named in the tables
    text = pdf_text(render(rs), tmp_path)
    for r in rs:
        assert r.session_id in text and r.day in text


def test_progress_charts_do_not_blow_up_a_small_change():
    assert progress._limits([17.1, 17.1, 17.55]) == pytest.approx((15.57, 19.08), abs=0.01)
    assert progress._limits([1.0, 3.0]) is None  # a change as large as that: left to matplotlib


def test_a_palm_sessions_tracked_share_counts_every_video_frame(tmp_path):
    rows = [{"frame": f, "t": f / 30, "blob": b, "u": 1.0, "v": 1.0, "area": 9, "score": 1}
            for f in range(50) for b in range(3)]
    pd.DataFrame(rows).to_csv(tmp_path / "detections.csv", index=False)
    pct, n = _tracked(WorkFolder(tmp_path), "palm", 100)  # the last 50 frames: no blob
    assert (pct, n) == (50.0, 100)
    assert _tracked(WorkFolder(tmp_path), "palm")[0] == 100.0  # without the video's count


def test_wrist_angular_speeds_have_their_unit_and_name():
    for a in ("flexion", "deviation", "pronation"):
        for k in ("peak", "mean"):
            m = f"wrist_{a}_{k}_speed"
            assert words.with_unit(139.5567, m) == "139.6 °/s"
            assert "angular speed" in words.name(m)


def test_a_counts_sd_is_not_rounded_to_zero():
    """movement units 4 with an SD of 0.36 units printed "4 ± 0" (the count's 0 decimals)."""
    assert words.sd_number(0.36162, "movement_units") == "0.4"
    assert words.sd_number(0.008354, "wrist_peak_speed") == "0.008"  # others: their decimals
    assert words.sd_number(0.00031, "wrist_mean_speed") == "0.0003"  # long-10: "± 0.000"
    assert words.sd_number(0.0, "wrist_mean_speed") == "0.000"
    r = report(kinematics=kin([("movement_units", 4.0, 0.36162)]))
    assert summary.value_text(r, "movement_units") == "4 ± 0.4"


def test_compare_json_gives_the_3d_accuracy_with_null_for_no_frames():
    """`compare --json` named only the CSVs: a CI script had to parse errors.csv for the RMSE."""
    import json

    from armtrack_cli.compare.errors import accuracy_3d, error_rows

    rng = np.random.default_rng(0)
    truth_xyz = rng.normal(size=(50, 3))
    est = truth_xyz + 0.01  # 1 cm on each axis: 3-D error √3 cm on every frame
    rows = error_rows("arm-smoother", "wrist", est, truth_xyz)
    rows += error_rows("arm-smoother", "elbow", est, np.full_like(est, np.nan))  # no frame
    acc = accuracy_3d(rows)
    assert acc["arm-smoother"]["wrist"] == {"rmse_cm": round(np.sqrt(3), 4),
                                            "within_5cm_pct": 100.0, "n": 50}
    assert acc["arm-smoother"]["elbow"] == {"rmse_cm": None, "within_5cm_pct": None, "n": 0}
    json.dumps(acc, allow_nan=False)  # valid JSON: no NaN


def test_dozens_of_movements_are_tabled_over_pages_inside_the_page():
    """A 10-minute session's movements were drawn as one page's tables, most below its foot."""
    from armtrack_cli.report import layout, tables

    segs = [{"measure": m, "segment": str(n), "value": "1.0", "sd": 0.1, "unit": "",
             "t_start": n, "t_end": n + 1}
            for n in range(1, 61) for m in ("wrist_peak_speed", "movement_time", "sparc")]
    r = report(kinematics=pd.concat([kin([("wrist_peak_speed", 0.2, 0.01)]), pd.DataFrame(segs)]))
    pages = tables.pages(r)[1:]
    assert len(pages) >= 2
    plt = layout.setup()
    for _title, draw in pages:
        fig = layout.page(plt, _title)
        draw(fig)
        for ax in fig.axes:
            assert ax.get_position().y0 >= 0.0, ax.get_position()
        plt.close(fig)
