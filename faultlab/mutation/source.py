"""The source of a SLAM's replaceable units and their private helpers, and rebuilding a unit from source.

A unit (a field of a frozen steps dataclass such as :class:`faultlab.slam.FastSlamSteps`) is a
module-level function.  Its *helpers* are the other module-level functions of the same module
that it calls, directly or through other helpers, and that are not units themselves (for the
reference FastSLAM: ``_wrap``, ``_vec2``, ``_sandwich_sym``, ``low_variance_indices``, ...).

:meth:`UnitSource.build` compiles the unit and all its helpers from source into a *copy* of the
module's namespace, with some functions' source replaced.  A mutated helper therefore changes
only the unit it is built for: ``wrap_bearing`` built with a mutated ``_wrap`` leaves
``wrap_heading`` (which calls the same helper) untouched, so a mutant still replaces exactly one
unit.  Nothing is written to disk and the module itself is never modified.  Code is compiled with
the module's ``__future__`` flags and padded so that line numbers are those of the file.
"""

from __future__ import annotations

import __future__
import dataclasses
import functools
import inspect
import linecache
import sys
import types
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from faultlab.errors import FaultError

__all__ = ["FunctionSource", "UnitSource", "unit_sources", "unit_source", "unit_functions", "code_identical",
           "POISONED_NUMPY", "ALTERNATE_POISONED_NUMPY", "ALTERNATE_POISON"]


@dataclass(frozen=True)
class FunctionSource:
    """The source of one module-level function.

    Attributes
    ----------
    name : str
        The function's name in its module.
    source : str
        Its source text (from :func:`inspect.getsource`), starting at the first decorator or ``def``.
    first_line : int
        Line of ``source``'s first line in the file (1-based).
    path : str
        Absolute path of the file.
    display_path : str
        Path relative to the directory holding the top-level package, e.g.
        ``faultlab/slam/units.py`` (what a diff names; ``patch -p1`` applies from there).
    """

    name: str
    source: str
    first_line: int
    path: str
    display_path: str


@dataclass(frozen=True, eq=False)
class UnitSource:
    """A unit function with its helpers, as source, and the namespace they run in.

    Attributes
    ----------
    unit : str
        The field name of the unit in the steps dataclass.
    functions : tuple of FunctionSource
        The unit's function first, then its helpers in the order they are first referenced.
    namespace : dict
        The globals of the unit's module (never modified; :meth:`build` copies it).
    """

    unit: str
    functions: tuple[FunctionSource, ...]
    namespace: dict = dataclasses.field(repr=False)

    @property
    def function_name(self) -> str:
        return self.functions[0].name

    def function(self, name: str) -> FunctionSource:
        for f in self.functions:
            if f.name == name:
                return f
        raise FaultError(f"unit {self.unit!r} has no function or helper {name!r}; it has "
                         f"{', '.join(f.name for f in self.functions)}")

    @property
    def future_flags(self) -> int:
        """Compiler flags of the ``from __future__`` imports of the unit's module."""
        flags = 0
        for feature in __future__.all_feature_names:
            if self.namespace.get(feature) is getattr(__future__, feature):
                flags |= getattr(__future__, feature).compiler_flag
        return flags

    def compile(self, name: str, source: str | None = None, *, filename: str | None = None) -> types.CodeType:
        """The module-level code object defining function ``name`` (``source`` replaces its own).

        Raises SyntaxError (or ValueError) if ``source`` does not compile.
        """
        f = self.function(name)
        text = f.source if source is None else source
        padded = "\n" * (f.first_line - 1) + text
        return compile(padded, filename or f.path, "exec", flags=self.future_flags, dont_inherit=True)

    def function_code(self, name: str, source: str | types.CodeType | None = None) -> types.CodeType:
        """The code object of function ``name`` itself (for bytecode comparison).

        ``source`` is its source or the module-level code object :meth:`compile` made of it
        (default: the original source).
        """
        module_code = source if isinstance(source, types.CodeType) else (
            self._original_code[name] if source is None else self.compile(name, source))
        for const in module_code.co_consts:
            if isinstance(const, types.CodeType) and const.co_name == name:
                return const
        raise FaultError(f"source of {name!r} does not define a function {name!r}")

    @functools.cached_property
    def _original_code(self) -> dict[str, types.CodeType]:
        return {f.name: self.compile(f.name) for f in self.functions}

    def build(self, changed: Mapping[str, str | types.CodeType] | None = None, *, filename: str | None = None,
              poison: bool | str = False) -> Callable:
        """The unit function compiled from source, with the functions in ``changed`` replaced.

        Parameters
        ----------
        changed : mapping, optional
            Function name (the unit or one of its helpers) -> new source of that function, or its
            module-level code object from :meth:`compile`.
        filename : str, optional
            File name for the changed functions' code (tracebacks); their source is registered
            with :mod:`linecache` under that name so tracebacks show the mutated lines.
        poison : bool or "alternate"
            Build against :data:`POISONED_NUMPY`: arrays from ``np.empty``/``np.empty_like`` are
            filled with NaN (and integer arrays with their minimum), so a unit that leaves part of
            an output unwritten gives the same, visible result on every run instead of whatever
            the memory held; ``"alternate"`` builds against :data:`ALTERNATE_POISONED_NUMPY`
            (a different fill), to tell whether the output depends on the fill at all.

        Returns
        -------
        callable
            The unit, in a copy of its module's namespace that also holds its rebuilt helpers.
        """
        changed = dict(changed or {})
        unknown = set(changed) - {f.name for f in self.functions}
        if unknown:
            raise FaultError(f"unit {self.unit!r}: cannot change {sorted(unknown)}; not the unit or its helpers")
        ns = dict(self.namespace)
        if poison:
            stand_in = ALTERNATE_POISONED_NUMPY if poison == "alternate" else POISONED_NUMPY
            for key, value in list(ns.items()):
                if value is np:
                    ns[key] = stand_in
        for f in self.functions:
            code = changed.get(f.name, self._original_code[f.name])
            if isinstance(code, str):
                name = filename or f"<changed {f.name} of {f.display_path}>"
                if filename:
                    lines = ("\n" * (f.first_line - 1) + code).splitlines(keepends=True)
                    linecache.cache[name] = (len(code), None, lines, name)
                code = self.compile(f.name, code, filename=name)
            exec(code, ns)  # defines the function in the namespace copy
        return ns[self.function_name]


