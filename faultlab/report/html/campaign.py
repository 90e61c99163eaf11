"""The HTML report of a campaign: an Analysis rendered as a static site (:mod:`faultlab.report.html.site`).

Pages: an overview (what ran, scale and cost, the headline verdicts with their intervals, the
cases where a fault was detected, Table I coverage, the analysis' notes); the sortable, filterable
tables of cases and of per-case verdicts; a page per case (the scenario's map, true path and the
landmarks the sensor saw, the error of every repetition of the baseline and of each variant, the
verdict of each fault with its test, effect and interval, the saved case file and the command that
exports it); the PDF's figures as images, each with its data table.

Every number comes from the :class:`~faultlab.analysis.Analysis`; nothing is computed here.  The
scenario of a case is read from the store's ``cases/`` directory, or, when the store has none (a
committed store keeps only its rows), generated again from the stored experiment by the one case
pipeline (:func:`faultlab.scenario.suite.draw_suite`, :func:`~faultlab.scenario.suite.generate_case`),
which gives the same scenario for the same seed.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pandas as pd

from faultlab.analysis import Analysis
from faultlab.errors import FaultlabError
from faultlab.report.html.site import Image, Links, Page, Plot, Site, Table, Text, figure_png, page_slug, write_site
from faultlab.runner.store import case_path
from faultlab.scenario.model import Scenario, load_scenario
from faultlab.vocabulary import BASELINE, REPLICA

__all__ = ["campaign_pages", "write_campaign_html", "build_campaign_html", "case_page_path", "HTML_DIR", "NAV"]

#: Folder of the site under a reports directory.
HTML_DIR = "html"
#: The navigation bar of every page of a campaign's site.
NAV = (("Overview", "index.html"), ("Cases", "cases.html"), ("Verdicts", "verdicts.html"),
       ("Figures", "figures.html"))
#: Verdicts that count as a detection.
DETECTED = ("detected", "crash_detected")


def case_page_path(run: int, suite: str, case: int) -> str:
    """The page of one case, relative to the site's root."""
    return f"cases/{page_slug('run', int(run), suite, 'case', int(case))}.html"


def write_campaign_html(analysis: Analysis, out: str | Path, *, store_dir: str | Path | None = None,
                        figures: bool = True) -> Site:
    """Write the campaign's site into ``out`` (e.g. ``REPORTS/html``); returns what was written.

    ``store_dir`` is the results directory whose saved cases are pictured (default: the store
    the analysis was made from); ``figures=False`` leaves out the PDF's figures (seconds faster).
    """
    store = Path(store_dir) if store_dir is not None else Path(analysis.metadata.get("path", ".")).parent
    pages = campaign_pages(analysis, store, out=Path(out), figures=figures)
    meta = analysis.metadata
    title = f"faultlab report: {Path(str(meta.get('experiment_source', 'campaign'))).stem}"
    return write_site(out, pages, title=title, nav=NAV)


def campaign_pages(analysis: Analysis, store_dir: Path, *, out: Path | None = None,
                   figures: bool = True) -> list[Page]:
    """Every page of a campaign's site (see the module docstring)."""
    scenarios = _Scenarios(store_dir, analysis.metadata)
    cases = _case_rows(analysis)
    pages = [_overview(analysis, cases), _cases_page(cases), _verdicts_page(analysis),
             _figures_page(analysis, figures)]
    pages += [_case_page(analysis, row, scenarios, out) for row in cases.to_dict("records")]
    return pages


# --------------------------------------------------------------------------- overview


def _fmt_pct(x: float) -> str:
    return "" if x is None or not math.isfinite(x) else f"{100 * x:.1f} %"


