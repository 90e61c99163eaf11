"""A small campaign with one planted detection, its saved cases and its HTML site, for the HTML report tests.

The results follow the store's schema (:mod:`tests.report.conftest`); every case's error is the same
for the baseline and each fault except one (case, fault), whose every repetition is 100 times worse:
the paper's rule (stored with no rule: the paper's) detects exactly that case, so the site must lead
to it.  Each case's scenario is saved in the store's ``cases/`` directory, as a campaign saves it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from faultlab.analysis import Analysis
from faultlab.runner.store import case_path
from faultlab.scenario.model import save_scenario
from faultlab.scenario.suite import draw_suite, generate_case
from faultlab.space import table1_space
from tests.report.conftest import REPO, make_results

#: The one (run, suite, case, fault) where a fault is planted, and the campaign's size.
PLANTED = (1, "random", 2, "missing_angle_wrap")
REPS = 3
CASES = 2


def planted_rms(run, suite, case, variant, rep) -> float:
    base = 40.0 + 10.0 * case + rep  # the same for the baseline and every fault: nothing to detect
    return 100.0 * base if (run, suite, case, variant) == PLANTED else base


def save_cases(store: Path, results) -> dict:
    """A generated scenario (60 steps) saved for every case of ``results``; returns them by case."""
    drawn = draw_suite("systematic", table1_space(), root_seed=5, run=1, n_cases=5)
    saved = {}
    keys = results[["run", "suite", "case"]].drop_duplicates().itertuples(index=False)
    for i, (run, suite, case) in enumerate(keys):
        scenario = generate_case(drawn[i % len(drawn)], n_steps=60)
        save_scenario(scenario, case_path(store, run, suite, case))
        saved[(run, suite, case)] = scenario
    return saved


@pytest.fixture(scope="package")
def planted(tmp_path_factory):
    """(analysis, store directory, saved scenarios) of the planted campaign."""
    store = tmp_path_factory.mktemp("planted-store")
    results = make_results(planted_rms, reps=REPS, cases=CASES)
    analysis = Analysis.from_frame(results, {"path": str(store / "results.sqlite")}, paper=False)
    return analysis, store, save_cases(store, results)


@pytest.fixture(scope="package")
def planted_site(planted, tmp_path_factory):
    """The planted campaign's site (without the PDF's figures) and the analysis."""
    from faultlab.report.html.campaign import write_campaign_html

    analysis, store, scenarios = planted
    out = tmp_path_factory.mktemp("planted-report") / "html"
    return write_campaign_html(analysis, out, store_dir=store, figures=False), analysis, scenarios


def seen_landmarks(scenario) -> int:
    """Landmarks observed at least once, counted from the scenario's observations."""
    return int(np.isin(scenario.landmark_ids, np.unique(scenario.obs_ids)).sum())


#: The committed mutation campaign's store (read only).
MUTATION_STORE = REPO / "reports" / "mutation" / "store"


def pick(outcomes: pd.DataFrame, outcome: str) -> str:
    return str(outcomes.loc[outcomes["outcome"] == outcome, "mutant"].iloc[0])


@pytest.fixture(scope="package")
def mutation_site(tmp_path_factory):
    """The site of three mutants of the committed campaign: one killed, one survived, one stillborn."""
    from faultlab.analysis.mutation import MutationAnalysis, analyse_mutation
    from faultlab.report.html.mutation import write_mutation_html

    full = analyse_mutation(MUTATION_STORE)
    chosen = [pick(full.outcomes, o) for o in ("killed", "survived", "stillborn")]
    analysis = MutationAnalysis(outcomes=full.outcomes[full.outcomes["mutant"].isin(chosen)].reset_index(drop=True),
                                scores=full.scores, mcnemar=full.mcnemar, meta=full.meta)
    site = write_mutation_html(analysis, MUTATION_STORE, tmp_path_factory.mktemp("mutation") / "html")
    return site, analysis, chosen
