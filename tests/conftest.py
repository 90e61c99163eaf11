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
