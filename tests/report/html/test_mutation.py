"""The mutation campaign's site, from the committed mutation store (read only): a page per mutant with its
diff, its status in every suite and the map errors of the cases that ran it."""

from __future__ import annotations

from faultlab.report.html.mutation import mutant_page_path
from faultlab.runner.store import load_results
from tests.report.html.conftest import MUTATION_STORE as STORE
from tests.report.html.test_site import refs_of


def test_every_mutant_has_a_page_linked_from_the_table(mutation_site):
    site, _, chosen = mutation_site
    refs = refs_of(site.root / "mutants.html")
    html = (site.root / "mutants.html").read_text()
    for mutant in chosen:
        assert (site.root / mutant_page_path(mutant)).is_file()
        assert f'"{mutant_page_path(mutant)}"' in html  # the table's link column
    assert len(site.pages) == 3 + len(chosen)
    assert all((site.root / r).is_file() for r in refs.refs if not r.startswith("#"))


def test_a_mutant_page_shows_the_diff_of_its_changed_line(mutation_site):
    from faultlab.mutation import show_mutant

    site, _, chosen = mutation_site
    for mutant in chosen:
        html = (site.root / mutant_page_path(mutant)).read_text()
        shown = show_mutant(mutant, cache=False)  # the diff `faultlab mutate show` prints
        changed = [line for line in shown.splitlines() if line.startswith(("+", "-")) and not line.startswith(("+++", "---"))]
        assert changed
        for line in changed:
            escaped = line.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&#34;").replace("'", "&#39;")
            assert f'class="{"add" if line[0] == "+" else "del"}">{escaped}' in html


def test_a_mutant_page_lists_every_job_that_ran_it_beside_the_baseline(mutation_site):
    site, analysis, chosen = mutation_site
    jobs = load_results(STORE)
    counts = []
    for mutant in chosen:
        n_jobs = int(jobs["variant"].str.endswith(f":{mutant}").sum())  # the campaign's variant "mutant:<id>"
        counts.append(n_jobs)
        parsed = refs_of(site.root / mutant_page_path(mutant))
        outcomes = analysis.outcomes[analysis.outcomes["mutant"] == mutant]
        html = (site.root / mutant_page_path(mutant)).read_text()
        for suite, outcome in zip(outcomes["suite"], outcomes["outcome"]):
            assert f"{suite} {outcome}" in html
        if n_jobs == 0:
            assert "screened out before the campaign" in html
        else:  # the paired table: 9 cells a row (run, suite, case, rep, mutant mm, status, baseline mm, status, diff)
            rows = parsed.cells[len(outcomes) * 17:]
            assert len(rows) == 9 * n_jobs
    killed, survived, stillborn = counts
    assert killed > 0 and survived > 0 and stillborn == 0  # the killed and survived mutants ran, the stillborn not


def test_the_outcomes_table_holds_the_mutants_that_ran(mutation_site):
    site, _, chosen = mutation_site
    killed, survived, stillborn = chosen
    html = (site.root / "outcomes.html").read_text()
    assert f'"{killed}"' in html and f'"{survived}"' in html and f'"{stillborn}"' not in html
    assert f'"{stillborn}"' in (site.root / "mutants.html").read_text()
