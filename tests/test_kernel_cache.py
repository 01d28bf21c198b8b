"""session/kernel_cache.py: the list of kernel modules is every module that imports numba, and
the cache folder's key follows their bytes."""

from __future__ import annotations

import os
import re
import subprocess
import sys

from armtrack_cli.session import kernel_cache

NUMBA_IMPORT = re.compile(r"^(from numba\b|import numba\b)", re.M)


def test_every_module_that_imports_numba_at_its_top_is_a_kernel_module():
    found = sorted(str(p.relative_to(kernel_cache.PACKAGE)) for p in
                   kernel_cache.PACKAGE.rglob("*.py") if NUMBA_IMPORT.search(p.read_text()))
    assert found == sorted(kernel_cache.KERNEL_MODULES)


def test_the_key_changes_with_any_kernel_module(tmp_path, monkeypatch):
    """A copy of the kernel modules: the key is the package's, and changes when one byte of
    one helper module (splitmix) changes."""
    for rel in kernel_cache.KERNEL_MODULES:
        dst = tmp_path / rel
        dst.parent.mkdir(parents=True, exist_ok=True)
        dst.write_bytes((kernel_cache.PACKAGE / rel).read_bytes())
    before = kernel_cache.kernel_key()
    monkeypatch.setattr(kernel_cache, "PACKAGE", tmp_path)
    assert kernel_cache.kernel_key() == before
    p = tmp_path / "filters" / "splitmix.py"
    p.write_bytes(p.read_bytes() + b"\n")
    assert kernel_cache.kernel_key() != before


def test_numba_uses_the_folder_and_a_user_setting_wins(tmp_path):
    code = ("import armtrack_cli, numba, os; "
            "print(numba.config.CACHE_DIR == os.environ['NUMBA_CACHE_DIR'], "
            "os.environ['NUMBA_CACHE_DIR'])")
    env = {k: v for k, v in __import__("os").environ.items() if k != "NUMBA_CACHE_DIR"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, env={**env, "XDG_CACHE_HOME": str(tmp_path)}).stdout.split()
    assert out == ["True", str(tmp_path / "armtrack" / f"numba-{kernel_cache.kernel_key()}")]
    mine = str(tmp_path / "mine")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, env={**env, "NUMBA_CACHE_DIR": mine}).stdout.split()
    assert out == ["True", mine]


def test_stale_kernel_folders_go_when_a_new_version_is_made(tmp_path):
    """Folders of other versions unused for more than STALE_DAYS are removed, recent ones and
    anything not a numba-* folder stay; the folder in use has its time stamp renewed."""
    root = tmp_path / "armtrack"
    now = 2.0e9
    old, recent = now - (kernel_cache.STALE_DAYS + 1) * 86400.0, now - 86400.0
    for name, stamp in (("numba-aaaa", old), ("numba-bbbb", recent), ("other", old),
                        ("numba-keep", old)):
        (root / name).mkdir(parents=True)
        (root / name / "index.nbi").write_bytes(b"x")
        os.utime(root / name, (stamp, stamp))
    removed = kernel_cache.prune(root, keep="numba-keep", now=now)
    assert removed == [root / "numba-aaaa"]
    assert sorted(p.name for p in root.iterdir()) == ["numba-bbbb", "numba-keep", "other"]
    assert kernel_cache.prune(tmp_path / "missing", keep="x", now=now) == []


def test_the_import_renews_the_folder_in_use_and_prunes_on_a_new_version(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["XDG_CACHE_HOME"] = str(tmp_path)
    root = tmp_path / "armtrack"
    stale = root / "numba-0000000000000000"
    stale.mkdir(parents=True)
    os.utime(stale, (1.0e9, 1.0e9))
    subprocess.run([sys.executable, "-c", "import armtrack_cli"], check=True, env=env)
    assert not stale.exists()  # our version's folder did not exist: the stale one went
    mine = root / f"numba-{kernel_cache.kernel_key()}"
    mine.mkdir()
    os.utime(mine, (1.0e9, 1.0e9))
    subprocess.run([sys.executable, "-c", "import armtrack_cli"], check=True, env=env)
    assert mine.stat().st_mtime > 1.5e9  # renewed
