"""The replay page renders the replay it is given: executions, stops, every changed verdict with its reason."""

import pandas as pd

from faultlab.analysis.replay import REPLAY_PAIRS, REPLAY_SUMMARY, REPLAY_VERDICTS, AdaptiveReplay
from faultlab.report.replay import REPLAY_FILE, replay_markdown, write_replay

WHY = "stopped after 5 of 10 repetitions (futile); planted reason"


def _replay(changed: bool) -> AdaptiveReplay:
    pairs = pd.DataFrame({"run": [1] * 4, "suite": ["fixed"] * 4, "case": [1, 1, 2, 2],
                          "variant": ["baseline", "f", "baseline", "f"], "reps_fixed": [10] * 4,
                          "reps_adaptive": [10, 10, 5, 5], "stages_run": [2, 2, 1, 1],
                          "stop": ["follows_variants", "completed", "follows_variants", "futile"]})
    summary = pd.DataFrame({"variant": ["baseline", "f", "(all)"], "n_pairs": [2, 2, 4], "n_stopped": [1, 1, 2],
                            "executions_fixed": [20, 20, 40], "executions_adaptive": [15, 15, 30],
                            "saved_pct": [25.0, 25.0, 25.0], "n_changed": [0, int(changed), int(changed)]})
    verdicts = pd.DataFrame({"suite": ["fixed"] * 2, "run": [1, 1], "case": [1, 2], "fault": ["f", "f"],
                             "family": ["f", "f"], "stop": ["completed", "futile"], "reps_fixed": [10, 10],
                             "reps_adaptive": [10, 5], "verdict_fixed": ["detected", "detected" if changed else
                                                                         "not_detected"],
                             "verdict_adaptive": ["detected", "not_detected"], "reason_fixed": ["", ""],
                             "reason_adaptive": ["", ""], "p_fixed": [0.001, 0.002 if changed else 0.6],
                             "p_adaptive": [0.001, 0.5], "p_holm_fixed": [0.002, 0.002 if changed else 0.6],
                             "p_holm_adaptive": [0.002, 0.5], "changed": [False, changed],
                             "why": ["", WHY if changed else ""]})
    meta = {"store": "results/toy", "design": {"stages": [5, 10], "level": 0.05, "alternative": "greater",
                                               "futility": 0.5},
            "K": 10, "metric": "rms", "rule": "planted rule", "executions_fixed": 40, "executions_adaptive": 30,
            "saved_pct": 25.0, "stops": [], "notes": ["a planted note"] if changed else []}
    return AdaptiveReplay(summary=REPLAY_SUMMARY.conform(summary), pairs=REPLAY_PAIRS.conform(pairs),
                          verdicts=REPLAY_VERDICTS.conform(verdicts), meta=meta)


def test_the_page_lists_every_changed_verdict_with_its_reason():
    page = replay_markdown(_replay(True))
    assert "**Executions: 30 of 40 (25.0 % saved).** 1 of 2 (case, variant) pairs stopped early" in page
    assert "1 of 2 cases ran their baseline for all 10 repetitions" in page
    assert "| futile | 5 | 1 |" in page
    assert "**1 of 2 per-case verdicts change:**" in page
    assert f"| fixed | 1 | 2 | f | detected | not_detected | {WHY} |" in page
    assert "- a planted note." in page and "planted rule" in page and "`results/toy`" in page


def test_an_unchanged_replay_says_so(tmp_path):
    replay = _replay(False)
    page = replay_markdown(replay)
    assert "**All 2 per-case verdicts are unchanged.**" in page and "change:**" not in page
    paths = write_replay(replay, tmp_path)
    assert (tmp_path / REPLAY_FILE).read_text() == page and all(p.exists() for p in paths)
