"""Table II recomputed from the paper's own raw data, beside the printed figures.

The paper's replication data (``paper_repro/paper_table2_rms.csv``) holds the
unrounded RMS errors behind Table II; ``paper_table2_reported.csv`` the
"Detected Faults" percentages as printed.  :func:`paper_table` classifies the
raw rows once (:func:`faultlab.stats.outcomes`) and tabulates them with the
detection module (:func:`faultlab.stats.tabulate_rates`,
:func:`faultlab.stats.tabulate_by_suite`) -- nothing computed is hard-coded --
rounds the percentages as the paper does
(to whole percent, halves up) and marks every cell where the computed and the
printed figure differ.

The printed "by Suite" column is not in the reported CSV; unless that file has
rows with variant ``by_suite``, the printed values of Table II are taken from
:data:`PRINTED_BY_SUITE` (published figures, not computed ones).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np
import pandas as pd

from faultlab.data import shipped_file
from faultlab.errors import ResultsError
from faultlab.stats.detection import DetectionRule, outcomes
from faultlab.stats.rates import tabulate_by_suite, tabulate_rates
from faultlab.vocabulary import BASELINE, DEFAULT_ALPHA, PAPER_FAULTS, SUITE_ORDER, Outcome, ordered

__all__ = ["PaperTable", "paper_table", "load_paper_raw", "load_paper_reported", "resolve_data_path", "data_label",
           "percent", "PRINTED_BY_SUITE", "RAW_CSV", "REPORTED_CSV", "PAPER_RATE_COLUMNS",
           "PAPER_BY_SUITE_COLUMNS"]

#: Default locations: relative to the working directory, else the copies shipped in the package.
RAW_CSV = "paper_repro/paper_table2_rms.csv"
REPORTED_CSV = "paper_repro/paper_table2_reported.csv"
#: Table II's printed "by Suite" column (percent), used when the reported CSV lacks it.
PRINTED_BY_SUITE: dict[str, int] = {"systematic": 100, "fixed": 67, "random": 78}
_BY_SUITE_VARIANTS = ("by_suite", "(by suite)", "by suite")
#: Columns of :attr:`PaperTable.rates` (``detected`` counts the detecting jobs, ``k`` elsewhere).
PAPER_RATE_COLUMNS: tuple[str, ...] = ("suite", "fault", "detected", "n", "rate", "wilson_low", "wilson_high",
                                       "cp_low", "cp_high", "computed_pct", "reported_pct", "agrees")
#: Columns of :attr:`PaperTable.by_suite`.
PAPER_BY_SUITE_COLUMNS: tuple[str, ...] = ("suite", "detected_pairs", "n_pairs", "rate", "wilson_low",
                                           "wilson_high", "computed_pct", "reported_pct", "agrees", "missed")


def percent(k, n):
    """Whole percent of ``k / n`` rounded half up, as printed in Table II (exact integer arithmetic)."""
    k = np.asarray(k, dtype=np.int64)
    n = np.asarray(n, dtype=np.int64)
    if np.any(n <= 0):
        raise ValueError("percent: n must be positive")
    out = (200 * k + n) // (2 * n)
    return int(out) if out.ndim == 0 else out


def resolve_data_path(path: str | Path | None, default: str) -> Path:
    """Find a data file: ``path`` (or ``default``) as given, else the copy shipped with faultlab.

    A relative path is looked up in the working directory first; a repository path of a
    shipped file (``paper_repro/paper_table2_rms.csv``, see
    :func:`faultlab.data.shipped_file`) then falls back to the package's copy, so the
    defaults work from any directory and in an install without the repository.

    Raises
    ------
    ResultsError
        If no candidate exists (names every place tried).
    """
    p = Path(default if path is None else path)
    candidates = [p] if p.is_absolute() else [Path.cwd() / p]
    packaged = shipped_file(p)
    if packaged is not None:
        candidates.append(packaged)
    for c in candidates:
        if c.is_file():
            return c
    raise ResultsError(f"paper data file not found: tried {', '.join(str(c) for c in candidates)}")


def data_label(path: str | Path) -> str:
    """A name of a paper data file that holds no machine path, for what an analysis saves.

    The paper's own data (a file with the content of a shipped copy and its name) is named by
    its repository path (:data:`RAW_CSV`, :data:`REPORTED_CSV`), which
    :func:`resolve_data_path` finds again on any machine; any other file by its name and the
    sha256 of its content (``"mine.csv (sha256 <hex>)"``).  A relative path is kept as given.

    Parameters
    ----------
    path : str or Path
        The file read (as :func:`resolve_data_path` returned it), or an older saved label.
        An absolute path of a file that no longer exists keeps its name only.
    """
    p = Path(path)
    if not p.is_absolute():
        return str(path)
    if not p.is_file():
        return p.name
    digest = hashlib.sha256(p.read_bytes()).hexdigest()
    for repo_path in (RAW_CSV, REPORTED_CSV):
        shipped = shipped_file(repo_path)
        if (shipped is not None and p.name == shipped.name
                and hashlib.sha256(shipped.read_bytes()).hexdigest() == digest):
            return repo_path
    return f"{p.name} (sha256 {digest})"


def _read_csv(path: Path, required: tuple[str, ...]) -> pd.DataFrame:
    try:
        df = pd.read_csv(path)
    except (OSError, pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise ResultsError(f"{path}: cannot read CSV ({exc})") from exc
    missing = [c for c in required if c not in df.columns]
    if missing:
        raise ResultsError(f"{path}: missing column(s) {', '.join(missing)}")
    return df


def _numeric(df: pd.DataFrame, col: str, path: Path, *, integer: bool = False) -> pd.Series:
    x = pd.to_numeric(df[col], errors="coerce")
    bad = x.isna() | ~np.isfinite(x.astype(float))
    if integer:
        bad |= (x != np.round(x))
    if bad.any():
        i = int(np.flatnonzero(bad.to_numpy())[0])
        raise ResultsError(f"{path}: row {i + 2}: column {col} has invalid value {df[col].iloc[i]!r}")
    return x.astype(np.int64) if integer else x.astype(float)


def load_paper_raw(path: str | Path) -> pd.DataFrame:
    """The raw Table II RMS rows as a results-schema frame (``rep`` 0, ``status`` ok).

    Parameters
    ----------
    path : path of a CSV with columns ``suite, variant, run, case, rms_mm``.

    Returns
    -------
    DataFrame
        Columns ``run, suite, case, variant, rep, rms_mm, status``.
    """
    path = Path(path)
    df = _read_csv(path, ("suite", "variant", "run", "case", "rms_mm"))
    out = pd.DataFrame({"run": _numeric(df, "run", path, integer=True), "suite": df["suite"].astype(str),
                        "case": _numeric(df, "case", path, integer=True), "variant": df["variant"].astype(str),
                        "rep": 0, "rms_mm": _numeric(df, "rms_mm", path), "status": "ok"})
    if (out["rms_mm"] < 0).any():
        i = int(np.flatnonzero((out["rms_mm"] < 0).to_numpy())[0])
        raise ResultsError(f"{path}: row {i + 2}: negative rms_mm")
    dup = out.duplicated(["run", "suite", "case", "variant"])
    if dup.any():
        i = int(np.flatnonzero(dup.to_numpy())[0])
        raise ResultsError(f"{path}: row {i + 2}: duplicate (suite, variant, run, case)")
    if not (out["variant"] == BASELINE).any():
        raise ResultsError(f"{path}: no '{BASELINE}' rows")
    return out


def load_paper_reported(path: str | Path) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Printed percentages: ``(detected, by_suite)`` frames.

    ``detected`` has columns ``suite, fault, reported_pct``; ``by_suite``
    ``suite, reported_pct`` (from rows with variant ``by_suite`` if present,
    else :data:`PRINTED_BY_SUITE`).
    """
    path = Path(path)
    df = _read_csv(path, ("suite", "variant", "detected_pct"))
    df = df.assign(detected_pct=_numeric(df, "detected_pct", path))
    is_bs = df["variant"].astype(str).str.lower().isin(_BY_SUITE_VARIANTS)
    det = df.loc[~is_bs].rename(columns={"variant": "fault", "detected_pct": "reported_pct"})
    det = det[["suite", "fault", "reported_pct"]].reset_index(drop=True)
    if is_bs.any():
        bs = df.loc[is_bs, ["suite", "detected_pct"]].rename(columns={"detected_pct": "reported_pct"})
    else:
        bs = pd.DataFrame({"suite": list(PRINTED_BY_SUITE), "reported_pct": list(PRINTED_BY_SUITE.values())})
    return det, bs.reset_index(drop=True)


