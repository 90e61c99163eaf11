"""The layer contract of pyproject.toml holds (import-linter), and no module imports a higher layer."""

import ast
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.skipif(shutil.which("lint-imports") is None, reason="import-linter is not installed")
def test_import_contracts_are_kept():
    done = subprocess.run(["lint-imports", "--config", str(ROOT / "pyproject.toml")], cwd=ROOT,
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "0 broken" in done.stdout


PACKAGE = ROOT / "faultlab"


def _package_of(module: str) -> str:
    """``faultlab.x.y`` -> ``faultlab.x`` (a top-level module ``faultlab.x`` is its own package)."""
    return ".".join(module.split(".")[:2])


def _module_name(path: Path) -> str:
    return ".".join(path.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__")


def _private_imports_across_packages(source: str, module: str) -> list[str]:
    """``from faultlab.<other package>... import _name`` (and ``import faultlab.x._mod``) in ``source``,
    the text of the module named ``module``."""
    own = _package_of(module)
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").startswith("faultlab"):
            names = [a.name for a in node.names]
            targets = [(node.module, n) for n in names if n.startswith("_") and not n.startswith("__")]
            targets += [(node.module, p) for p in node.module.split(".") if p.startswith("_")]
        elif isinstance(node, ast.Import):
            targets = [(a.name, p) for a in node.names if a.name.startswith("faultlab")
                       for p in a.name.split(".") if p.startswith("_")]
        else:
            continue
        found += [f"{module}:{node.lineno} imports {name} from {source}" for source, name in targets
                  if _package_of(source) != own]
    return found


def test_private_imports_across_packages_are_detected():
    """The check itself: a planted private import across packages is found, one within a package is not."""
    planted = ("from faultlab.runner.store import _q\nfrom faultlab.analysis.result import _x\n"
               "import faultlab.runner._hidden\nfrom faultlab.runner import run_experiment\n")
    found = _private_imports_across_packages(planted, "faultlab.analysis._layers_probe")
    assert found == ["faultlab.analysis._layers_probe:1 imports _q from faultlab.runner.store",
                     "faultlab.analysis._layers_probe:3 imports _hidden from faultlab.runner._hidden"]


def test_no_module_imports_another_packages_private_names():
    found = [hit for path in sorted(PACKAGE.rglob("*.py"))
             for hit in _private_imports_across_packages(path.read_text(), _module_name(path))]
    assert found == []
