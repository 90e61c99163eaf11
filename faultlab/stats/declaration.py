"""A study's declared analyses: what it will test, at what level, over which unit, fixed before it runs.

A study file's ``[declaration]`` table names its primary comparisons before any SLAM runs; ``faultlab
study run`` stores it in the results store's metadata (covered by the metadata checksum) when the
store is created, and refuses to resume a store declared otherwise.  The analysis computes the
declared comparisons at the declared level, sidedness and unit, corrects them for multiplicity over
the declared family, and labels every other figure of the report *exploratory*.  A margin is part
of the declaration: it is never derived from the data it judges.

.. code-block:: toml

    [declaration]
    alpha = 0.05
    sidedness = "two-sided"     # of a difference test: "two-sided", "greater" (a > b), "less"
    family = "holm"             # multiplicity over the declared analyses: "holm" or "none" (one analysis)
    unit = "run"                # the unit of analysis: "run" (cases nested in evaluation runs) or "case"

    [[declaration.analyses]]
    table = "detection_means"   # the mean single-case detection probability over the faults
    strategy_a = "systematic"
    strategy_b = "random"
    test = "difference"         # H0: no difference

    [[declaration.analyses]]
    table = "detection_means"
    strategy_a = "systematic"
    strategy_b = "random"
    test = "equivalence"        # H0: |difference| >= margin (two one-sided tests at alpha)
    margin = 0.05

A declaration added to a study after it ran (the committed studies that predate declarations) is
recorded with ``recorded = "after the run"``: it says what the study was planned to test, and its
analyses stay exploratory.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np
import pandas as pd
from scipy.stats import ttest_ind
from statsmodels.stats.weightstats import ttost_ind

from faultlab.config import Table
from faultlab.errors import ConfigError
from faultlab.inference.clusters import compare_by_cluster
from faultlab.inference.multiplicity import holm
from faultlab.vocabulary import DEFAULT_ALPHA

__all__ = ["DECLARATION_KEY", "DECLARED_TABLES", "TESTS", "UNITS", "FAMILIES", "SIDEDNESS", "RECORDED",
           "DeclaredAnalysis", "Declaration", "declaration_from", "DECLARED_COLUMNS", "CONFIRMATORY",
           "DECLARED_AFTER", "EXPLORATORY", "label_rows", "declared_table"]

#: Metadata key of a store (and of a saved study analysis) holding the declaration.
DECLARATION_KEY = "declaration"
#: Tables of a study analysis a declared analysis can name.
DECLARED_TABLES: tuple[str, ...] = ("detection_means", "detection_comparisons", "comparisons")
#: Declared tests: a difference from 0, or equivalence within a declared margin.
TESTS: tuple[str, ...] = ("difference", "equivalence")
#: Units of analysis: the evaluation run (cases nested in runs) or the case.
UNITS: tuple[str, ...] = ("run", "case")
#: Multiplicity over the declared analyses.
FAMILIES: tuple[str, ...] = ("holm", "none")
#: Sidedness of a difference test (SciPy's names).
SIDEDNESS: tuple[str, ...] = ("two-sided", "greater", "less")
#: When a declaration was recorded: stored by ``study run`` before the first SLAM execution, or added later.
RECORDED: tuple[str, ...] = ("before the run", "after the run")

_KEYS = ("alpha", "sidedness", "family", "unit", "analyses", "recorded", "note")
_ANALYSIS_KEYS = ("table", "strategy_a", "strategy_b", "variant", "test", "margin", "size")


@dataclass(frozen=True)
class DeclaredAnalysis:
    """One declared comparison.

    Attributes
    ----------
    table : str
        The study table it is read from (:data:`DECLARED_TABLES`).
    strategy_a, strategy_b : str
        The pair compared (``a - b``); ``"*"`` declares every pair of the table.
    test : {"difference", "equivalence"}
    margin : float or None
        The equivalence margin (a difference of proportions, 0.05 = 5 pp); required for
        ``equivalence``, absent otherwise.
    variant : str
        The fault of a ``detection_comparisons`` row (``"*"``: every fault).
    size : int or None
        The suite size of a ``comparisons`` row (None: every size).
    """

    table: str
    strategy_a: str = "*"
    strategy_b: str = "*"
    test: str = "difference"
    margin: float | None = None
    variant: str = "*"
    size: int | None = None

    def to_dict(self) -> dict:
        return {"table": self.table, "strategy_a": self.strategy_a, "strategy_b": self.strategy_b,
                "test": self.test, "margin": self.margin, "variant": self.variant, "size": self.size}

    def matches(self, table: str, a: str, b: str, *, variant: str | None = None, size: int | None = None) -> bool:
        """Whether the row ``(a, b[, variant, size])`` of ``table`` is one this analysis declares (either order)."""
        if table != self.table:
            return False
        pair = {self.strategy_a, self.strategy_b}
        if "*" not in pair and pair != {a, b}:
            return False
        if variant is not None and self.variant not in ("*", variant):
            return False
        return size is None or self.size is None or self.size == size

    def describe(self) -> str:
        pair = "every pair" if "*" in (self.strategy_a, self.strategy_b) else f"{self.strategy_a} - {self.strategy_b}"
        what = f"{self.table}: {pair}"
        if self.table == "detection_comparisons":
            what += ", every fault" if self.variant == "*" else f", {self.variant}"
        if self.size is not None:
            what += f", suites of {self.size}"
        return what + (f", equivalence within ±{self.margin:g}" if self.test == "equivalence" else ", difference")


@dataclass(frozen=True)
class Declaration:
    """A study's declared analyses (the ``[declaration]`` table).

    Attributes
    ----------
    analyses : tuple of DeclaredAnalysis
    alpha : float
        The level of every declared test (the family-wise level under ``family = "holm"``).
    sidedness : {"two-sided", "greater", "less"}
        Of the difference tests (an equivalence test is two one-sided tests).
    family : {"holm", "none"}
        Multiplicity over the declared analyses.
    unit : {"run", "case"}
        The unit of analysis of the declared tests.
    recorded : {"before the run", "after the run"}
        When it was recorded (``study run`` records ``before the run`` in a new store).
    note : str
        Free text (e.g. what the plan was when a declaration is recorded after the run).
    """

    analyses: tuple[DeclaredAnalysis, ...]
    alpha: float = DEFAULT_ALPHA
    sidedness: str = "two-sided"
    family: str = "holm"
    unit: str = "run"
    recorded: str = "before the run"
    note: str = ""

    @property
    def confirmatory(self) -> bool:
        """Whether its analyses are confirmatory (declared before the run)."""
        return self.recorded == RECORDED[0]

    def declares(self, table: str, a: str, b: str, *, variant: str | None = None, size: int | None = None) -> bool:
        return any(x.matches(table, a, b, variant=variant, size=size) for x in self.analyses)

    def margin_declared(self, table: str) -> bool:
        """Whether an equivalence margin is declared for ``table``."""
        return any(x.table == table and x.test == "equivalence" for x in self.analyses)

    def to_dict(self) -> dict:
        return {"alpha": self.alpha, "sidedness": self.sidedness, "family": self.family, "unit": self.unit,
                "recorded": self.recorded, "note": self.note, "analyses": [x.to_dict() for x in self.analyses]}


def _analysis(data, i: int, source: str) -> DeclaredAnalysis:
    if isinstance(data, Mapping):  # a stored record writes an absent margin or size as null
        data = {k: v for k, v in data.items() if v is not None}
    t = Table(data, f"declaration.analyses[{i}]", source)
    t.check_unknown(_ANALYSIS_KEYS)
    table = t.str("table", "", choices=DECLARED_TABLES)
    if not table:
        raise t.error("table", f"is required (one of {', '.join(DECLARED_TABLES)})")
    test = t.str("test", "difference", choices=TESTS)
    margin = None
    if test == "equivalence":
        if not t.has("margin"):
            raise t.error("margin", "is required for an equivalence test (a difference of proportions, 0.05 = 5 pp), "
                                    "declared before the run, never derived from its data")
        margin = t.float("margin", 0.0, positive=True, maximum=1.0)
    elif t.has("margin"):
        raise t.error("margin", "belongs to an equivalence test (test = \"equivalence\")")
    size = t.int("size", 0, minimum=1) if t.has("size") else None
    if size is not None and table != "comparisons":
        raise t.error("size", "names a suite size of the comparisons table only")
    variant = t.str("variant", "*")
    if variant != "*" and table != "detection_comparisons":
        raise t.error("variant", "names a fault of the detection_comparisons table only")
    a, b = t.str("strategy_a", "*"), t.str("strategy_b", "*")
    if (a == "*") != (b == "*") or (a != "*" and a == b):
        raise ConfigError(f"{source}: declaration.analyses[{i}]: strategy_a and strategy_b name two different "
                          f"strategies, or both are \"*\" (every pair), got {a!r} and {b!r}")
    return DeclaredAnalysis(table=table, strategy_a=a, strategy_b=b, test=test, margin=margin, variant=variant,
                            size=size)


def declaration_from(data: Mapping, *, source: str, recorded: str | None = None) -> Declaration:
    """Validate a ``[declaration]`` table (or a stored one) into a :class:`Declaration`.

    ``recorded`` overrides the table's own ``recorded`` (a study file cannot claim when it was
    recorded: ``study run`` says so); a table without it reads as recorded after the run.

    Raises
    ------
    ConfigError
        One message naming the file and key: an unknown key, a level outside (0, 1), an unknown
        sidedness, family or unit, no analyses, an equivalence test without a margin, ...
    """
    t = Table(data, "declaration", source)
    t.check_unknown(_KEYS)
    alpha = t.float("alpha", DEFAULT_ALPHA, positive=True)
    if not alpha < 1:
        raise t.error("alpha", f"must lie in (0, 1), got {alpha!r}")
    raw = t.get("analyses", [])
    if not isinstance(raw, list) or not raw:
        raise t.error("analyses", "must be a non-empty list of tables ([[declaration.analyses]])")
    analyses = tuple(_analysis(x, i, source) for i, x in enumerate(raw))
    family = t.str("family", "holm", choices=FAMILIES)
    if family == "none" and len(analyses) > 1:
        raise t.error("family", f"is \"none\" but {len(analyses)} analyses are declared: name the correction "
                                f"(\"holm\")")
    return Declaration(analyses=analyses, alpha=alpha, sidedness=t.str("sidedness", "two-sided", choices=SIDEDNESS),
                       family=family, unit=t.str("unit", "run", choices=UNITS),
                       recorded=recorded if recorded is not None else t.str("recorded", RECORDED[1], choices=RECORDED),
                       note=t.str("note", ""))


#: Columns of :func:`declared_table`.
DECLARED_COLUMNS = ("analysis", "status", "table", "strategy_a", "strategy_b", "test", "unit", "sidedness", "margin",
                    "n_a", "n_b", "runs", "estimate", "level", "estimate_low", "estimate_high", "p", "p_family",
                    "decision")

#: Values of a table's ``analysis`` column (:func:`label_rows`).
CONFIRMATORY, DECLARED_AFTER, EXPLORATORY = "confirmatory", "declared after the run", "exploratory"


def label_rows(frame, declaration: Declaration | None, table: str):
    """``frame`` (a study table with ``strategy_a``, ``strategy_b`` and, where it has them, ``variant``
    and ``size``) with a column ``analysis``: ``confirmatory`` for a row a declaration recorded before
    the run declares, ``declared after the run`` for one a later declaration names, ``exploratory``
    for every other row."""
    out = frame.copy()
    if out.empty:
        out["analysis"] = []
        return out
    status = CONFIRMATORY if declaration is not None and declaration.confirmatory else DECLARED_AFTER
    variants = out["variant"] if "variant" in out.columns else [None] * len(out)
    sizes = out["size"] if "size" in out.columns else [None] * len(out)
    declared = [declaration is not None and declaration.declares(table, a, b, variant=v,
                                                                 size=None if n is None else int(n))
                for a, b, v, n in zip(out["strategy_a"], out["strategy_b"], variants, sizes)]
    out["analysis"] = np.where(declared, status, EXPLORATORY)
    return out


def declared_table(declaration: Declaration | None, *, score, strategy, run) -> pd.DataFrame:
    """The declared analyses computed at the declared level, sidedness and unit.

    Parameters
    ----------
    declaration : Declaration or None
        None gives an empty table (with the columns).
    score : array_like, shape (N,)
        Per pool case, the share of the faults it alone detects
        (:func:`faultlab.stats.killmatrix.case_scores`): the quantity of ``detection_means``.
    strategy, run : array_like, shape (N,)
        The pool case's strategy and evaluation run.

    Returns
    -------
    DataFrame
        One row per declared analysis (:data:`DECLARED_COLUMNS`).  A ``detection_means`` analysis is
        computed here: with ``unit = "run"`` paired by run
        (:func:`faultlab.inference.clusters.compare_by_cluster`: t over the runs' differences), with
        ``unit = "case"`` by Welch's t test over the cases (statsmodels ``ttost_ind`` for
        equivalence); a difference test's interval is at ``1 - alpha``, an equivalence test's at
        ``1 - 2 alpha`` (its dual).  ``p_family`` is Holm over the declared analyses (``family =
        "holm"``).  An analysis of another table is marked in that table's ``analysis`` column
        (:func:`label_rows`) and listed here without figures.
    """
    if declaration is None:
        return pd.DataFrame(columns=list(DECLARED_COLUMNS))
    d = declaration
    score, strategy, run = np.asarray(score, float), np.asarray(strategy), np.asarray(run)
    status = CONFIRMATORY if d.confirmatory else DECLARED_AFTER
    rows = []
    for x in d.analyses:
        row = {"analysis": x.describe(), "status": status, "table": x.table, "strategy_a": x.strategy_a,
               "strategy_b": x.strategy_b, "test": x.test, "unit": d.unit, "sidedness": d.sidedness,
               "margin": math.nan if x.margin is None else x.margin, "n_a": math.nan, "n_b": math.nan,
               "runs": math.nan, "estimate": math.nan, "level": math.nan, "estimate_low": math.nan,
               "estimate_high": math.nan, "p": math.nan,
               "decision": f"see {x.table}.csv (rows marked {status})"}
        if x.table == "detection_means" and "*" not in (x.strategy_a, x.strategy_b):
            a, b = strategy == x.strategy_a, strategy == x.strategy_b
            both = a | b
            level = 1 - d.alpha if x.test == "difference" else 1 - 2 * d.alpha
            row |= {"n_a": int(a.sum()), "n_b": int(b.sum()), "level": level}
            if d.unit == "run":
                res = compare_by_cluster(score[both], arm=a[both], cluster=run[both], alpha=1 - level,
                                         alternative=d.sidedness, margin=x.margin)
                p = res.p if x.test == "difference" else res.p_equivalence
                row |= {"runs": res.clusters, "estimate": res.estimate, "estimate_low": res.ci_low,
                        "estimate_high": res.ci_high, "p": p}
            else:
                xa, xb = score[a], score[b]
                res = ttest_ind(xa, xb, equal_var=False, alternative=d.sidedness if x.test == "difference"
                                else "two-sided")
                ci = ttest_ind(xa, xb, equal_var=False).confidence_interval(level)
                p = res.pvalue if x.test == "difference" else ttost_ind(xa, xb, -x.margin, x.margin,
                                                                        usevar="unequal")[0]
                row |= {"estimate": float(xa.mean() - xb.mean()), "estimate_low": float(ci.low),
                        "estimate_high": float(ci.high), "p": float(p)}
        rows.append(row)
    out = pd.DataFrame(rows)
    p = out["p"].to_numpy(float)
    fam = np.full(p.shape, np.nan)
    ok = np.isfinite(p)
    if ok.any():
        fam[ok] = holm(p[ok], alpha=d.alpha)[1] if d.family == "holm" else p[ok]
    out["p_family"] = fam
    for i, x in enumerate(d.analyses):
        if not ok[i]:
            if x.table == "detection_means" and "*" not in (x.strategy_a, x.strategy_b):
                out.loc[i, "decision"] = "cannot be judged (no spread over the units)"
            continue
        shown = fam[i] <= d.alpha
        if x.test == "equivalence":
            out.loc[i, "decision"] = (f"shown within ±{100 * x.margin:g} pp" if shown
                                      else f"not shown within ±{100 * x.margin:g} pp")
        else:
            sign = ">" if out.loc[i, "estimate"] > 0 else "<"
            out.loc[i, "decision"] = (f"shown: {x.strategy_a} {sign} {x.strategy_b}" if shown
                                      else "no difference shown")
    return out[list(DECLARED_COLUMNS)]