@dataclass(frozen=True, eq=False)
class PaperTable:
    """Table II recomputed from raw data, beside the printed percentages.

    Attributes
    ----------
    rule : DetectionRule
    results : DataFrame
        The raw RMS rows in the results schema (:func:`load_paper_raw`).
    outcomes : DataFrame
        :func:`faultlab.stats.outcomes` of ``results`` under ``rule``.
    rates : DataFrame
        Per (suite, fault), columns :data:`PAPER_RATE_COLUMNS`: ``detected, n, rate,
        wilson_low, wilson_high, cp_low, cp_high, computed_pct, reported_pct, agrees``.
    by_suite : DataFrame
        Per suite, columns :data:`PAPER_BY_SUITE_COLUMNS`: ``detected_pairs, n_pairs, rate,
        wilson_low, wilson_high, computed_pct, reported_pct, agrees, missed``.
    raw_path, reported_path : Path or str
        The files read, or their :func:`data_label` when the table comes from a saved analysis.
    """

    rule: DetectionRule
    results: pd.DataFrame
    outcomes: pd.DataFrame
    rates: pd.DataFrame
    by_suite: pd.DataFrame
    raw_path: Path | str
    reported_path: Path | str

    @cached_property
    def rms(self) -> pd.DataFrame:
        """RMS errors, mm; index (suite, variant) in Table II order, columns MultiIndex (run, case)."""
        suites = ordered(self.results["suite"], SUITE_ORDER)
        faulty = self.results.loc[self.results["variant"] != BASELINE, "variant"]
        variants = [BASELINE] + ordered(faulty, PAPER_FAULTS)
        wide = self.results.pivot_table(index=["suite", "variant"], columns=["run", "case"], values="rms_mm",
                                        aggfunc="first")
        index = pd.MultiIndex.from_product([suites, variants], names=["suite", "variant"])
        return wide.reindex(index).sort_index(axis=1)

    @cached_property
    def detected(self) -> pd.DataFrame:
        """Same shape as :attr:`rms`: True where the faulty cell detects its fault (baseline rows False)."""
        rms = self.rms
        oc = self.outcomes
        det = oc.assign(hit=oc["outcome"] == Outcome.DETECTED.value).pivot_table(
            index=["suite", "fault"], columns=["run", "case"], values="hit", aggfunc="any")
        det.index = det.index.set_names(["suite", "variant"])
        return det.reindex(index=rms.index, columns=rms.columns).fillna(False).astype(bool)

    @property
    def disagreements(self) -> pd.DataFrame:
        """Every cell where computed and printed differ: ``column, suite, fault, computed_pct, reported_pct``."""
        a = self.rates.loc[~self.rates["agrees"], ["suite", "fault", "computed_pct", "reported_pct"]]
        a = a.assign(column="Detected Faults")
        b = self.by_suite.loc[~self.by_suite["agrees"], ["suite", "computed_pct", "reported_pct"]]
        b = b.assign(column="by Suite", fault="")
        cols = ["column", "suite", "fault", "computed_pct", "reported_pct"]
        return pd.concat([a[cols], b[cols]], ignore_index=True)

    def to_text(self) -> str:
        """The RMS table with detected cells starred, then the comparison of percentages."""
        cells = self.rms.map(lambda v: "" if np.isnan(v) else f"{int(np.floor(v + 0.5))}")
        cells = cells.where(~self.detected, cells + "*")
        cells.columns = [f"{r}.{c}" for r, c in cells.columns]
        lines = [f"Table II recomputed from {data_label(self.raw_path)}",
                 f"RMS map error, mm, column = run.case; * = {self.rule.describe()}", "",
                 cells.to_string(), "", f"Detected Faults: computed vs printed ({data_label(self.reported_path)})"]
        r = self.rates.copy()
        r["computed"] = [f"{p:d} % ({k}/{n})" if n else "-"
                         for p, k, n in zip(r["computed_pct"], r["detected"], r["n"])]
        r["printed"] = [f"{p:g} %" if np.isfinite(p) else "-" for p in r["reported_pct"]]
        r["95% Wilson CI"] = [f"{100 * lo:.0f}-{100 * hi:.0f} %" for lo, hi in zip(r["wilson_low"],
                                                                                   r["wilson_high"])]
        r[""] = np.where(r["agrees"], "", "<-- DIFFERS")
        lines.append(r[["suite", "fault", "computed", "printed", "95% Wilson CI", ""]].to_string(index=False))
        lines += ["", "by Suite (fault x run pairs detected by >= 1 case): computed vs printed"]
        b = self.by_suite.copy()
        b["computed"] = [f"{p:d} % ({k}/{n})" for p, k, n in zip(b["computed_pct"], b["detected_pairs"],
                                                                 b["n_pairs"])]
        b["printed"] = [f"{p:g} %" if np.isfinite(p) else "-" for p in b["reported_pct"]]
        b[""] = np.where(b["agrees"], "", "<-- DIFFERS")
        b["missed"] = b["missed"].replace("", "-")
        lines.append(b[["suite", "computed", "printed", "", "missed"]].to_string(index=False))
        dis = self.disagreements
        lines.append("")
        if dis.empty:
            lines.append("All computed percentages agree with the printed ones.")
        else:
            lines.append(f"{len(dis)} cell(s) differ from the printed table:")
            for d in dis.itertuples():
                where = f"{d.suite} / {d.fault}" if d.fault else d.suite
                lines.append(f"  {d.column}, {where}: computed {d.computed_pct} %, printed {d.reported_pct:g} %")
        return "\n".join(lines) + "\n"

    __str__ = to_text


