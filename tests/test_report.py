"""`armtrack report` and the measures on simulated sessions with ground truth (issue 12).

The arm session is the bundled circle-01 (20 s, Xsens export, Qualisys with two gaps in the
wrist marker), run through calibrate, detect, fuse (arm-smoother and ekf) and compare into a tmp
work folder. The palm session is the bundled wrist-rom-01 with a synthetic trajectory-ukf-palm
.csv made from its exact truth plus seeded noise (the ukf-palm method is another issue).
"""

from __future__ import annotations

import re
import shutil

import numpy as np
import pandas as pd
import pytest

from armtrack_cli.compare.errors import truth_at
from armtrack_cli.pipeline.kinematics import (
    kinematics_table,
    measure_comparison,
    trajectory_inputs,
    truth_inputs,
)
from armtrack_cli.report import progress
from armtrack_cli.session.config import load_session
from armtrack_cli.session.qualisys import read_qualisys, select_markers, to_world

from .conftest import REPO, run_cli

pypdf = pytest.importorskip("pypdf")
SAMPLES = REPO / "sample_sessions"


def pdf_pages(path) -> list[str]:
    return [p.extract_text() for p in pypdf.PdfReader(str(path)).pages]


def shown(x: float, decimals: int) -> str:
    """The report's number format: fixed decimals, a true minus sign."""
    return f"{x:.{decimals}f}".replace("-", "−")


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    out = tmp_path_factory.mktemp("circle")
    s = SAMPLES / "circle-01"
    for args in (("calibrate",), ("detect",), ("fuse", "--seed", "1"), ("fuse", "--method", "ekf"),
                 ("compare",)):
        r = run_cli(args[0], s, *args[1:], "--out", out)
        assert r.exit_code == 0, r.stderr
    r = run_cli("report", s, "--out", out)
    assert r.exit_code == 0, r.stderr
    return s, out


def test_measures_agree_with_qualisys_on_a_simulated_session(arm):
    """Issue 12's goals, measured by compare: elbow RoM within 3°, peak wrist speed within
    5 %, path length within 3 %."""
    _, out = arm
    m = pd.read_csv(out / "measures.csv", dtype={"segment": str})
    m = m[(m["method"] == "arm-smoother") & (m["segment"] == "session")].set_index("measure")
    assert abs(m.loc["elbow_flexion_rom", "error"]) <= 3.0
    assert abs(m.loc["wrist_peak_speed", "error_pct"]) <= 5.0
    assert abs(m.loc["wrist_path_length", "error_pct"]) <= 3.0
    assert {"estimate", "estimate_sd", "truth", "error", "error_pct", "unit"} <= set(m.columns)


def test_every_page_is_a4_and_headed_with_subject_date_and_page_number(arm):
    _, out = arm
    reader = pypdf.PdfReader(str(out / "report.pdf"))
    n = len(reader.pages)
    assert n >= 8
    for k, page in enumerate(reader.pages, 1):
        w, h = float(page.mediabox.width), float(page.mediabox.height)
        assert abs(w - 595.3) < 1 and abs(h - 841.9) < 1  # A4 in points
        text = page.extract_text()
        assert "Subject SIM" in text and "2026-11-20" in text and f"page {k} of {n}" in text
        assert "trajectory-" not in text and ".csv" not in text  # no file names or paths
        assert not re.search(r"/(tmp|work|home|sample_sessions)|armtrack/", text)