def _display_path(path: str, module_name: str) -> str:
    top = sys.modules.get(module_name.split(".")[0])
    top_file = getattr(top, "__file__", None)
    if top_file:
        root = Path(top_file).resolve().parent.parent
        try:
            return Path(path).resolve().relative_to(root).as_posix()
        except ValueError:
            pass
    return Path(path).name


def _function_source(func: types.FunctionType) -> FunctionSource:
    lines, first = inspect.getsourcelines(func)
    path = inspect.getsourcefile(func) or inspect.getfile(func)
    return FunctionSource(name=func.__name__, source="".join(lines), first_line=first, path=path,
                          display_path=_display_path(path, func.__module__))


def _referenced_names(code: types.CodeType) -> list[str]:
    names = list(code.co_names)
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            names += _referenced_names(const)
    return list(dict.fromkeys(names))


def _why_not_source(func) -> str | None:
    """Why ``func`` cannot be mutated from source (None if it can)."""
    if not isinstance(func, types.FunctionType):
        return f"not a Python function ({type(func).__name__})"
    if func.__name__ == "<lambda>" or func.__qualname__ != func.__name__:
        return f"not a module-level function ({func.__qualname__})"
    if func.__code__.co_freevars:
        return f"a closure over {', '.join(func.__code__.co_freevars)}"
    try:
        inspect.getsourcelines(func)
    except (OSError, TypeError) as exc:
        return f"no source ({exc})"
    return None


def unit_functions(steps) -> dict[str, Callable]:
    """Field name -> unit of a frozen steps dataclass (an instance or the class: its defaults)."""
    if not dataclasses.is_dataclass(steps):
        raise FaultError(f"expected a steps dataclass (such as FastSlamSteps), got {type(steps).__name__}")
    if isinstance(steps, type):
        return {f.name: f.default for f in dataclasses.fields(steps) if f.default is not dataclasses.MISSING}
    return {f.name: getattr(steps, f.name) for f in dataclasses.fields(steps)}


def _helpers(func: types.FunctionType, units: set[int]) -> list[types.FunctionType]:
    found: list[types.FunctionType] = []
    queue = [func]
    seen = {id(func)}
    while queue:
        current = queue.pop(0)
        for name in _referenced_names(current.__code__):
            obj = current.__globals__.get(name)
            if (isinstance(obj, types.FunctionType) and id(obj) not in seen and id(obj) not in units
                    and obj.__module__ == func.__module__ and obj.__globals__ is func.__globals__
                    and _why_not_source(obj) is None):
                seen.add(id(obj))
                found.append(obj)
                queue.append(obj)
    return found


def _unit_source(unit: str, func: types.FunctionType, other_units: set[int], helpers: bool) -> UnitSource:
    funcs = [func] + (_helpers(func, other_units) if helpers else [])
    return UnitSource(unit=unit, functions=tuple(_function_source(f) for f in funcs), namespace=func.__globals__)