def paper_table(raw_csv: str | Path, reported_csv: str | Path, *,
                rule: DetectionRule = DetectionRule(), alpha: float = DEFAULT_ALPHA) -> PaperTable:
    """Recompute Table II from the raw RMS rows and compare with the printed percentages.

    Parameters
    ----------
    raw_csv : path
        ``suite, variant, run, case, rms_mm`` rows (see ``paper_repro/``).
    reported_csv : path
        ``suite, variant, detected_pct`` as printed.
    rule : DetectionRule
        Detection thresholds (the paper's by default).
    alpha : float
        1 - confidence level of the intervals.

    Returns
    -------
    PaperTable
    """
    raw_path, reported_path = Path(raw_csv), Path(reported_csv)
    results = load_paper_raw(raw_path)
    printed, printed_bs = load_paper_reported(reported_path)
    oc = outcomes(results, rule=rule)

    dr = tabulate_rates(oc, alpha=alpha)
    rates = dr[["suite", "fault", "k", "n", "rate", "wilson_low", "wilson_high", "cp_low", "cp_high"]].rename(
        columns={"k": "detected"})
    rates["computed_pct"] = [percent(k, n) if n else -1 for k, n in zip(rates["detected"], rates["n"])]
    rates = rates.merge(printed, on=["suite", "fault"], how="left")
    rates["reported_pct"] = rates["reported_pct"].astype(float)
    rates["agrees"] = rates["computed_pct"] == rates["reported_pct"]

    bs = tabulate_by_suite(oc, alpha=alpha)
    bs["computed_pct"] = [percent(k, n) for k, n in zip(bs["detected_pairs"], bs["n_pairs"])]
    bs = bs.merge(printed_bs, on="suite", how="left")
    bs["reported_pct"] = bs["reported_pct"].astype(float)
    bs["agrees"] = bs["computed_pct"] == bs["reported_pct"]
    return PaperTable(rule=rule, results=results, outcomes=oc, rates=rates[list(PAPER_RATE_COLUMNS)],
                      by_suite=bs[list(PAPER_BY_SUITE_COLUMNS)], raw_path=raw_path, reported_path=reported_path)
