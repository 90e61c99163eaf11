"""Mutants of a user's own SLAM source: targets, generation, and serving a mutated module at import.

A *target* names code outside faultlab -- ``package.module``, ``package.module:Class.method`` (or a
module-level function) or a file with line ranges, ``path/to/file.py:10-40,55-60`` -- and
:func:`generate_source_mutants` finds its mutation points with the same operators as the unit
mutants (:mod:`faultlab.mutation.operators`): every module-level function and every method of a
module-level class is one mutable *function*; its source is dedented, mutated, and put back in
the module's text at its place.  A function whose ``def`` line (or a decorator line) carries the
pragma ``# faultlab: no mutate`` is left alone; so is any line carrying it.

The module's source is read through its import spec (``loader.get_source``), so a target installed
as a wheel in site-packages works as well as one in a checkout.  Nothing is ever written to the
user's files: a mutant reaches a SLAM through :func:`mutated_modules`, which imports the Python
modules of the target's package (and of the SLAM factory's) afresh -- compiled extension modules
are shared, they cannot be initialised twice -- with a meta-path finder that serves the mutated
source for the target module, builds the SLAM, and puts the original modules back.  The fresh modules
are kept per process and mutant, so a worker imports a mutant's package once.

Ids are ``<module>:<function>:<operator>:<n>:<key>``; ``n`` counts the operator's points in the
function from 1 and ``key`` is the first 12 hex digits of the SHA-256 of the function's source,
the operator and ``n``: a mutant keeps its id while its function is unchanged, whatever changes
elsewhere in the file (what an incremental rerun reuses).
"""

from __future__ import annotations

import ast
import contextlib
import difflib
import functools
import hashlib
import importlib
import importlib.abc
import importlib.machinery
import importlib.util
import linecache
import re
import sys
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

from faultlab.errors import ConfigError, FaultError
from faultlab.mutation.mutant import function_mutants
from faultlab.mutation.operatorbase import MutationOperator
from faultlab.mutation.registry import all_operators, get_operator
from faultlab.mutation.source import FunctionSource

__all__ = ["NO_MUTATE_PRAGMA", "Target", "SourceFunction", "SourceMutant", "SourceMutants", "parse_target",
           "generate_source_mutants", "source_mutant", "is_source_mutant_id", "mutated_modules",
           "SourceMutantFault", "source_mutant_fault", "list_source_mutants"]

#: A line carrying this comment is never mutated; on a ``def`` (or decorator) line, the whole function.
NO_MUTATE_PRAGMA = "# faultlab: no mutate"
_PRAGMA = re.compile(r"#\s*faultlab:\s*no\s+mutate\b")
_RANGE = re.compile(r"^\s*(\d+)\s*(?:-\s*(\d+))?\s*$")


@dataclass(frozen=True)
class Target:
    """Where to mutate: a module, optionally only some of its functions and lines.

    Attributes
    ----------
    module : str
        The importable module's dotted name.
    functions : tuple of str
        Qualified names (``func`` or ``Class.method``) of the functions to mutate; empty: all.
    lines : tuple of (int, int)
        Inclusive line ranges of the file a mutated line must fall in; empty: all.
    """

    module: str
    functions: tuple[str, ...] = ()
    lines: tuple[tuple[int, int], ...] = ()

    def __str__(self) -> str:
        text = self.module + (":" + ",".join(self.functions) if self.functions else "")
        if self.lines:
            text += "@" + ",".join(f"{a}-{b}" for a, b in self.lines)
        return text


def _parse_lines(text: str, *, where: str) -> tuple[tuple[int, int], ...]:
    out = []
    for part in (p for p in text.split(",") if p.strip()):
        m = _RANGE.match(part)
        if not m:
            raise ConfigError(f"{where}: line range {part!r} is not N or N-M")
        a, b = int(m.group(1)), int(m.group(2) or m.group(1))
        if a < 1 or b < a:
            raise ConfigError(f"{where}: line range {part!r} is empty or starts before line 1")
        out.append((a, b))
    return tuple(out)