def test_the_pdf_text_holds_the_numbers_of_the_csvs(arm):
    """The report prints speeds and lengths to 3 decimals, times to 2, angles to 1, counts
    as integers; each session measure of kinematics-arm-smoother.csv, each estimate and
    reference of measures.csv and each Table I cell of errors.csv is found in the text."""
    _, out = arm
    text = "\n".join(pdf_pages(out / "report.pdf"))
    kin = pd.read_csv(out / "kinematics-arm-smoother.csv", dtype={"value": str, "segment": str},
                      keep_default_na=False)
    decimals = lambda m: (1 if m.startswith(("elbow", "shoulder", "forearm")) else  # noqa: E731
                          0 if m in ("movement_units", "segments") else
                          2 if m in ("movement_time", "time_to_peak_speed", "sparc", "ldlj",
                                     "straightness") else 3)
    checked = 0
    for r in kin.itertuples(index=False):
        if r.value.startswith("not computable"):
            assert r.value.split(":", 1)[1].strip() in text
            continue
        assert shown(float(r.value), decimals(r.measure)) in text, r
        checked += 1
    assert checked >= 20
    m = pd.read_csv(out / "measures.csv", dtype={"segment": str, "estimate": str, "truth": str},
                    keep_default_na=False)
    for r in m[(m["method"] == "arm-smoother") & (m["segment"] == "session")].itertuples():
        for v in (r.estimate, r.truth):
            if not v.startswith("not computable"):
                assert shown(float(v), decimals(r.measure)) in text, r
    e = pd.read_csv(out / "errors.csv")
    for r in e[e["axis"] != "3d"].itertuples():
        assert f"{shown(r.mean_cm, 2)}/{shown(r.std_cm, 2)}" in text, r
    wrist = e[(e["method"] == "arm-smoother") & (e["joint"] == "wrist") & (e["axis"] == "3d")]
    assert f"{wrist['rmse_cm'].iloc[0]:.2f} cm RMS" in text


def test_the_first_page_says_who_what_and_the_verdict(arm):
    _, out = arm
    first = pdf_pages(out / "report.pdf")[0]
    for words in ("Subject: SIM", "circles on the table", "right arm",
                  "orientation-aware arm smoother", "elbow flexion (0° = straight arm)",
                  "frames in which the camera found the wrist", "samples", "lost",
                  "reprojection error", "time offsets used", "Verdict: "):
        assert words in first, words
    assert re.search(r"Verdict: (good|usable with care|not usable)", first)


def test_smoothness_of_several_movements_is_their_median_on_the_first_page(arm):
    """circle-01 holds three movements: its session SPARC is not computable (one movement's
    measure, measures/base.ONE_MOVEMENT); page 1 gives the median over the movements from
    kinematics CSV's segment rows, with their range."""
    _, out = arm
    k = pd.read_csv(out / "kinematics-arm-smoother.csv", dtype={"value": str, "segment": str})
    sparc = k[k["measure"] == "sparc"]
    assert sparc[sparc["segment"] == "session"]["value"].iloc[0].startswith("not computable")
    seg = sparc[sparc["segment"] != "session"]["value"].astype(float).to_numpy()
    assert seg.size >= 2
    first = " ".join(pdf_pages(out / "report.pdf")[0].split())
    line = (f"smoothness, SPARC (nearer 0 = smoother): median {shown(np.median(seg), 2)} over "
            f"{seg.size} movements (from {shown(seg.min(), 2)} to {shown(seg.max(), 2)})")
    assert line in first


def _synthetic_palm(work, seed=7):
    """trajectory-ukf-palm.csv from the exact truth of wrist-rom-01: angles + 0.5° noise,
    WRIST marker + 1 mm noise, both smoothed over 0.5 s (a filter's errors are smooth), with
    SD columns."""
    tr = dict(np.load(SAMPLES / "wrist-rom-01.truth.npz"))
    rng = np.random.default_rng(seed)
    t = tr["frame_t"]
    smooth = lambda sd: np.apply_along_axis(  # noqa: E731
        lambda x: np.convolve(x, np.ones(15) / np.sqrt(15), "same"), 0,
        rng.normal(0, sd, (t.size, 3)))
    ang = tr["frame_angles_deg"] + smooth(0.5)
    w = tr["frame_wrist"] + smooth(0.001)
    cols = {"t": t, **{f"wrist_{a}": w[:, k] for k, a in enumerate("xyz")},
            **{f"wrist_{a}_sd": np.full(t.size, 0.001) for a in "xyz"},
            "flexion_deg": ang[:, 0], "deviation_deg": ang[:, 1], "pronation_deg": ang[:, 2],
            **{f"{n}_sd": np.full(t.size, 0.5) for n in ("flexion_deg", "deviation_deg",
                                                         "pronation_deg")}}
    traj = pd.DataFrame(cols)
    traj.to_csv(work / "trajectory-ukf-palm.csv", index=False)
    return traj, tr


