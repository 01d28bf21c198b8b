"""ux12: depth frames that armtrack read silently wrong or not at all. A depth PNG of
another size than the video is not registered to its pixels (a RealSense depth stream left
unaligned): its depths were read under the wrong pixels. PNGs in depth/ none of which is
named NNNNNN.png: info counted them as depth frames, and calibrate and fuse ran without
depth, silently. Each test failed before its fix."""

from __future__ import annotations

import shutil

import cv2
import pytest

from armtrack_cli.core.errors import DataError

from .conftest import REPO, run_cli


@pytest.fixture
def palm(tmp_path):
    s = tmp_path / "wrist rom"
    shutil.copytree(REPO / "sample_sessions" / "wrist-rom-01", s)
    return s


def test_depth_of_another_size_is_refused(palm):
    from armtrack_cli.session.depth import read_depth_frame

    f = palm / "depth" / "000000.png"
    d = cv2.imread(str(f), cv2.IMREAD_UNCHANGED)
    cv2.imwrite(str(f), cv2.resize(d, (320, 240), interpolation=cv2.INTER_NEAREST))
    with pytest.raises(DataError, match="is 320x240, the video 640x480"):
        read_depth_frame(palm, 0, (640, 480))
    r = run_cli("calibrate", palm)
    assert r.exit_code == 1 and "000000.png: is 320x240" in r.stderr
    assert not (palm / "armtrack" / "palm.toml").exists()


def test_misnamed_depth_frames_are_an_error_not_a_run_without_depth(palm):
    for f in (palm / "depth").iterdir():
        f.rename(f.with_name("depth_" + f.name))
    for command in ("info", "calibrate"):
        r = run_cli(command, palm)
        assert r.exit_code == 1, r.output
        assert "depth: holds 360 PNGs (such as depth_000000.png)" in r.stderr
        assert not (palm / "armtrack").exists()


def test_depth_frames_are_counted_by_name(palm):
    (palm / "depth" / "preview.png").write_bytes(b"x")
    r = run_cli("info", palm, "--json")
    assert r.exit_code == 0
    import json

    assert json.loads(r.stdout)["depth"]["frames"] == 360
