"""Fixtures shared by the whole test suite."""

import sys

import pytest


@pytest.fixture
def site(tmp_path, monkeypatch):
    """A fresh directory on sys.path for throwaway distributions; their modules are unloaded after."""
    path = tmp_path / "site"
    path.mkdir()
    monkeypatch.syspath_prepend(str(path))
    before = set(sys.modules)
    yield path
    for name in set(sys.modules) - before:
        if getattr(sys.modules[name], "__file__", "") and str(path) in sys.modules[name].__file__:
            del sys.modules[name]


@pytest.fixture
def tmpfs(tmp_path):
    """``make(size)``: a fresh tmpfs of ``size`` (e.g. ``"1m"``) mounted under ``tmp_path``, unmounted after the
    test: a file system that really runs out of space.  Skips where it cannot be mounted (not Linux, not root)."""
    import subprocess
    import sys

    mounted = []

    def make(size: str = "1m"):
        if not sys.platform.startswith("linux"):
            pytest.skip("a small file system for disk-full tests needs Linux's tmpfs")
        point = tmp_path / f"tmpfs{len(mounted)}"
        point.mkdir()
        done = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(point)],
                              capture_output=True, text=True)
        if done.returncode != 0:
            pytest.skip(f"cannot mount a tmpfs for a disk-full test (needs root): {done.stderr.strip()}")
        mounted.append(point)
        return point

    yield make
    for point in mounted:
        subprocess.run(["umount", "-l", str(point)], check=False)


@pytest.fixture
def small_tmpfs(tmpfs):
    """A 1 MiB tmpfs (see :func:`tmpfs`)."""
    return tmpfs("1m")


def pytest_collection_finish(session):
    """Move what collection left alive (the imported modules, the collected tests) out of the garbage
    collector's view: a test worker holds a few hundred thousand such objects, and every full
    collection (automatic, or forced by a library) would otherwise walk them all again."""
    import gc

    gc.collect()
    gc.freeze()
