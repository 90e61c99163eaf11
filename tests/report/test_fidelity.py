"""The fidelity page renders a Fidelity result as it is: every cell, the rule, the verdicts in words."""

from __future__ import annotations

import numpy as np
import pandas as pd

from faultlab.analysis.fidelity import FIDELITY, Fidelity, compare_with_paper
from faultlab.report.fidelity import fidelity_markdown, write_fidelity


def _fidelity(n_steps: int = 1000) -> Fidelity:
    rng = np.random.default_rng(1)
    rows = []
    for source in ("this", "paper"):
        for suite in ("systematic", "fixed"):
            for variant, scale in (("baseline", 60.0), ("missing_angle_wrap", 2000.0)):
                factor = 10.0 if (source == "this" and suite == "fixed" and variant == "baseline") else 1.0
                for i, x in enumerate(np.exp(rng.normal(np.log(scale * factor), 0.05, 15))):
                    rows.append({"source": source, "run": 1 + i // 5, "suite": suite, "case": 1 + i % 5,
                                 "variant": variant, "rep": 0, "rms_mm": x, "status": "ok"})
    df = pd.DataFrame(rows)
    meta = {"experiment": {"n_steps": n_steps, "runs": 3, "fov_bug": True,
                           "slam": {"name": "fastslam", "profile": "paper", "particles": 200}}}
    return compare_with_paper(df[df.source == "this"], df[df.source == "paper"], metadata=meta, n_boot=500)


def test_markdown_names_what_ran_the_rule_and_every_verdict():
    fid = _fidelity()
    md = fidelity_markdown(fid)
    assert "profile `paper`, fov_bug = true, 3 run(s), 1000 steps per case, 200 particles" in md
    assert "REDUCED" not in md
    assert "Mann-Whitney U" in md and "Holm" in md and "[1/2, 2]" in md
    table_rows = [line for line in md.splitlines() if line.startswith("| ") and "---" not in line][1:]
    assert len(table_rows) == len(fid.fidelity) == 4
    for row, verdict in zip(table_rows, fid.fidelity["verdict"]):
        assert row.rstrip(" |").endswith(verdict)
    assert fid.fidelity.loc[(fid.fidelity.suite == "fixed") & (fid.fidelity.variant == "baseline"), "verdict"].item() \
        == "differs"
    assert "Differs (1): Fixed / Nonfaulty Baseline." in md
    assert "## Faulty rotation (`missing_angle_wrap`)" in md
    rot = fid.fidelity[fid.fidelity.variant == "missing_angle_wrap"]
    lo, hi, plo, phi = rot.min_mm.min(), rot.max_mm.max(), rot.paper_min_mm.min(), rot.paper_max_mm.max()
    inside = plo <= lo and hi <= phi  # both samples ~2000 mm with 5 % spread: never far apart
    assert ("within the paper's range." in md) == inside
    assert inside or "the same range within a factor of 2 at both ends; the ranges overlap" in md


def test_a_reduced_campaign_is_labelled_and_files_hold_the_table(tmp_path):
    fid = _fidelity(n_steps=200)
    files = write_fidelity(fid, tmp_path / "r")
    assert "**REDUCED configuration**" in files.markdown.read_text()
    pd.testing.assert_frame_equal(FIDELITY.read_csv(files.csv), fid.fidelity)
    # the result's own save wrote the table: the bytes the schema writes, read back with its settings
    assert files.csv.read_bytes() == FIDELITY.to_csv(fid.fidelity, tmp_path / "schema.csv").read_bytes()
    back = Fidelity.load(files.meta.parent)
    assert (back.alpha, back.seed, back.campaign) == (fid.alpha, fid.seed, fid.campaign) and back.campaign["reduced"]
    pd.testing.assert_frame_equal(back.table("fidelity"), fid.fidelity)


def test_pdf_pages_and_the_ablations_evidence_on_the_faulty_rotation():
    from faultlab.analysis.ablation import compare_arms
    from faultlab.report.fidelity import FIDELITY_TITLE, fidelity_pages

    fid = _fidelity()
    rows = [{"arm": arm, "run": 1, "suite": "fixed", "case": c, "variant": "missing_angle_wrap", "rep": 0,
             "rms_mm": 1000.0 + 10 * c + shift, "status": "ok"}
            for arm, shift in (("paper_no_aliasing", 0.0), ("paper_no_aliasing_unwrapped_prediction", 500.0))
            for c in range(1, 6)]
    df = pd.DataFrame(rows)
    abl = compare_arms({a: g for a, g in df.groupby("arm")}, n_boot=200)
    md = fidelity_markdown(fid, abl)
    assert "Two-sample test per suite (Mann-Whitney U, Holm over the table): Systematic: p = " in md
    assert ("- predicted bearing: with the paper's choice the faulty rotation's median error is 1030 mm, with "
            "faultlab's alternative 1530 mm (paired median difference -500 mm [-500, -500], ratio 0.67") in md
    assert "Evidence from the ablation" not in fidelity_markdown(fid)
    titles = [getattr(p, "_faultlab_page_title") for p in fidelity_pages(fid, abl)]
    assert titles == [FIDELITY_TITLE, FIDELITY_TITLE + ": what it says"]