def _module_of_file(path: Path, *, where: str) -> str:
    path = path.resolve()
    best: tuple[int, str] | None = None
    for entry in sys.path:
        try:
            root = Path(entry or ".").resolve()
            rel = path.relative_to(root)
        except (ValueError, OSError):
            continue
        parts = list(rel.with_suffix("").parts)
        if parts and parts[-1] == "__init__":
            parts.pop()
        if parts and all(p.isidentifier() for p in parts) and (best is None or len(parts) < best[0]):
            best = (len(parts), ".".join(parts))
    if best is None:
        raise ConfigError(f"{where}: {path} is not importable from sys.path (install its package, or run "
                          f"from the directory holding it); name the module instead")
    return best[1]


def parse_target(text: str, *, functions: Iterable[str] = (), lines: Iterable | str = (),
                 where: str = "target") -> Target:
    """The :class:`Target` of ``text``: ``package.module``, ``package.module:function`` (``Class.method``,
    several comma-separated) or ``path/to/file.py`` with optional ``:10-40,55-60``.

    ``functions`` and ``lines`` (ranges as text ``"10-40,55"`` or pairs) narrow it further.
    """
    if not isinstance(text, str) or not text.strip():
        raise ConfigError(f"{where}: expected package.module[:function] or a file.py[:lines], got {text!r}")
    text = text.strip()
    head, _, tail = text.partition(".py:") if ".py:" in text else (text, "", "")
    funcs: list[str] = []
    ranges: tuple[tuple[int, int], ...] = ()
    if text.endswith(".py") or ".py:" in text:
        file = Path(head + ".py" if not text.endswith(".py") else text)
        if not file.is_file():
            raise ConfigError(f"{where}: no file {file}")
        module = _module_of_file(file, where=where)
        ranges = _parse_lines(tail, where=where) if tail else ()
    else:
        module, _, names = text.partition(":")
        funcs = [n.strip() for n in names.split(",") if n.strip()]
    if not all(p.isidentifier() for p in module.split(".")):
        raise ConfigError(f"{where}: {module!r} is not a module name")
    if module.split(".")[0] == "faultlab":
        raise ConfigError(f"{where}: {module!r} is faultlab's own code; its units are mutated without a target "
                          f"(faultlab mutate list)")
    funcs += [f for f in functions if f not in funcs]
    extra = _parse_lines(lines, where=where) if isinstance(lines, str) else tuple(
        (int(a), int(b)) for a, b in lines)
    return Target(module=module, functions=tuple(funcs), lines=ranges + extra)


# --------------------------------------------------------------------------- the module's functions

@dataclass(frozen=True)
class SourceFunction:
    """One mutable function of a module: its qualified name and its dedented source."""

    qualname: str
    first_line: int
    last_line: int
    indent: str
    source: str  # dedented
    excluded: str = ""  # why it is not mutated ("" if it is)
    body_line: int = 0  # first line of its body (after the signature): what runs only when it is called


@dataclass(frozen=True)
class ModuleSource:
    name: str
    path: str
    display_path: str
    text: str

    @cached_property
    def lines(self) -> list[str]:
        return self.text.splitlines(keepends=True)

    @cached_property
    def digest(self) -> str:
        return hashlib.sha256(self.text.encode()).hexdigest()[:16]


