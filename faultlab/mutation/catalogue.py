"""The screened mutants of a SLAM by name, with an on-disk cache, and their listing for the command line.

:func:`mutant_catalogue` generates every mutant of a SLAM's units, records unit examples and
screens the mutants (:mod:`faultlab.mutation.screening`).  Screening the reference FastSLAM's
~1150 mutants takes a few seconds, so the results are cached in a JSON file keyed by a hash of
everything they depend on: the faultlab, Python, numpy and libcst versions, the source of every
module of the faultlab package and of the SLAM's unit modules, and the id and digest of every
mutant.  Any edit invalidates the cache; a stale entry is never used.

The cache lives in :func:`faultlab.cache.cache_dir` (``$FAULTLAB_CACHE_DIR`` if set, an empty
string disabling it, else ``$XDG_CACHE_HOME/faultlab``, else ``~/.cache/faultlab``).  An unwritable
cache directory only disables caching.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import inspect
import json
import sys
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import faultlab
from faultlab.cache import cache_dir, write_cache_json
from faultlab.errors import FaultError
from faultlab.mutation.examples import unit_examples
from faultlab.mutation.mutant import Mutant, MutantSet, generate_mutants
from faultlab.mutation.outcome import SCREENED_OUT, MutantOutcome
from faultlab.mutation.registry import get_operator
from faultlab.mutation.screening import Screening, ScreeningReport, screen_mutants
from faultlab.slam.registry import build_slam

__all__ = ["Catalogue", "CLASS_NOTES", "mutant_catalogue", "cache_dir", "list_mutants", "show_mutant", "class_counts"]

_CACHE_FORMAT = "faultlab-mutant-screening-2"

#: What each class means, for the count lines of the listing.
CLASS_NOTES = {
    "live": "run in a campaign",
    "stillborn": "does not compile, or raises on every unit example",
    "equivalent": "identical bytecode, or bit-identical unit outputs on every unit example",
    "duplicate": "bit-identical unit outputs to an earlier mutant, which runs instead",
    "nondeterministic": "unit outputs depend on what unwritten (np.empty) memory held: reported, never run",
}


@dataclass(frozen=True, eq=False)
class Catalogue:
    """The screened mutants of one SLAM.

    Attributes
    ----------
    slam : str
        The SLAM's name (``fastslam`` or an import path).
    report : ScreeningReport
    seconds : float
        Time to generate (and screen, unless cached) the mutants.
    cached : bool
        Whether the screening results came from the cache.
    """

    slam: str
    report: ScreeningReport
    seconds: float
    cached: bool = False

    @property
    def mutants(self) -> MutantSet:
        return self.report.mutants


def _source_files(mutants: MutantSet, slam) -> list[Path]:
    files = set(Path(faultlab.__file__).resolve().parent.rglob("*.py"))
    for src in mutants.sources.values():
        files.update(Path(f.path).resolve() for f in src.functions)
    try:
        files.add(Path(inspect.getsourcefile(type(slam))).resolve())
    except (TypeError, OSError):
        pass
    return sorted(files)


def _version(distribution: str) -> str:
    try:
        return importlib.metadata.version(distribution)
    except importlib.metadata.PackageNotFoundError:
        return "?"


def _cache_key(mutants: MutantSet, slam) -> str:
    h = hashlib.sha256()
    for part in (_CACHE_FORMAT, faultlab.__version__, sys.version, np.__version__,
                 _version("libcst"), mutants.steps_type.__module__, mutants.steps_type.__qualname__):
        h.update(f"{part}\0".encode())
    for path in _source_files(mutants, slam):
        h.update(f"{path.name}\0".encode())
        try:
            h.update(path.read_bytes())
        except OSError:
            h.update(b"<unreadable>")
    for m in mutants:
        h.update(f"{m.id}:{m.digest}\0".encode())
    return h.hexdigest()[:32]


def _cache_file(mutants: MutantSet, key: str) -> Path | None:
    d = cache_dir()
    if d is None:
        return None
    return d / "mutation" / f"{mutants.steps_type.__qualname__.lower()}-{key}.json"


def _load(path: Path | None, key: str, mutants: MutantSet) -> ScreeningReport | None:
    if path is None or not path.is_file():
        return None
    try:
        data = json.loads(path.read_text())
        if data.get("key") != key:
            return None
        results = {}
        for m in mutants:
            outcome, reason, dup = data["results"][m.id]
            results[m.id] = Screening(m.id, MutantOutcome(outcome) if outcome else None, reason, dup)
        return ScreeningReport(mutants=mutants, results=results, n_examples=dict(data["n_examples"]),
                               seconds=float(data["seconds"]))
    except (OSError, ValueError, KeyError, TypeError):
        return None  # a damaged or foreign file is ignored (and overwritten)


def _save(path: Path | None, key: str, report: ScreeningReport) -> None:
    if path is None:
        return
    data = {"key": key, "format": _CACHE_FORMAT, "faultlab": faultlab.__version__,
            "seconds": report.seconds, "n_examples": report.n_examples,
            "results": {i: [s.outcome.value if s.outcome else None, s.reason, s.duplicate_of]
                        for i, s in report.results.items()}}
    write_cache_json(path, data)


def mutant_catalogue(slam: str = "fastslam", *, cache: bool = True) -> Catalogue:
    """Every mutant of the units of SLAM ``slam``, screened.

    Parameters
    ----------
    slam : str
        A built-in SLAM name (``"fastslam"``) or an import path ``package.module:factory``; the
        SLAM must keep its units in a steps dataclass (``slam.steps``, ``slam.with_steps``).
    cache : bool
        Use and update the on-disk cache of screening results.

    Returns
    -------
    Catalogue
    """
    start = time.perf_counter()
    adapter = build_slam(slam, {})
    steps = getattr(adapter, "steps", None)
    if steps is None or not callable(getattr(adapter, "with_steps", None)):
        raise FaultError(f"SLAM {slam!r} has no replaceable units (no steps table / with_steps): "
                         f"there is nothing to mutate")
    mutants = generate_mutants(steps)
    key = _cache_key(mutants, adapter) if cache else ""
    path = _cache_file(mutants, key) if cache else None
    report = _load(path, key, mutants)
    cached = report is not None
    if report is None:
        report = screen_mutants(mutants, unit_examples(adapter))
        _save(path, key, report)
    return Catalogue(slam=slam, report=report, seconds=time.perf_counter() - start, cached=cached)


# --------------------------------------------------------------------------- listing

def _select(catalogue: Catalogue, unit: str | None, operator: str | None) -> list[Mutant]:
    mutants = list(catalogue.mutants)
    if unit is not None:
        units = {m.unit for m in mutants} | set(catalogue.mutants.skipped)
        if unit not in units:
            raise FaultError(f"unknown unit {unit!r}; {catalogue.slam} has: {', '.join(sorted(units))}")
        mutants = [m for m in mutants if m.unit == unit]
    if operator is not None:
        get_operator(operator)  # a clear error for an unknown name
        mutants = [m for m in mutants if m.operator == operator]
    return mutants


def _table(rows: list[tuple[str, ...]], header: tuple[str, ...]) -> list[str]:
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header) - 1)]
    lines = []
    for r in [header, *rows]:
        cells = [c.ljust(w) for c, w in zip(r, widths)] + [r[-1]]
        lines.append("  ".join(cells).rstrip())
    return lines


def list_mutants(slam: str = "fastslam", *, unit: str | None = None, operator: str | None = None,
                 all_mutants: bool = False, cache: bool = True) -> str:
    """The listing of ``faultlab mutate list``: one line per mutant, then a count line per class.

    By default only live mutants are listed (stillborn, equivalent and duplicate ones are
    counted); ``all_mutants`` lists every mutant with its class.
    """
    catalogue = mutant_catalogue(slam, cache=cache)
    report = catalogue.report
    chosen = _select(catalogue, unit, operator)
    shown = chosen if all_mutants else [m for m in chosen if report.results[m.id].live]
    lines: list[str] = []
    if shown:
        if all_mutants:
            header = ("id", "unit", "line", "operator", "class", "change")
            rows = [(m.id, m.unit, str(m.line), m.operator, report.results[m.id].label, m.change) for m in shown]
        else:
            header = ("id", "unit", "line", "operator", "change")
            rows = [(m.id, m.unit, str(m.line), m.operator, m.change) for m in shown]
        lines += _table(rows, header)
        lines.append("")
    counts = report.counts(chosen)
    scope = [f"unit {unit}"] if unit else []
    scope += [f"operator {operator}"] if operator else []
    how = "screening from the cache" if catalogue.cached else "screened"
    lines.append(f"{catalogue.slam}: {len(chosen)} mutants{' of ' + ', '.join(scope) if scope else ''} "
                 f"({how}; {catalogue.seconds:.1f} s)")
    width = max(len(k) for k in counts)
    for label, n in counts.items():
        lines.append(f"  {label.ljust(width)}  {n:5d}  {CLASS_NOTES[label]}")
    if catalogue.mutants.skipped and unit is None:
        for u, why in catalogue.mutants.skipped.items():
            lines.append(f"  unit {u} has no mutants: {why}")
    return "\n".join(lines)


def show_mutant(mutant_id: str, slam: str = "fastslam", *, cache: bool = True) -> str:
    """The text of ``faultlab mutate show ID``: the mutant's record, its class and its unified diff."""
    catalogue = mutant_catalogue(slam, cache=cache)
    report = catalogue.report
    m = catalogue.mutants.get(mutant_id)
    s = report.results[m.id]
    where = m.unit if m.function == m.unit else f"{m.unit} (helper {m.function}, built into this unit only)"
    lines = [
        f"mutant      {m.id}",
        f"unit        {where}",
        f"location    {m.path}:{m.line}",
        f"operator    {m.operator}: {get_operator(m.operator).description}",
        f"change      {m.description}",
        f"class       {s.label}: {s.reason}",
    ]
    if s.duplicate_of:
        lines.append(f"runs as     {s.duplicate_of}")
    members = report.members(m.id)
    if members:
        lines.append(f"stands for  {len(members)} duplicate(s): {', '.join(members)}")
    lines.append(f"fault name  {m.fault_name}")
    lines.append("")
    lines.append(m.diff.rstrip("\n"))
    return "\n".join(lines)


def class_counts(catalogue: Catalogue) -> dict[str, dict[str, int]]:
    """Operator -> class -> number of mutants (for reports and the docs)."""
    c = Counter((m.operator, catalogue.report.results[m.id].label) for m in catalogue.mutants)
    labels = ("live", *map(str, SCREENED_OUT))
    return {op: {label: c.get((op, label), 0) for label in labels}
            for op in dict.fromkeys(m.operator for m in catalogue.mutants)}
