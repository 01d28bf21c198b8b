"""ux12: session.toml mistakes whose hint led the wrong way."""

from __future__ import annotations

import shutil

import pytest

from armtrack_cli.core.errors import ConfigError
from armtrack_cli.session.config import load_session

from .conftest import REPO


@pytest.mark.parametrize("value", ["y", "Y", "x"])
def test_forearm_axis_without_a_sign_is_not_given_a_sign(tmp_path, value):
    """'y' was answered "did you mean '-y'?" (difflib's pick among '+y' and '-y'): followed,
    the forearm points from the hand to the elbow. Now the hint names both signs."""
    s = tmp_path / "s"
    shutil.copytree(REPO / "sample_sessions" / "circle-01", s)
    toml = s / "session.toml"
    toml.write_text(toml.read_text().replace('forearm_axis = "+y"', f'forearm_axis = "{value}"'))
    with pytest.raises(ConfigError) as e:
        load_session(s)
    msg = str(e.value)
    low = value.lower()
    assert "has no sign" in msg and f"'+{low}' or '-{low}'" in msg
    assert "did you mean" not in msg


def test_an_impossible_arm_is_named_when_the_smoother_diverges(tmp_path):
    """upper_arm_m = 1.0 (a typo for 0.31) on circle-01: the first detection's ray still meets
    the arm's sphere, but the default method diverges. It printed ten numpy warnings and
    blamed the detections and the IMU; now one error that names [arm], exit 1, nothing
    written."""
    from .conftest import run_cli

    s = tmp_path / "s"
    shutil.copytree(REPO / "sample_sessions" / "circle-01", s,
                    ignore=shutil.ignore_patterns("armtrack"))
    toml = s / "session.toml"
    text = toml.read_text()
    assert "upper_arm_m = 0.31" in text
    toml.write_text(text.replace("upper_arm_m = 0.31", "upper_arm_m = 1.0"))
    assert run_cli("calibrate", s).exit_code == 0 and run_cli("detect", s).exit_code == 0
    r = run_cli("fuse", s)
    assert r.exit_code == 1
    assert "diverged" in r.stderr and "check [arm]" in r.stderr
    assert "warning" not in r.stderr.lower()
    assert not list((s / "armtrack").glob("trajectory-*.csv"))