def module_source(name: str, *, where: str = "target") -> ModuleSource:
    """The source of module ``name`` through its import spec (never executing it)."""
    try:
        spec = importlib.util.find_spec(name)
    except (ImportError, ValueError) as exc:
        raise ConfigError(f"{where}: module {name!r} cannot be found ({type(exc).__name__}: {exc})") from None
    if spec is None or spec.loader is None or not hasattr(spec.loader, "get_source"):
        raise ConfigError(f"{where}: module {name!r} cannot be found on sys.path")
    try:
        text = spec.loader.get_source(name)
    except (ImportError, OSError) as exc:
        text = None
        why = str(exc)
    else:
        why = "no Python source (a compiled extension?)"
    if text is None:
        raise ConfigError(f"{where}: module {name!r} has no source to mutate: {why}")
    path = str(spec.origin)
    depth = name.count(".") + (1 if Path(path).name == "__init__.py" else 0)
    root = Path(path).resolve().parents[depth]
    try:
        display = Path(path).resolve().relative_to(root).as_posix()
    except ValueError:
        display = Path(path).name
    return ModuleSource(name=name, path=path, display_path=display, text=text)


def _has_pragma(line: str) -> bool:
    return bool(_PRAGMA.search(line))


def module_functions(src: ModuleSource) -> list[SourceFunction]:
    """Every module-level function and method of a module-level class, in file order."""
    try:
        tree = ast.parse(src.text)
    except SyntaxError as exc:
        raise ConfigError(f"{src.display_path}: the target module does not parse ({exc})") from None
    found: list[SourceFunction] = []

    def visit(body, prefix: str) -> None:
        for node in body:
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                found.append(_function(src, node, prefix + node.name))
            elif isinstance(node, ast.ClassDef) and not prefix:
                visit(node.body, node.name + ".")

    visit(tree.body, "")
    return found


def _function(src: ModuleSource, node, qualname: str) -> SourceFunction:
    first = min([node.lineno] + [d.lineno for d in node.decorator_list])
    last = node.end_lineno
    lines = src.lines[first - 1:last]
    indent = re.match(r"[ \t]*", lines[0]).group(0)
    excluded = ""
    if any(_has_pragma(src.lines[i - 1]) for i in range(first, node.body[0].lineno)):
        excluded = f"pragma {NO_MUTATE_PRAGMA!r}"
    dedented = []
    for line in lines:
        if line.startswith(indent):
            dedented.append(line[len(indent):])
        elif not line.strip():
            dedented.append(line.lstrip(" \t"))
        else:
            excluded = excluded or "a line indented less than its def (a multi-line string?)"
            dedented.append(line)
    source = "".join(dedented)
    if not excluded and _indent(source, indent) != "".join(lines):
        excluded = "its source does not survive dedenting"
    return SourceFunction(qualname=qualname, first_line=first, last_line=last, indent=indent, source=source,
                          excluded=excluded, body_line=node.body[0].lineno)


def _indent(text: str, indent: str) -> str:
    return "".join(indent + line if line.strip() else line for line in text.splitlines(keepends=True))


# --------------------------------------------------------------------------- mutants

def _key(function_source: str, operator: str, index: int) -> str:
    return hashlib.sha256(f"{function_source}\0{operator}\0{index}".encode()).hexdigest()[:12]


@dataclass(frozen=True)
class SourceMutant:
    """One mutant of a user's module: one operator at one point of one function.

    ``line`` is the first changed line of the file, ``key`` the incremental key (see the module
    docstring); ``original_module``/``mutated_module`` are the whole module's text.
    """

    id: str
    module: str
    function: str
    operator: str
    index: int
    key: str
    line: int
    path: str
    description: str
    change: str
    original_module: str = field(repr=False)
    mutated_module: str = field(repr=False)

    @property
    def unit(self) -> str:
        """The mutated function (what the unit is for a unit mutant)."""
        return self.function

    @cached_property
    def diff(self) -> str:
        """Unified diff of the file (``a/<path>``, ``b/<path>``; applies with ``patch -p1``)."""
        return "".join(difflib.unified_diff(self.original_module.splitlines(keepends=True),
                                            self.mutated_module.splitlines(keepends=True),
                                            fromfile=f"a/{self.path}", tofile=f"b/{self.path}", n=3))

    @cached_property
    def span(self) -> tuple[int, int, int, int]:
        """(start line, start column, end line, end column) of the changed text in the original file (1-based)."""
        a = self.original_module.splitlines()
        b = self.mutated_module.splitlines()
        for tag, i1, i2, _, _ in difflib.SequenceMatcher(a=a, b=b, autojunk=False).get_opcodes():
            if tag != "equal":
                i2 = max(i2, i1 + 1)
                first = a[i1] if i1 < len(a) else ""
                last = a[i2 - 1] if i2 - 1 < len(a) else ""
                col = len(first) - len(first.lstrip()) + 1
                return i1 + 1, col, i2, len(last) + 1
        return self.line, 1, self.line, 1

    @property
    def replacement(self) -> str:
        a = self.original_module.splitlines()
        b = self.mutated_module.splitlines()
        for tag, _, _, j1, j2 in difflib.SequenceMatcher(a=a, b=b, autojunk=False).get_opcodes():
            if tag != "equal":
                return "\n".join(line.strip() for line in b[j1:j2])
        return ""


