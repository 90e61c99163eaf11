"""Reproducer written by faultlab check: metamorphic fails pairwise-1-002 (minimal: 24 steps, 1 landmarks).

Replays the case through the SLAM's adapter and asserts the oracle passes: this test fails while the
bug is there.  Set FAULTLAB_SLAM to another SLAM (built-in name or package.module:factory), or
FAULTLAB_COMMAND to another process SLAM command, to replay it on another build, e.g. the fixed one.
"""

import json
import os
import shlex
from pathlib import Path

from faultlab.campaigns.checkspec import CheckSpec, judge_scenario
from faultlab.scenario.model import load_scenario

HERE = Path(__file__).resolve().parent
SPEC = json.loads('{"slam": "faultlab_g2o_smoother:G2oSmoother", "command": [], "slam_options": {}, "reference": "ekf", "suite": "pairwise", "n_cases": null, "n_steps": 100, "seed": 2026, "repetitions": 8, "alpha": 0.03, "oracles": ["metamorphic"], "options": {"relations": ["rigid_motion", "id_relabel", "bearing_turn"], "metamorphic_atol": 1e-06, "floor_ratio": 1.0, "floor_margin_mm": 50.0, "differential_ratio": 2.0, "differential_margin_mm": 100.0}, "paths": [], "space": {"map_size": {"classes": {"small": [4, 8], "medium": [8, 12], "large": [12, 16]}}, "landmark_density": {"classes": {"low": [1, 1.5], "medium": [1.5, 2], "high": [2, 3]}}}}')


def test_pairwise_1_002_metamorphic():
    spec = dict(SPEC)
    if os.environ.get("FAULTLAB_SLAM"):
        spec["slam"], spec["command"] = os.environ["FAULTLAB_SLAM"], ()
    if os.environ.get("FAULTLAB_COMMAND"):
        spec["slam"], spec["command"] = "", shlex.split(os.environ["FAULTLAB_COMMAND"])
    spec["paths"] = tuple(spec["paths"]) + (str(HERE),)
    check = CheckSpec(**{**spec, "command": tuple(spec["command"]), "oracles": tuple(spec["oracles"])})
    judgement = judge_scenario(check, 'pairwise-1-002', load_scenario(HERE / "case.npz"))
    (result,) = [r for r in judgement.results if r.oracle == 'metamorphic']
    assert result.status != "fail", result.message
