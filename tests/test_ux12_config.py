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