def test_palm_wrist_angle_ranges_against_qualisys_and_the_palm_pages(tmp_path):
    """The wrist-angle RoM of a synthetic estimate against the one compare derives from the
    Qualisys palm markers: within 2°. The reference's own angles (hand frame from three
    markers, 0.3 mm marker noise) match the simulator's exact angles within 2° (0.5° mean)."""
    s = load_session(SAMPLES / "wrist-rom-01")
    traj, exact = _synthetic_palm(tmp_path)
    kin = kinematics_table(traj, s)
    kin.to_csv(tmp_path / "kinematics-ukf-palm.csv", index=False)
    qtm = read_qualisys(s.groundtruth.file)
    cols = select_markers(qtm, s.groundtruth.markers, s.toml_path)
    t = traj["t"].to_numpy()
    truths = {k: truth_at(t, qtm.t + s.sync.groundtruth_offset_s,
                          to_world(qtm.xyz[:, c], s.groundtruth.to_world), qtm.rate_hz)
              for k, c in cols.items()}
    truth = truth_inputs(trajectory_inputs(traj, s), s, truths)
    ok = np.isfinite(truth.wrist_angles).all(axis=1)
    d = np.abs(truth.wrist_angles[ok] - exact["frame_angles_deg"][ok])
    assert d.max() < 2.0 and d.mean() < 0.5
    rows = pd.DataFrame(measure_comparison("ukf-palm", kin.astype({"value": str}).to_dict("records"),
                                           truth))
    rows = rows[rows["segment"] == "session"].set_index("measure")
    for a in ("flexion", "deviation", "pronation"):
        assert abs(rows.loc[f"wrist_{a}_rom", "error"]) <= 2.0, rows.loc[f"wrist_{a}_rom"]
    rows.reset_index().to_csv(tmp_path / "measures.csv", index=False)
    r = run_cli("report", SAMPLES / "wrist-rom-01", "--out", tmp_path)
    assert r.exit_code == 0, r.stderr
    pages = pdf_pages(tmp_path / "report.pdf")
    angles = next(p for p in pages if "Wrist angles" in p)
    rom = float(kin.set_index("measure").loc["wrist_flexion_rom", "value"])
    assert f"wrist flexion (+ towards the palm; − extension): range {shown(rom, 1)}°" in pages[0]
    x = traj["flexion_deg"]
    assert f"range {shown(x.max() - x.min(), 1)}°" in angles  # the page marks the same RoM
    assert "palm-marker Kalman filter" in pages[0]


def test_a_palm_session_without_a_wrist_pose_says_so_and_same_inputs_same_bytes(tmp_path):
    for name in ("x.pdf", "y.pdf"):
        r = run_cli("report", SAMPLES / "wrist-rom-01", "--out", tmp_path, "-o", tmp_path / name)
        assert r.exit_code == 0, r.stderr
    text = "\n".join(pdf_pages(tmp_path / "x.pdf"))
    assert "no wrist-pose estimate in this work folder" in text and "Verdict: not usable" in text
    assert (tmp_path / "x.pdf").read_bytes() == (tmp_path / "y.pdf").read_bytes()


def test_progress_change_beyond_uncertainty_rule():
    """|Δ| > 1.96·√(SD₁² + SD₂²): 5 > 2.77 yes; 2 < 2.77 no; no SD, not judged."""
    assert progress.change((10.0, 1.0), (15.0, 1.0)) == (5.0, "yes")
    assert progress.change((10.0, 1.0), (12.0, 1.0)) == (2.0, "no")
    assert progress.change((10.0, float("nan")), (12.0, 1.0))[1] == "no uncertainty"