def _overview(analysis: Analysis, cases: pd.DataFrame) -> Page:
    meta = analysis.metadata
    jobs = analysis.this_run_jobs
    variants = [v for v in dict.fromkeys(jobs["variant"]) if v != BASELINE]
    per_run = ", ".join(f"{s} {n}" for s, n in analysis.cases_per_run.items())
    runs = int(analysis.cases["run"].nunique())
    statuses = ", ".join(f"{n} {s}" for s, n in analysis.status_counts.items())
    expected = analysis.expected_jobs
    total_s = float(jobs["runtime_s"].sum())
    what = [f"Experiment {meta.get('experiment_source', '(unknown)')} (hash {meta.get('experiment_hash', '?')}), "
            f"results store {meta.get('path', '?')}.",
            f"{runs} evaluation run(s); cases per run and suite: {per_run}; {len(cases)} cases in all.",
            f"Variants beside the baseline: {', '.join(variants) or 'none'}; K = {analysis.n_reps} repetition(s) per "
            f"case and variant.",
            f"{analysis.n_rows} SLAM executions" + (f" of the {expected} the experiment plans" if expected else "")
            + f" ({statuses}); {total_s:.0f} s of SLAM time ({total_s / 60:.1f} min).",
            f"Detection rule: {analysis.rule.describe()}."]
    sections = [Text("What ran, at what scale and cost", tuple(what))]
    rates = analysis.case_rates
    if not rates.empty:
        headline = pd.DataFrame({
            "suite": rates["suite"], "fault": rates["fault"], "detected cases": rates["k"],
            "judged cases": rates["n"], "cannot judge": rates["n_cannot_judge"],
            "rate": rates["rate"].map(_fmt_pct),
            "95 % interval (Clopper-Pearson)": [f"{_fmt_pct(lo)} to {_fmt_pct(hi)}" if math.isfinite(lo) else ""
                                                 for lo, hi in zip(rates["cp_low"], rates["cp_high"])]})
        sections.append(Table("Headline verdicts: cases where each fault was detected", headline, key="headline",
                              caption=_verdict_caption(analysis)))
    found = analysis.case_verdicts[analysis.case_verdicts["verdict"].isin(DETECTED)
                                   & (analysis.case_verdicts["fault"] != REPLICA)]
    items = tuple((f"run {int(r.run)}, {r.suite} case {int(r.case)}: {r.fault}",
                   case_page_path(r.run, r.suite, r.case),
                   f"({r.verdict.replace('_', ' ')}{_effect_text(r)})") for r in found.itertuples(index=False))
    sections.append(Links(f"Cases where a fault was detected ({len(found)})", items[:200],
                          caption="Each links to the case's page: its scenario, the error of every repetition and "
                                  "the verdicts." + (f" The first 200 of {len(items)}; the verdicts table lists all."
                                                     if len(items) > 200 else "")
                          if items else "No fault was detected on any case."))
    cov = analysis.coverage
    pooled = cov[cov["run"].isna()] if not cov.empty else cov
    if not pooled.empty:
        frame = pd.DataFrame({"parameter": pooled["parameter"], "suite": pooled["suite"],
                              "classes": pooled["classes"], "covered": pooled["covered"],
                              "coverage": pooled["coverage"].map(_fmt_pct), "uncovered": pooled["uncovered"]})
        sections.append(Table("Coverage of Table I (all runs pooled)", frame, key="coverage",
                              caption="Per parameter of Table I and suite: classes covered by the suite's cases "
                                      "(Sec. V); 'overall' pools the parameters."))
    notes = tuple(n.text for n in analysis.notes)
    if notes:
        sections.append(Text("Notes of the analysis", notes))
    sections.append(Links("Pages", (("All cases", "cases.html", "(sortable, filterable)"),
                                    ("All per-case verdicts", "verdicts.html", "(test, effect and interval of each)"),
                                    ("Figures of the PDF with their data", "figures.html", ""))))
    return Page("index.html", "Overview", tuple(sections))


def _verdict_caption(analysis: Analysis) -> str:
    text = " ".join(n.text for n in analysis.notes_on("verdicts"))
    return (f"Cases are the unit: detected / judged cases per suite and fault, exact 95 % intervals. {text}"
            if text else "Cases are the unit: detected / judged cases per suite and fault, exact 95 % intervals.")


def _effect_text(r) -> str:
    if not math.isfinite(float(r.median_diff_mm)):
        return ""
    lo, hi = float(r.median_low_mm), float(r.median_high_mm)
    interval = f" [{lo:.1f}, {hi:.1f}]" if math.isfinite(lo) and math.isfinite(hi) and lo < hi else ""
    return f", median shift {float(r.median_diff_mm):+.1f} mm{interval}"


# --------------------------------------------------------------------------- tables


def _case_rows(analysis: Analysis) -> pd.DataFrame:
    """One row per case: its values, faults detected on it and its page."""
    cases = analysis.cases.copy()
    v = analysis.case_verdicts
    v = v[v["fault"] != REPLICA]
    found = (v[v["verdict"].isin(DETECTED)].groupby(["run", "suite", "case"])["fault"]
             .agg(lambda f: ", ".join(sorted(f))).rename("faults detected"))
    cases = cases.merge(found, how="left", left_on=["run", "suite", "case"], right_index=True)
    cases["faults detected"] = cases["faults detected"].fillna("")
    cases["page"] = [case_page_path(r, s, c) for r, s, c in zip(cases["run"], cases["suite"], cases["case"])]
    cases["name"] = [f"run {int(r)} {s} {int(c)}" for r, s, c in zip(cases["run"], cases["suite"], cases["case"])]
    lead = ["name", "run", "suite", "case", "faults detected", "n_landmarks"]
    return cases[lead + [c for c in cases.columns if c not in lead]].reset_index(drop=True)