def is_source_mutant_id(mutant_id: str) -> bool:
    """Whether ``mutant_id`` names a mutant of user source (five ``:``-separated parts)."""
    return isinstance(mutant_id, str) and mutant_id.count(":") == 4


def _function_mutants(src: ModuleSource, fn: SourceFunction, ops: Sequence[MutationOperator]) -> list[SourceMutant]:
    fs = FunctionSource(name=fn.qualname, source=fn.source, first_line=fn.first_line, path=src.path,
                        display_path=src.display_path)
    before = "".join(src.lines[:fn.first_line - 1])
    after = "".join(src.lines[fn.last_line:])
    out = []
    for m in function_mutants(fn.qualname, fs, ops, is_unit=True):
        if _has_pragma(src.lines[m.line - 1]):
            continue
        key = _key(fn.source, m.operator, m.index)
        out.append(SourceMutant(
            id=f"{src.name}:{fn.qualname}:{m.operator}:{m.index}:{key}", module=src.name, function=fn.qualname,
            operator=m.operator, index=m.index, key=key, line=m.line, path=src.display_path,
            description=m.description, change=m.change, original_module=src.text,
            mutated_module=before + _indent(m.mutated_source, fn.indent) + after))
    return out


@dataclass(frozen=True, eq=False)
class SourceMutants:
    """The mutants of a target: ``mutants`` in file, operator and point order; ``skipped`` function ->
    why it is not mutated; ``module`` the source they were made from."""

    target: Target
    module: ModuleSource
    mutants: tuple[SourceMutant, ...]
    skipped: dict[str, str]
    functions: tuple[SourceFunction, ...] = ()

    def __len__(self) -> int:
        return len(self.mutants)

    def __iter__(self):
        return iter(self.mutants)

    @cached_property
    def by_id(self) -> dict[str, SourceMutant]:
        return {m.id: m for m in self.mutants}

    def get(self, mutant_id: str) -> SourceMutant:
        if mutant_id in self.by_id:
            return self.by_id[mutant_id]
        close = difflib.get_close_matches(mutant_id, list(self.by_id), n=3, cutoff=0.6)
        hint = f"; did you mean {' or '.join(map(repr, close))}?" if close else ""
        raise FaultError(f"unknown mutant {mutant_id!r} of {self.target}{hint}")