def test_several_sessions_of_one_subject_give_a_progress_report(arm, tmp_path):
    """A later copy of the session (date changed) beside the first: progress pages first,
    in date order, with the change, then each session's first page; a different subject is
    refused."""
    s, out = arm
    later = tmp_path / "circle-02"
    shutil.copytree(s, later)
    toml = later / "session.toml"
    toml.write_text(toml.read_text().replace("2026-11-20T10:15:00", "2026-11-27T09:00:00")
                    .replace('id = "circle-01"', 'id = "circle-02"'))
    shutil.copytree(out, tmp_path / "work" / "circle-02")
    shutil.copytree(out, tmp_path / "work" / "circle-01")
    r = run_cli("report", later, s, "--out", tmp_path / "work", "-o", tmp_path / "p.pdf")
    assert r.exit_code == 0, r.stderr
    pages = pdf_pages(tmp_path / "p.pdf")
    assert "Progress over sessions" in pages[0] and "2026-11-20 to 2026-11-27" in pages[0]
    assert pages[0].index("2026-11-20 (circle-01") < pages[0].index("2026-11-27 (circle-02")
    # table, two pages of charts (every measure of the table: 10, eight a page), two first pages
    assert "beyond uncertainty" in pages[0] and len(pages) == 5
    assert "Movement report" in pages[3] and "circle-02" in pages[4]
    kin = pd.read_csv(out / "kinematics-arm-smoother.csv", dtype={"value": str}).set_index(
        "measure")
    assert shown(float(kin.loc["elbow_flexion_rom", "value"]), 1) in pages[0]
    toml.write_text(toml.read_text().replace('subject = "SIM"', 'subject = "S02"'))
    r = run_cli("report", later, s, "--out", tmp_path / "work", "-o", tmp_path / "q.pdf")
    assert r.exit_code == 1 and "different subjects (S02, SIM)" in r.stderr
    assert not (tmp_path / "q.pdf").exists()


def _text_outside_the_page(reports) -> list[str]:
    """What is drawn on a page of render.plan(reports) past the page's edge: each text of the
    page itself and each chart with its titles, labels and tick labels (as the renderer lays
    them out: matplotlib's tight boxes hold what is drawn), named with the page's title."""
    from armtrack_cli.report import layout
    from armtrack_cli.report.render import plan

    plt = layout.setup()
    bad = []
    planned = plan(reports)
    for n, (left, title, draw) in enumerate(planned, 1):
        fig = layout.page(plt, title)
        layout.header(fig, left, n, len(planned))
        draw(fig)
        fig.canvas.draw()
        page, renderer = fig.bbox, fig.canvas.get_renderer()
        drawn = [(f"{t.get_text()[:60]!r}", t.get_window_extent(renderer)) for t in fig.texts
                 if t.get_visible() and t.get_text().strip()]
        drawn += [(f"chart {ax.get_title()[:40]!r}", ax.get_tightbbox(renderer))
                  for ax in fig.axes if ax.get_visible()]
        bad += [f"page {n} ({title}): {what}" for what, box in drawn
                if box.x0 < page.x0 - 0.5 or box.x1 > page.x1 + 0.5 or box.y0 < page.y0 - 0.5
                or box.y1 > page.y1 + 0.5]
        plt.close(fig)
    return bad


def test_every_text_of_a_session_and_a_progress_report_stays_on_the_page(arm):
    """Every line a clinician is meant to read lies within the A4 page (a caption once ran
    off the progress charts' page, cut mid-sentence, and no test saw it)."""
    import dataclasses

    from armtrack_cli.pipeline.report import gather

    s, out = arm
    one = gather(s, out)
    assert not _text_outside_the_page([one])
    later = dataclasses.replace(one, session_id="circle-02", date="2027-02-01T09:00:00")
    assert not _text_outside_the_page([one, later])