def _cases_page(cases: pd.DataFrame) -> Page:
    frame = cases.drop(columns=[c for c in cases.columns if c.startswith("class_")])
    table = Table("Cases", frame, key="cases", links={"name": "page"},
                  caption="One row per test case: its Table I values (SI units, as drawn) and the faults detected on "
                          "it. Click a column header to sort, type in the box to filter, click a name to open the case.")
    return Page("cases.html", "Test cases", (table,))


def _verdict_frame(v: pd.DataFrame) -> pd.DataFrame:
    frame = pd.DataFrame({
        "case": [f"run {int(r)} {s} {int(c)}" for r, s, c in zip(v["run"], v["suite"], v["case"])],
        "page": [case_page_path(r, s, c) for r, s, c in zip(v["run"], v["suite"], v["case"])],
        "fault": v["fault"], "verdict": v["verdict"], "reason": v["reason"], "judged pairs": v["n_judged"],
        "p": v["p"], "p (Holm)": v["p_holm"], "family": v["family"], "alternative": v["alternative"],
        "direction": v["direction"], "median shift mm": v["median_diff_mm"], "low mm": v["median_low_mm"],
        "high mm": v["median_high_mm"], "ratio": v["ratio"], "ratio low": v["ratio_low"],
        "ratio high": v["ratio_high"], "detectable shift mm": v["mde_mm"]})
    return frame.reset_index(drop=True)


def _verdicts_page(analysis: Analysis) -> Page:
    table = Table("Per-case verdicts", _verdict_frame(analysis.case_verdicts), key="verdicts", links={"case": "page"},
                  caption="One row per case and fault (the A/A replica included): the verdict of the campaign's rule "
                          "over the case's repetitions, the exact paired test's p and its Holm adjustment within the "
                          "family, the median shift of the error (faulty minus baseline) with its interval, the ratio "
                          "of medians and the smallest shift the case's test could detect. " + _verdict_caption(analysis))
    return Page("verdicts.html", "Per-case verdicts", (table,))


def _figures_page(analysis: Analysis, figures: bool) -> Page:
    if not figures:
        return Page("figures.html", "Figures", (Text("Figures", ("This report was written without figures.",)),))
    from faultlab.report.figures import detection_rate_figure, rms_distribution_figure

    rates = analysis.detection_rates
    rate_data = Table("Data: detection rates", rates[["suite", "variant", "k", "n", "rate", "wilson_low", "wilson_high",
                                                     "cp_low", "cp_high", "paper_k", "paper_n", "paper_rate"]],
                      key="figure-rates",
                      caption="Per suite and fault: detected pairs k of n (one SLAM pair per case, as in the paper), "
                              "the rate with Wilson and Clopper-Pearson 95 % intervals, the paper's figures beside.")
    jobs = analysis.jobs[analysis.jobs["status"] == "ok"]
    q = jobs.groupby(["source", "suite", "variant"])["rms_mm"]
    spread = pd.DataFrame({"n": q.size(), "min": q.min(), "q1": q.quantile(0.25), "median": q.median(),
                           "q3": q.quantile(0.75), "max": q.max()}).reset_index()
    rms_data = Table("Data: RMS map error per suite and variant (mm)", spread, key="figure-rms", digits=1,
                     caption="Successful jobs only; the quartiles the box plot draws.")
    sections = (Image("Detection rates per suite and fault", "figures/detection_rates.png",
                      figure_png(detection_rate_figure(analysis)),
                      caption="Bars with 95 % Wilson intervals; the paper's figures as markers.", data=rate_data),
                Image("RMS map error per suite and variant (log scale)", "figures/rms_distribution.png",
                      figure_png(rms_distribution_figure(analysis)), caption="Box plots and every job as a dot.",
                      data=rms_data))
    return Page("figures.html", "Figures of the PDF report", sections)


# --------------------------------------------------------------------------- a case


