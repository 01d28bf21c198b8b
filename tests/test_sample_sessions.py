"""The bundled sample sessions are what their recorded command makes, and readable.

Regenerated here, a sample equals the committed one within the cross-machine tolerances of
``session_equal`` (float round-off differs between CPUs); run twice on one machine, the
simulator writes the same bytes.
"""

from __future__ import annotations

import shlex
import shutil

import numpy as np
import pytest

from . import session_equal
from .conftest import REPO, run_cli

SAMPLES = REPO / "sample_sessions"
NAMES = sorted(p.name for p in SAMPLES.iterdir() if p.is_dir())


def test_there_are_the_three_promised_sessions_under_20_mb():
    assert NAMES == ["circle-01", "reach-01", "wrist-rom-01"]
    size = sum(p.stat().st_size for p in SAMPLES.rglob("*") if p.is_file())
    assert size < 20e6


def _regenerate(name, folder):
    first = (SAMPLES / name / "session.toml").read_text().splitlines()[0]
    assert first.startswith("# simulated by: armtrack simulate ")
    args = shlex.split(first.removeprefix("# simulated by: armtrack "))
    args[1] = str(folder / name)
    r = run_cli(*args)
    assert r.exit_code == 0, r.stderr


@pytest.mark.parametrize("name", NAMES)
def test_sample_is_what_its_recorded_command_makes(tmp_path, name):
    _regenerate(name, tmp_path)
    diffs = session_equal.differences(tmp_path / name, SAMPLES / name) + session_equal.compare_file(
        tmp_path / f"{name}.truth.npz", SAMPLES / f"{name}.truth.npz")
    assert not diffs, "regenerated sample differs (run `make samples` after changing the " \
        "simulator):\n" + "\n".join(diffs)


def test_simulate_twice_on_one_machine_gives_the_same_bytes(tmp_path):
    for k in (1, 2):
        r = run_cli("simulate", tmp_path / f"run{k}" / "s", "--seed", "5", "--duration", "4",
                    "--imu-format", "mcap", "--gt-gaps", "1")
        assert r.exit_code == 0, r.stderr
    files = sorted(p.relative_to(tmp_path / "run1") for p in (tmp_path / "run1").rglob("*")
                   if p.is_file())
    assert len(files) >= 6
    for rel in files:
        assert (tmp_path / "run1" / rel).read_bytes() == (tmp_path / "run2" / rel).read_bytes(), rel


def test_the_comparison_fails_loudly_on_a_perturbed_value(tmp_path):
    """One value moved by 1e-6 of its scale, in a truth array and in an MCAP payload, and one
    Qualisys millimetre: each is named, with its size."""
    name = "reach-01"
    ref = SAMPLES
    made = tmp_path / "made"
    shutil.copytree(SAMPLES / name, made / name)
    with np.load(ref / f"{name}.truth.npz") as z:
        arrays = {k: z[k].copy() for k in z.files}
    key = next(k for k, v in arrays.items() if v.dtype == np.float64 and v.size > 10)
    arrays[key].flat[7] += 1e-6 * max(1.0, np.nanmax(np.abs(arrays[key])))
    np.savez_compressed(made / f"{name}.truth.npz", **arrays)
    tsv = (made / name / "qualisys.tsv").read_text().splitlines()
    last = tsv[-1].split("\t")
    last[-1] = f"{float(last[-1]) + 0.01:.3f}"
    (made / name / "qualisys.tsv").write_text("\n".join(tsv[:-1] + ["\t".join(last)]) + "\n")
    diffs = session_equal.differences(made / name, ref / name) + session_equal.compare_file(
        made / f"{name}.truth.npz", ref / f"{name}.truth.npz")
    assert any(f"[{key}]" in d and "max difference" in d for d in diffs), diffs
    assert any(d.startswith("qualisys.tsv: number") for d in diffs), diffs
    assert len(diffs) == 2, diffs


def test_the_mcap_comparison_sees_one_changed_float(tmp_path):
    from armtrack_cli.session.export.mcap import write_imu_mcap

    t = np.arange(50) / 100.0
    acc = np.tile([0.0, 0.0, 9.81], (50, 1))
    gyr = np.zeros((50, 3))
    q = np.tile([1.0, 0.0, 0.0, 0.0], (50, 1))
    write_imu_mcap(tmp_path / "a.mcap", t, acc, gyr, q)
    write_imu_mcap(tmp_path / "b.mcap", t, acc + 1e-12, gyr, q)
    assert session_equal.mcap(tmp_path / "b.mcap", tmp_path / "a.mcap") == []
    acc[20, 1] = 1e-3
    write_imu_mcap(tmp_path / "c.mcap", t, acc, gyr, q)
    diffs = session_equal.mcap(tmp_path / "c.mcap", tmp_path / "a.mcap")
    assert diffs and "linear_acceleration.y" in diffs[0] and "0.001" in diffs[0], diffs


@pytest.mark.parametrize("name", NAMES)
def test_info_reads_every_sample(name):
    r = run_cli("info", SAMPLES / name, "--json")
    assert r.exit_code == 0, r.stderr