def unit_sources(steps, *, helpers: bool = True) -> tuple[dict[str, UnitSource], dict[str, str]]:
    """The source of every unit of a steps table.

    Parameters
    ----------
    steps : dataclass instance or class
        A frozen steps dataclass (e.g. :data:`faultlab.slam.REFERENCE_STEPS`; a class stands for
        its default units).
    helpers : bool
        Include each unit's private helpers (module-level functions of its module that it calls
        and that are not units).

    Returns
    -------
    sources : dict
        Unit name -> :class:`UnitSource`, in field order.
    skipped : dict
        Unit name -> why it has no mutable source (a builtin, a closure, a lambda, ...).
    """
    units = unit_functions(steps)
    unit_ids = {id(f) for f in units.values()}
    sources: dict[str, UnitSource] = {}
    skipped: dict[str, str] = {}
    for name, func in units.items():
        why = _why_not_source(func)
        if why is not None:
            skipped[name] = why
        else:
            sources[name] = _unit_source(name, func, unit_ids - {id(func)}, helpers)
    return sources, skipped


@functools.lru_cache(maxsize=256)
def unit_source(unit: str, func: Callable, steps_type: type, *, helpers: bool = True) -> UnitSource:
    """The :class:`UnitSource` of one unit function ``func`` of a steps dataclass type.

    The other units are the type's defaults (a helper is never one of them).  Remembered per
    process (reading source with :mod:`inspect` tokenises the file), like :mod:`linecache` does.
    """
    why = _why_not_source(func)
    if why is not None:
        raise FaultError(f"unit {unit!r} cannot be mutated from source: {why}")
    others = {id(f) for f in unit_functions(steps_type).values()} - {id(func)}
    return _unit_source(unit, func, others, helpers)


# --------------------------------------------------------------------------- bytecode comparison

def _const_key(value):
    if isinstance(value, types.CodeType):
        return ("code", _code_key(value))
    if isinstance(value, (tuple, frozenset)):
        items = [_const_key(v) for v in value]
        return (type(value).__name__, tuple(sorted(items, key=repr) if isinstance(value, frozenset) else items))
    return (type(value).__name__, repr(value))  # repr tells -0.0 from 0.0 and 1 from 1.0


def _code_key(code: types.CodeType) -> tuple:
    return (code.co_code, tuple(_const_key(c) for c in code.co_consts), code.co_names, code.co_varnames,
            code.co_freevars, code.co_cellvars, getattr(code, "co_exceptiontable", b""))


def code_identical(a: types.CodeType, b: types.CodeType) -> bool:
    """Same bytecode, constants (by type and repr), names and nested code objects, recursively."""
    return _code_key(a) == _code_key(b)


# --------------------------------------------------------------------------- poisoned numpy

def _poison(arr: np.ndarray, alternate: bool = False) -> np.ndarray:
    kind = arr.dtype.kind
    if kind in "fc":
        arr.fill(ALTERNATE_POISON if alternate else np.nan)
    elif kind in "iu":
        arr.fill(np.iinfo(arr.dtype).max if alternate else np.iinfo(arr.dtype).min)
    elif kind == "b":
        arr.fill(not alternate)
    return arr


#: The finite fill of :data:`ALTERNATE_POISONED_NUMPY`'s float arrays (any value a unit would not
#: write by chance).
ALTERNATE_POISON = -7.25e3


class _PoisonedNumpy(types.ModuleType):
    """numpy, except that ``empty`` and ``empty_like`` return poisoned arrays.

    The default poison is NaN (integer arrays: their minimum; booleans: True); the alternate
    poison is :data:`ALTERNATE_POISON` (integers: their maximum; booleans: False).  A unit whose
    output differs between the two reads memory it never wrote.
    """

    def __init__(self, alternate: bool = False) -> None:
        super().__init__("numpy", "numpy with poisoned np.empty (faultlab mutant screening)")
        self._alternate = alternate

    def __getattr__(self, name: str):
        return getattr(np, name)

    def empty(self, *args, **kwargs) -> np.ndarray:
        return _poison(np.empty(*args, **kwargs), self._alternate)

    def empty_like(self, *args, **kwargs) -> np.ndarray:
        return _poison(np.empty_like(*args, **kwargs), self._alternate)


#: Stands in for numpy in the namespace of units built with ``poison=True``.
POISONED_NUMPY = _PoisonedNumpy()
#: The same with the alternate poison (``poison="alternate"``).
ALTERNATE_POISONED_NUMPY = _PoisonedNumpy(alternate=True)
