"""Our FileStorage YAML parser reads what OpenCV writes, value for value (OpenCV is the
independent reference), and refuses what is not that subset with a line number."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from armtrack_cli.session.opencv_yaml import YamlError, parse

floats = st.floats(allow_nan=False, allow_infinity=False, width=64)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(rows=st.integers(1, 5), cols=st.integers(1, 5), data=st.data(),
       scalar=st.floats(-1e6, 1e6), n=st.integers(0, 10000))
def test_parse_equals_opencv(tmp_path_factory, rows, cols, data, scalar, n):
    m = np.array(data.draw(st.lists(floats, min_size=rows * cols, max_size=rows * cols)),
                 float).reshape(rows, cols)
    path = tmp_path_factory.mktemp("y") / "c.yaml"
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE | cv2.FILE_STORAGE_FORMAT_YAML)
    fs.write("M", m)
    fs.write("x", float(scalar))
    fs.write("n", int(n))
    fs.release()
    doc = parse(path.read_text())
    np.testing.assert_array_equal(doc["M"], m)
    assert doc["x"] == float(scalar) and doc["n"] == n


def test_special_values_and_errors():
    doc = parse("%YAML:1.0\n---\nd: !!opencv-matrix\n   rows: 1\n   cols: 3\n   dt: d\n"
                "   data: [ .nan, -.inf,\n       2. ]\n")
    assert np.isnan(doc["d"][0, 0]) and doc["d"][0, 1] == -np.inf and doc["d"][0, 2] == 2.0
    for bad, where in (("hello", "line 1"), ("%YAML:1.0\n- a\n", "line 2"),
                       ("%YAML:1.0\nm: !!opencv-matrix\n  rows: 2\n  cols: 2\n  dt: d\n"
                        "  data: [ 1, 2, 3 ]\n", "3 values"),
                       ("%YAML:1.0\nm: !!opencv-matrix\n  rows: 1\n  cols: 1\n  dt: d\n"
                        "  data: [ 1,\n", "never closed")):
        with pytest.raises(YamlError, match=where):
            parse(bad)