def generate_source_mutants(target: Target, *, operators: Iterable[MutationOperator | str] | None = None,
                            plugins: bool = True) -> SourceMutants:
    """Every mutant of ``target`` (its functions and line ranges; pragma lines and functions left out)."""
    ops = all_operators(plugins=plugins) if operators is None else [
        get_operator(o) if isinstance(o, str) else o for o in operators]
    src = module_source(target.module)
    functions = module_functions(src)
    names = {f.qualname for f in functions}
    unknown = [f for f in target.functions if f not in names]
    if unknown:
        close = [c for u in unknown for c in difflib.get_close_matches(u, sorted(names), n=2)]
        raise ConfigError(f"target {target}: no function {', '.join(map(repr, unknown))} in {src.display_path}"
                          + (f"; did you mean {' or '.join(map(repr, close))}?" if close else
                             f"; it has {', '.join(sorted(names)) or 'none'}"))
    mutants: list[SourceMutant] = []
    skipped: dict[str, str] = {}
    chosen = []
    for fn in functions:
        if target.functions and fn.qualname not in target.functions:
            continue
        if target.lines and not any(a <= fn.last_line and fn.first_line <= b for a, b in target.lines):
            continue
        if fn.excluded:
            skipped[fn.qualname] = fn.excluded
            continue
        chosen.append(fn)
        mutants += [m for m in _function_mutants(src, fn, ops)
                    if not target.lines or any(a <= m.line <= b for a, b in target.lines)]
    return SourceMutants(target=target, module=src, mutants=tuple(mutants), skipped=skipped, functions=tuple(chosen))


def _current(module: str) -> ModuleSource:
    try:
        return module_source(module)
    except ConfigError as exc:
        raise FaultError(str(exc)) from None


def source_mutant(mutant_id: str) -> SourceMutant:
    """The mutant ``mutant_id`` regenerated from the module's current source (only its operator's
    points in its function); FaultError if the function changed since the id was made."""
    module = mutant_id.split(":")[0]
    return _source_mutant(mutant_id, _current(module))


@functools.lru_cache(maxsize=1024)
def _source_mutant(mutant_id: str, src: ModuleSource) -> SourceMutant:
    try:
        module, qualname, operator, n, key = mutant_id.split(":")
        index = int(n)
    except ValueError:
        raise FaultError(f"malformed mutant id {mutant_id!r}: expected <module>:<function>:<operator>:<n>:<key>") \
            from None
    fn = next((f for f in module_functions(src) if f.qualname == qualname), None)
    if fn is None:
        raise FaultError(f"mutant {mutant_id!r}: {src.display_path} has no function {qualname!r} any more")
    candidates = _function_mutants(src, fn, [get_operator(operator)])
    mutant = next((m for m in candidates if m.index == index), None)
    if mutant is None or mutant.key != key:
        raise FaultError(f"mutant {mutant_id!r} does not exist in the current source of {src.display_path}: "
                         f"{qualname} changed since it was generated")
    return mutant


# --------------------------------------------------------------------------- serving a mutated module

class _MutatedLoader(importlib.abc.Loader):
    def __init__(self, mutant: SourceMutant, origin: str):
        self.mutant = mutant
        self.origin = origin

    def create_module(self, spec):
        return None

    def exec_module(self, module) -> None:
        filename = f"<mutant {self.mutant.id} of {self.mutant.path}>"
        text = self.mutant.mutated_module
        linecache.cache[filename] = (len(text), None, text.splitlines(keepends=True), filename)
        module.__file__ = self.origin
        exec(compile(text, filename, "exec", dont_inherit=True), module.__dict__)


class _MutatedFinder(importlib.abc.MetaPathFinder):
    """Serves the mutated source of one module; every other import goes to the other finders."""

    def __init__(self, mutant: SourceMutant):
        self.mutant = mutant

    def find_spec(self, fullname, path=None, target=None):
        if fullname != self.mutant.module:
            return None
        for finder in sys.meta_path:
            if finder is self or not hasattr(finder, "find_spec"):
                continue
            spec = finder.find_spec(fullname, path, target)
            if spec is not None:
                break
        else:
            return None
        new = importlib.util.spec_from_loader(fullname, _MutatedLoader(self.mutant, str(spec.origin)),
                                              origin=spec.origin,
                                              is_package=spec.submodule_search_locations is not None)
        if spec.submodule_search_locations is not None:
            new.submodule_search_locations = list(spec.submodule_search_locations)
        new.has_location = spec.has_location
        return new