class _Scenarios:
    """Scenarios of a store's cases: the saved files, else generated again from the stored experiment."""

    def __init__(self, store_dir: Path, metadata: dict):
        self.store_dir = store_dir
        self.metadata = metadata
        self._drawn: dict | None = None
        self.why_not = ""

    def saved(self, run: int, suite: str, case: int) -> Path | None:
        path = case_path(self.store_dir, run, suite, case)
        return path if path.with_suffix(".npz").exists() else None

    def get(self, run: int, suite: str, case: int) -> tuple[Scenario | None, str]:
        path = self.saved(run, suite, case)
        if path is not None:
            try:
                return load_scenario(path), f"saved case {path.with_suffix('.npz')}"
            except (FaultlabError, OSError) as exc:
                return None, f"the saved case {path} cannot be read ({exc})"
        return self._generated(run, suite, case)

    def _generated(self, run: int, suite: str, case: int) -> tuple[Scenario | None, str]:
        from faultlab.runner.experiment import parse_experiment
        from faultlab.scenario.suite import draw_suite, generate_case

        if self._drawn is None:
            self._drawn = {}
            try:
                data = dict(self.metadata["experiment"])
                if isinstance(data.get("suites"), list):  # JSON keeps the suites as [[kind, n], ...]
                    data["suites"] = {kind: n for kind, n in data["suites"]}
                experiment = parse_experiment(data, source="stored experiment")
                space = experiment.parameter_space()
                self._experiment = experiment
                for r in range(1, experiment.runs + 1):
                    for s in experiment.suites:
                        for c in draw_suite(s.kind, space, root_seed=experiment.seed, run=r, n_cases=s.n_cases):
                            self._drawn[(c.run, c.suite, c.case)] = c
            except (FaultlabError, KeyError, TypeError, ValueError) as exc:
                self.why_not = f"the store keeps no case files and its experiment cannot be read ({exc})"
        drawn = self._drawn.get((int(run), suite, int(case)))
        if drawn is None:
            return None, self.why_not or "the case is not in the stored experiment"
        e = self._experiment
        scenario = generate_case(drawn, n_steps=e.n_steps, sensor_range=e.sensor_range, min_distance=e.min_distance,
                                 fov_bug=e.fov_bug)
        return scenario, "generated again from the stored experiment and the case's seed (the store keeps no case files)"


def _scenario_plot(scenario: Scenario):
    from bokeh.plotting import figure

    lm = scenario.landmarks.astype(np.float32)  # a picture: micrometres at 10 m, half the page
    seen = np.zeros(lm.shape[0], dtype=bool)
    ids = np.asarray(scenario.landmark_ids)
    observed = np.unique(np.asarray(scenario.obs_ids))
    seen[np.isin(ids, observed)] = True
    p = scenario.true_poses[:, :2].astype(np.float32)
    fig = figure(match_aspect=True, width=560, height=520, x_axis_label="x [m]", y_axis_label="y [m]",
                 tools="pan,wheel_zoom,box_zoom,reset,save", title=None)
    fig.scatter(lm[~seen, 0], lm[~seen, 1], size=4, color="#c8c8c8", legend_label=f"landmarks never seen ({int((~seen).sum())})")
    fig.scatter(lm[seen, 0], lm[seen, 1], size=5, color="#ff7f0e", legend_label=f"landmarks seen ({int(seen.sum())})")
    fig.line(p[:, 0], p[:, 1], color="#1f77b4", line_width=1.5, legend_label="true path")
    fig.scatter([p[0, 0]], [p[0, 1]], size=9, color="#1f77b4", marker="circle", legend_label="start")
    fig.legend.location = "top_left"
    fig.legend.click_policy = "hide"
    return fig


def _repetition_plot(jobs: pd.DataFrame):
    from bokeh.models import ColumnDataSource
    from bokeh.palettes import Category10_10
    from bokeh.plotting import figure

    ok = jobs[(jobs["status"] == "ok") & (jobs["rms_mm"] > 0)]
    fig = figure(width=640, height=360, y_axis_type="log", x_axis_label="repetition",
                 y_axis_label="RMS map error (mm, log)", tools="pan,wheel_zoom,box_zoom,reset,save,hover",
                 tooltips=[("variant", "@variant"), ("repetition", "@rep"), ("RMS mm", "@rms_mm{0.0}")])
    for i, (variant, rows) in enumerate(ok.groupby("variant", sort=False)):
        rows = rows.sort_values("rep")
        source = ColumnDataSource({"rep": rows["rep"].astype(int).tolist(), "rms_mm": rows["rms_mm"].astype(float).tolist(),
                                   "variant": [variant] * len(rows)})
        colour = Category10_10[i % 10]
        fig.line("rep", "rms_mm", source=source, color=colour, legend_label=variant, line_width=1.2)
        fig.scatter("rep", "rms_mm", source=source, color=colour, legend_label=variant, size=7)
    fig.legend.click_policy = "hide"
    fig.legend.location = "top_left"
    return fig


