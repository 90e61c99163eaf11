"""The default test level (alpha) and power are each written once, in faultlab.vocabulary: no function,
dataclass field or command-line option states its own."""

import ast
import re
from pathlib import Path

from faultlab.vocabulary import DEFAULT_ALPHA, DEFAULT_POWER

PACKAGE = Path(__file__).resolve().parents[1] / "faultlab"
LEVELS = {"alpha": DEFAULT_ALPHA, "power": DEFAULT_POWER}
#: The default power written out: "80 %", "80%", "mdd80" (a column named after it).
POWER_STRING = re.compile(rf"(?<![\d.]){100 * DEFAULT_POWER:g}\s?%|mdd{100 * DEFAULT_POWER:g}")


def _power_strings(tree: ast.AST):
    """(text, line) of every string (docstrings and f-string parts included) that writes the default power."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            for m in POWER_STRING.finditer(node.value):
                yield m.group(0), node.lineno


def _literal_levels(tree: ast.AST):
    """(name, line) of every literal number given as an alpha or power default."""
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            a = node.args
            positional = a.posonlyargs + a.args
            pairs = list(zip(positional[len(positional) - len(a.defaults):], a.defaults))
            pairs += [(arg, d) for arg, d in zip(a.kwonlyargs, a.kw_defaults) if d is not None]
            for arg, default in pairs:
                if arg.arg in LEVELS and isinstance(default, ast.Constant) and isinstance(default.value, float):
                    yield arg.arg, default.lineno
        elif (isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) and node.target.id in LEVELS
              and isinstance(node.value, ast.Constant) and isinstance(node.value.value, float)):
            yield node.target.id, node.lineno
        elif isinstance(node, ast.Call):
            options = [a.value for a in node.args if isinstance(a, ast.Constant) and isinstance(a.value, str)]
            for kw in node.keywords:
                if (kw.arg == "default" and isinstance(kw.value, ast.Constant) and isinstance(kw.value.value, float)
                        and any(o.lstrip("-") in LEVELS for o in options)):
                    yield options[0], kw.value.lineno
                if (kw.arg in LEVELS and isinstance(kw.value, ast.Constant) and kw.value.value == LEVELS[kw.arg]
                        and not (isinstance(node.func, ast.Attribute) and node.func.attr == "plot")):
                    yield kw.arg, kw.value.lineno


def test_no_literal_default_level_or_power_outside_the_vocabulary():
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if path.name == "vocabulary.py" and path.parent == PACKAGE:
            continue
        found += [f"{path.relative_to(PACKAGE.parent)}:{line}: {name}"
                  for name, line in _literal_levels(ast.parse(path.read_text()))]
    assert not found, "literal levels (use DEFAULT_ALPHA / DEFAULT_POWER):\n" + "\n".join(found)


def test_no_power_written_out_outside_the_vocabulary():
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if path.name == "vocabulary.py" and path.parent == PACKAGE:
            continue
        found += [f"{path.relative_to(PACKAGE.parent)}:{line}: {text!r}"
                  for text, line in _power_strings(ast.parse(path.read_text()))]
    assert not found, "the default power written out (use POWER_TEXT / MDD_COLUMN):\n" + "\n".join(found)


def test_the_power_scan_finds_planted_strings_and_passes_derived_ones():
    planted = ast.parse('def f(c):\n    """Detects with 80 % power."""\n    return f"at 80% power {c[\'mdd80\']}"\n'
                        'x = "180 % of 0.80 %"\ny = f"{POWER_TEXT} power, {MDD_COLUMN}"\n')
    assert sorted(text for text, _ in _power_strings(planted)) == ["80 %", "80%", "mdd80"]


def test_the_scan_finds_a_planted_literal_level():
    planted = ast.parse("def f(x, *, alpha: float = 0.05, power=0.8):\n    return g(alpha=0.05)\n"
                        "p.add_argument('--alpha', type=float, default=0.01)\n")
    assert sorted(name for name, _ in _literal_levels(planted)) == ["--alpha", "alpha", "alpha", "power"]
