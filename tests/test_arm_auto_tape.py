"""validation/arm_auto_tape.py's error model for the arm a lab would declare (lengths off by
N(0, σ_L), the shoulder by N(0, σ_S) per axis) draws what it says, and its section of
docs/validation-arm-auto.md survives validation/arm_auto.py's regeneration of the rest."""

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from validation import arm_auto, arm_auto_tape  # noqa: E402
from validation import arm_auto_tape_doc as doc  # noqa: E402


def test_error_model_draws_the_sds_it_states():
    sigma_l, sigma_s = (0.005, 0.01), (0.005, 0.01, 0.03)
    e = arm_auto_tape.draw_errors((2, 1), draws=20000, sigma_l=sigma_l, sigma_s=sigma_s)
    assert e["lengths"].shape == (2, 20000, 2) and e["shoulder"].shape == (3, 20000, 3)
    for lv, d in zip(sigma_l, e["lengths"]):  # each length, each level
        np.testing.assert_allclose(d.std(axis=0), lv, rtol=0.03)
        assert np.all(np.abs(d.mean(axis=0)) < 4 * lv / np.sqrt(20000))
    for sv, d in zip(sigma_s, e["shoulder"]):  # per axis, independent axes
        np.testing.assert_allclose(d.std(axis=0), sv, rtol=0.03)
        assert np.all(np.abs(d.mean(axis=0)) < 4 * sv / np.sqrt(20000))
        assert np.all(np.abs(np.corrcoef(d.T)[np.triu_indices(3, 1)]) < 0.03)
    # the levels are one draw scaled, and the lengths and shoulder draws are independent
    np.testing.assert_allclose(e["shoulder"][2], 3 * e["shoulder"][1], rtol=1e-12)
    assert abs(np.corrcoef(e["lengths"][0, :, 0], e["shoulder"][0, :, 0])[0, 1]) < 0.03


def test_error_model_draws_are_fixed_by_the_session():
    a, b = arm_auto_tape.draw_errors((0, 1)), arm_auto_tape.draw_errors((0, 1))
    c = arm_auto_tape.draw_errors((1, 1))
    np.testing.assert_array_equal(a["shoulder"], b["shoulder"])
    assert not np.allclose(a["lengths"], c["lengths"])


def _row(scale: float) -> dict:
    d, nl, ns = 2, len(arm_auto_tape.SIGMA_L_M), len(arm_auto_tape.SIGMA_S_M)
    return {"true": (0.1, 0.1), "auto": (0.2 * scale, 0.3), "auto_err_cm": [0.5, 0.1, -0.1],
            "taped": [[(0.3, 0.4)] * d] * nl, "measured": [[[(0.5, 0.6)] * d] * ns] * nl}


@pytest.mark.parametrize("first", ["arm_auto", "tape"])
def test_section_written_once_and_kept_by_arm_auto(tmp_path, first):
    out = tmp_path / "validation-arm-auto.md"
    write_tape = lambda scale: doc.write_section(  # noqa: E731
        out, {"circle-s0": _row(scale)}, 1.0, 2, arm_auto_tape.SIGMA_L_M, arm_auto_tape.SIGMA_S_M)
    write_main = lambda body: out.write_text(  # noqa: E731
        arm_auto.kept_sections(f"# The arm model\n\n{body}\n\n## With the movement\n\nrows\n", out))
    if first == "arm_auto":
        write_main("old")
    write_tape(1.0)
    write_main("new")
    write_tape(2.0)  # regenerated: replaces its section, no second copy
    text = out.read_text()
    assert text.count(doc.HEADING) == 1 and text.count("# The arm model") == 1
    assert "new" in text and "| circle-s0 | 0.10 | 0.40 |" in text
    assert text.index("## With the movement") < text.index(doc.HEADING)
    assert "| all five auto | 0.40 (0.40) |" in text