def _case_page(analysis: Analysis, row: dict, scenarios: _Scenarios, out: Path | None) -> Page:
    run, suite, case = int(row["run"]), row["suite"], int(row["case"])
    sections = []
    scenario, source = scenarios.get(run, suite, case)
    values = {k: v for k, v in row.items() if k not in ("name", "page", "faults detected")}
    facts = [f"Run {run}, suite {suite}, case {case}; faults detected here: {row['faults detected'] or 'none'}.",
             "Table I values: " + ", ".join(f"{k} = {_value(v)}" for k, v in values.items()
                                            if k not in ("run", "suite", "case") and not k.startswith("class_")) + ".",
             "Classes: " + ", ".join(f"{k.removeprefix('class_')} = {v}" for k, v in values.items()
                                     if k.startswith("class_")) + "."]
    sections.append(Text("The case", tuple(facts)))
    if scenario is not None:
        sections.append(Plot("Scenario: map, true path and landmarks seen", _scenario_plot(scenario),
                             caption=f"{scenario.landmarks.shape[0]} landmarks, {scenario.n_steps} steps; the scenario: "
                                     f"{source}. Click a legend entry to hide it."))
    else:
        sections.append(Text("Scenario", (f"Not pictured: {source}.",)))
    jobs = analysis.this_run_jobs
    jobs = jobs[(jobs["run"] == run) & (jobs["suite"] == suite) & (jobs["case"] == case)]
    sections.append(Plot("Error of every repetition, baseline and variants", _repetition_plot(jobs),
                         caption="Kabsch-aligned RMS map error of each SLAM execution; repetition r of every variant "
                                 "runs with the same SLAM seed (common random numbers). Crashes and timeouts have no "
                                 "error and appear in the table only."))
    rep_table = jobs.pivot_table(index="rep", columns="variant", values="rms_mm", aggfunc="first")
    order = [v for v in dict.fromkeys(jobs["variant"]) if v in rep_table.columns]
    rep_table = rep_table[order].reset_index()
    rep_table.columns = ["repetition"] + [f"{v} RMS mm" for v in order]
    failed = jobs[jobs["status"] != "ok"]
    sections.append(Table("Errors per repetition (mm)", rep_table, key="repetitions", digits=1, interactive=False,
                          caption="One row per repetition, one column per variant." + (
                              f" {len(failed)} execution(s) failed: "
                              + ", ".join(f"{v} rep {int(r)} ({s})" for v, r, s in
                                          zip(failed['variant'], failed['rep'], failed['status'])) + "."
                              if len(failed) else "")))
    v = analysis.case_verdicts
    v = v[(v["run"] == run) & (v["suite"] == suite) & (v["case"] == case)]
    sections.append(Table("Verdicts on this case", _verdict_frame(v).drop(columns=["case", "page"]), key="case-verdicts",
                          caption=_verdict_caption(analysis), interactive=False))
    saved = scenarios.saved(run, suite, case)
    export = [f"Export it (ROS 2 bag, TUM trajectories or a process-protocol transcript): "
              f"faultlab export {saved if saved is not None else '<store>/cases/...'} --format rosbag2 --out bags"]
    if saved is not None and out is not None:
        target = Path(os.path.relpath(saved.with_suffix(".npz"), out))
        sections.append(Links("The saved case", ((saved.with_suffix(".npz").name, target.as_posix(),
                                                  "(the case file in the results store, relative to this report)"),),
                              caption=export[0]))
    else:
        sections.append(Text("The saved case", (
            "The results store keeps no case files; `faultlab generate` or rerunning the experiment writes them "
            "(same seed, same case). " + export[0],)))
    return Page(case_page_path(run, suite, case), f"Case: run {run}, {suite}, case {case}", tuple(sections))


def _value(v) -> str:
    if isinstance(v, float | np.floating):
        return f"{float(v):.4g}"
    return str(v)


def build_campaign_html(results_dir: str | Path, reports_dir: str | Path, *, figures: bool = True) -> Site:
    """Analyse the store in ``results_dir`` (:func:`faultlab.analysis.analyse`) and write its site into
    ``REPORTS_DIR/html``; runs nothing."""
    from faultlab.analysis import analyse
    from faultlab.runner.store import results_path

    analysis = analyse(results_dir)
    return write_campaign_html(analysis, Path(reports_dir) / HTML_DIR, store_dir=results_path(results_dir).parent,
                               figures=figures)