def _owned(name: str, tops: set[str]) -> bool:
    """Whether module ``name`` is imported afresh: a Python module of one of the ``tops`` packages
    (compiled extension modules stay: they cannot be initialised twice)."""
    if name.split(".")[0] not in tops:
        return False
    file = getattr(sys.modules.get(name), "__file__", None) or ""
    return not file.endswith(tuple(importlib.machinery.EXTENSION_SUFFIXES))


@functools.lru_cache(maxsize=8)
def _fresh(mutant: SourceMutant, factory_module: str, factory_source: ModuleSource | None) -> dict:
    """The target's and the factory's packages imported afresh with the mutant's module (cached per
    process and per source of the target and factory modules)."""
    tops = {mutant.module.split(".")[0], factory_module.split(".")[0]} - {"faultlab"}
    saved = {k: v for k, v in sys.modules.items() if _owned(k, tops)}
    finder = _MutatedFinder(mutant)
    for k in saved:
        del sys.modules[k]
    sys.meta_path.insert(0, finder)
    try:
        importlib.import_module(mutant.module)
        if factory_module:
            importlib.import_module(factory_module)
        return {k: v for k, v in sys.modules.items() if _owned(k, tops)}
    finally:
        sys.meta_path.remove(finder)
        for k in [k for k in sys.modules if _owned(k, tops)]:
            del sys.modules[k]
        sys.modules.update(saved)
        importlib.invalidate_caches()


@contextlib.contextmanager
def mutated_modules(mutant_id: str, factory_module: str = "") -> Iterator[None]:
    """Within the block, the target's package (and ``factory_module``'s) are those imported with the
    mutant's module; the original modules are back afterwards.  Import errors of the mutated
    module (a syntax error, a failing top-level statement) propagate."""
    factory = _current(factory_module) if factory_module and factory_module != mutant_id.split(":")[0] else None
    fresh = _fresh(source_mutant(mutant_id), factory_module, factory)
    saved = {k: sys.modules.get(k) for k in fresh}
    sys.modules.update(fresh)
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                sys.modules.pop(k, None)
            else:
                sys.modules[k] = v


def factory_module(slam_name: str) -> str:
    """The module of a SLAM factory import path ``package.module:factory`` ("" for a built-in name)."""
    return slam_name.partition(":")[0] if ":" in slam_name else ""


@dataclass(frozen=True)
class SourceMutantFault:
    """A mutant of user source as a campaign variant: :meth:`build_slam` builds the experiment's SLAM
    from the mutated module (the runner calls it instead of applying a unit fault)."""

    name: str
    mutant_id: str
    step: str = ""
    perturbs_stream: bool = False

    def build_slam(self, slam_spec):
        """``slam_spec.build()`` with the mutated module imported (see :func:`mutated_modules`)."""
        with mutated_modules(self.mutant_id, factory_module(slam_spec.name)):
            return slam_spec.build()


def source_mutant_fault(variant: str, mutant_id: str) -> SourceMutantFault:
    """The variant ``variant`` of mutant ``mutant_id`` (FaultError if it does not exist in the current source)."""
    source_mutant(mutant_id)
    return SourceMutantFault(name=variant, mutant_id=mutant_id)


def list_source_mutants(target: str, *, operator: str | None = None) -> str:
    """The listing of ``faultlab mutate list --target``: one line per mutant, then the functions left out."""
    found = generate_source_mutants(parse_target(target), operators=None if operator is None else [operator])
    rows = [("id", "line", "operator", "change")] + [(m.id, str(m.line), m.operator, m.change) for m in found]
    widths = [max(len(r[i]) for r in rows) for i in range(3)]
    lines = ["  ".join([c.ljust(w) for c, w in zip(r, widths)] + [r[3]]).rstrip() for r in rows]
    lines.append("")
    lines.append(f"{found.target}: {len(found)} mutants in {len(found.functions)} function(s) of "
                 f"{found.module.display_path} (not screened)")
    for name, why in found.skipped.items():
        lines.append(f"  {name} not mutated: {why}")
    return "\n".join(lines)
