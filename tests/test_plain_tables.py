"""compare's pandas-free table I/O held to the pandas readers and writer it stands in for:
the same values from the same files, the same one-line error for a bad file, the same bytes
written (session/plain_tables.py, session/outputs.write_rows)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from armtrack_cli.core.errors import DataError
from armtrack_cli.session.outputs import write_rows, write_table
from armtrack_cli.session.plain_tables import kinematics_rows, trajectory_columns
from armtrack_cli.session.tables import read_kinematics, read_trajectory

TRAJ = ("t,wrist_x,wrist_y,wrist_z,elbow_x,elbow_y,elbow_z,wrist_x_sd,ess\n"
        "0.000000,0.100000,0.200000,0.050000,,,,0.010000,480.000000\n"
        "0.033333,0.101234,0.199876,0.050321,0.300000,0.100000,0.020000,,470.5\n"
        "0.066667,0.102468,0.199752,0.050642,0.301000,0.101000,0.021000,0.011000,1e2\n")
KIN = ('measure,segment,value,sd,unit,t_start,t_end\n'
       'path_length,session,1.234500,0.010000,m,,\n'
       'peak_speed,1,0.500000,,m/s,0.000000,2.500000\n'
       'sparc,1,"not computable: a 0.62 s gap, too long",,"deg/s (low-passed, 6 Hz)",0.0,2.5\n'
       'peak_speed,2,0.400000,0.020000,m/s,2.500000,5.000000\n')


def test_trajectory_columns_are_read_trajectorys(tmp_path):
    p = tmp_path / "trajectory-x.csv"
    p.write_text(TRAJ)
    want = read_trajectory(p)
    got = trajectory_columns(p)
    assert list(got) == list(want.columns)
    for c in got:
        assert np.array_equal(got[c], want[c].to_numpy(), equal_nan=True)


@pytest.mark.parametrize("bad", [
    TRAJ.replace("0.102468", "abc"),  # a text cell
    TRAJ.replace("0.066667", "0.010000"),  # time going back
    TRAJ.replace("0.102468", "inf"),
    TRAJ.replace("0.102468", "250.0"),  # far beyond the board
    TRAJ.replace("0.033333,", "", 1),  # a row one cell short
    "t,wrist_x\n0,1\n",  # columns missing
    TRAJ.splitlines()[0] + "\n",  # no rows
    TRAJ.replace("0.102468", '"0.102468"'),  # quoted: the pandas reader takes it
])
def test_a_bad_trajectory_gets_the_pandas_readers_error(tmp_path, bad):
    p = tmp_path / "trajectory-x.csv"
    p.write_text(bad)
    try:
        want = read_trajectory(p)
    except DataError as exc:
        with pytest.raises(DataError) as got:
            trajectory_columns(p)
        assert str(got.value) == str(exc)
    else:
        got = trajectory_columns(p)
        assert all(np.array_equal(got[c], want[c].to_numpy(), equal_nan=True) for c in got)


@pytest.mark.parametrize("text", [
    KIN,
    KIN.replace('"not computable: a 0.62 s gap, too long"', "0.300000"),  # every value a number
    KIN.replace("m/s,2.5", "m/s,oops"),  # a text time: the pandas reader's error
    KIN.replace("1.234500", "NA"),  # an NA spelling: the pandas reader decides
])
def test_kinematics_rows_are_read_kinematicss(tmp_path, text):
    p = tmp_path / "kinematics-x.csv"
    p.write_text(text)
    try:
        want = read_kinematics(p).to_dict("records")
    except DataError as exc:
        with pytest.raises(DataError) as got:
            kinematics_rows(p)
        assert str(got.value) == str(exc)
        return
    got = kinematics_rows(p)
    assert len(got) == len(want)
    for g, w in zip(got, want):
        for k in ("measure", "segment", "value", "unit"):
            assert g[k] == w[k]
        for k in ("sd", "t_start", "t_end"):
            assert g[k] == w[k] or (np.isnan(g[k]) and np.isnan(w[k]))


def test_write_rows_writes_write_tables_bytes(tmp_path):
    nan = float("nan")
    errors = [{"method": "ekf", "joint": "wrist", "axis": a, "mean_cm": np.float64(1.5) * k,
               "std_cm": 0.0, "rmse_cm": nan if k == 2 else 2.25, "max_abs_cm": -0.0,
               "within_5cm_pct": 100.0, "n": k * 7} for k, a in enumerate("xyz")]
    measures = [{"method": "pf", "measure": "sparc", "segment": "1", "unit": "deg/s (a, b)",
                 "estimate": 'not computable: "x", y', "estimate_sd": nan, "truth": "0.5",
                 "error": nan, "error_pct": 3}, {"method": "pf", "measure": "path_length",
                 "segment": "session", "unit": "m", "estimate": "1.25", "estimate_sd": 0.01,
                 "truth": "1.2", "error": 0.05, "error_pct": 4.1666}]
    for rows, cols in ((errors, tuple(errors[0])), (measures, None), ([], ("a", "b"))):
        a, b = tmp_path / "a.csv", tmp_path / "b.csv"
        write_rows(a, rows, columns=cols, command="compare", settings={"k": 1})
        write_table(b, pd.DataFrame(rows, columns=list(cols) if cols else None),
                    command="compare", settings={"k": 1})
        assert a.read_bytes() == b.read_bytes()
        assert a.with_suffix(".meta.json").read_bytes() == b.with_suffix(".meta.json").read_bytes()
