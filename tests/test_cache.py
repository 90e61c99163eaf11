"""The user's cache directory: the mutant cache and numba's compiled kernels go there, never into the source."""

import os
import subprocess
import sys
from pathlib import Path

from faultlab.cache import cache_dir, numba_cache_dir

ROOT = Path(__file__).resolve().parents[1]


def test_cache_dir_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)  # set by faultlab.slam.kernels once imported
    monkeypatch.setenv("FAULTLAB_CACHE_DIR", str(tmp_path / "mine"))
    assert cache_dir() == tmp_path / "mine" and numba_cache_dir() == tmp_path / "mine" / "numba"
    monkeypatch.setenv("FAULTLAB_CACHE_DIR", "")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache_dir() is None and numba_cache_dir() == tmp_path / "xdg" / "faultlab" / "numba"
    monkeypatch.delenv("FAULTLAB_CACHE_DIR")
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "numba"))
    assert cache_dir() == tmp_path / "xdg" / "faultlab" and numba_cache_dir() == tmp_path / "numba"


def _kernel_cache_path(env: dict, *, numba_first: bool) -> str:
    code = ("import numba\n" if numba_first else "") + (
        "from faultlab.slam import kernels\n"
        "print(kernels.offsets._cache._cache_path)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env, cwd=ROOT)
    return done.stdout.strip()


def test_the_compiled_kernels_are_cached_in_the_user_cache_not_next_to_the_source(tmp_path):
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "FAULTLAB_CACHE_DIR")}
    env["XDG_CACHE_HOME"] = str(tmp_path)
    for numba_first in (False, True):  # also when numba was imported before faultlab chose the directory
        path = Path(_kernel_cache_path(env, numba_first=numba_first))
        assert path.is_relative_to(tmp_path / "faultlab" / "numba"), path
        assert not path.is_relative_to(ROOT)
