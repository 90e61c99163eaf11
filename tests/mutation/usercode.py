"""A SLAM written like a user's (not faultlab's units), for the tests of mutation analysis of user code.

Planted facts the tests check, known from reading the code:

* ``_gain`` runs at import: its mutant ``return 0.0`` makes ``GAIN = 1.0 / _gain()`` divide by zero,
  so the mutated module cannot be imported (invalid);
* ``self.steps`` is a diagnostic counter no estimate reads: mutants of its statement are equivalent;
* deleting ``self.map = {}`` in ``reset`` makes every run raise (trivially killed);
* ``clamp`` and ``make`` carry the no-mutate pragma, and so does the landmark line of ``update``.
"""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

import pytest

SOURCE = '''"""A user's SLAM: dead reckoning, each landmark where it was first seen."""

import numpy as np

from faultlab.slam import Estimate, SlamAdapter


def _gain():
    return 1.0


GAIN = 1.0 / _gain()


def wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


def clamp(v):  # faultlab: no mutate
    return max(v, 0.0)


class Mapper(SlamAdapter):
    name = "user_mapper"

    def reset(self, pose, *, rng):
        self.pose = np.array(pose, dtype=float)
        self.map = {}
        self.steps = 0

    def update(self, control, observations):
        v, omega = control
        x, y, th = self.pose
        x, y = x + GAIN * clamp(v) * np.cos(th), y + GAIN * clamp(v) * np.sin(th)
        th = wrap(th + omega)
        self.pose = np.array([x, y, th])
        self.steps = self.steps + 1
        for r, b, i in zip(observations.ranges, observations.bearings, observations.ids):
            self.map.setdefault(int(i), (x + r * np.cos(th + b), y + r * np.sin(th + b)))  # faultlab: no mutate

    def estimate(self):
        ids = np.array(sorted(self.map), dtype=np.int64)
        xy = np.array([self.map[i] for i in ids], dtype=float).reshape(-1, 2)
        return Estimate(self.pose.copy(), ids, xy)


def make():  # faultlab: no mutate
    return Mapper()
'''

PACKAGE = "usermap"
MODULE = "usermap.slam"
FACTORY = "usermap.slam:make"


def write_package(root: Path, source: str = SOURCE) -> Path:
    """Write the package under ``root`` (a directory put on sys.path) and return the module's file."""
    pkg = root / PACKAGE
    pkg.mkdir(parents=True, exist_ok=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "slam.py").write_text(source)
    return pkg / "slam.py"


def forget_package() -> None:
    """Drop the package from sys.modules (each test writes its own copy)."""
    for k in [k for k in sys.modules if k == PACKAGE or k.startswith(PACKAGE + ".")]:
        del sys.modules[k]


@pytest.fixture
def user_package(tmp_path, monkeypatch):
    """The package written under tmp_path and importable; yields the module's file."""
    root = tmp_path / "site"
    path = write_package(root)
    monkeypatch.syspath_prepend(str(root))
    forget_package()
    importlib.invalidate_caches()
    yield path
    forget_package()
