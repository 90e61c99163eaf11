"""The lock (``requirements/test.lock``) pins every dependency of ``pyproject.toml`` within its bounds,
and is refreshed by the one command CONTRIBUTING.md documents."""

import re
import tomllib
from pathlib import Path

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name
from packaging.version import Version

ROOT = Path(__file__).resolve().parents[1]
LOCK = ROOT / "requirements" / "test.lock"


def _pins(text: str) -> dict[str, list[Version]]:
    """Package -> pinned versions (one per Python-version branch of a universal lock)."""
    pins: dict[str, list[Version]] = {}
    for line in text.splitlines():
        m = re.match(r"([A-Za-z0-9._-]+)(?:\[[^]]*\])?==([^ ;]+)", line)
        if m:
            pins.setdefault(canonicalize_name(m[1]), []).append(Version(m[2]))
    return pins


def _requirements() -> list[Requirement]:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    plugin = tomllib.loads((ROOT / "examples" / "faultlab-example-plugin" / "pyproject.toml").read_text())["project"]
    extras = project["optional-dependencies"]
    reqs = [*project["dependencies"], *extras["test"], *extras["wild"], *plugin["dependencies"]]
    return [r for r in map(Requirement, reqs) if canonicalize_name(r.name) != "faultlab"]


def missing_from_lock(requirements: list[Requirement], lock_text: str) -> list[str]:
    """The requirements the lock does not pin, or pins outside their specifier."""
    pins = _pins(lock_text)
    bad = []
    for r in requirements:
        versions = pins.get(canonicalize_name(r.name))
        if not versions or not all(r.specifier.contains(v, prereleases=True) for v in versions):
            bad.append(str(r))
    return bad


def test_every_dependency_of_pyproject_is_pinned_in_the_lock_within_its_bounds():
    reqs = _requirements()
    assert len(reqs) >= 20
    assert missing_from_lock(reqs, LOCK.read_text()) == [], "re-lock: see CONTRIBUTING.md, 'The lock'"


def test_a_dependency_added_without_relocking_is_caught():
    text = LOCK.read_text()
    assert missing_from_lock([Requirement("jsonschema-faultlab-probe>=1")], text) == ["jsonschema-faultlab-probe>=1"]
    # a lower bound raised above the pinned version is caught as well
    numpy = max(_pins(text)["numpy"])
    raised = Requirement(f"numpy>={numpy.major}.{numpy.minor + 1}")
    assert missing_from_lock([raised], text) == [str(raised)]


def test_the_lock_says_the_command_that_contributing_documents():
    header = re.search(r"^#    (uv pip compile .*)$", LOCK.read_text(), flags=re.M)
    assert header, "the lock's header names the command that wrote it"
    assert f"python -m {header[1]}" in (ROOT / "CONTRIBUTING.md").read_text()
