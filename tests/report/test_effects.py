"""Rendering of an effects study's tables."""

from __future__ import annotations

import pandas as pd

from faultlab.report.effects import _morris_md


def test_a_parameter_whose_elementary_effects_are_all_zero_shows_no_interval():
    t = pd.DataFrame({"rank": [1, 2], "parameter": ["map_size", "inactivity"], "mu_star": [0.2, 0.0],
                      "mu_star_low": [0.02, 0.0], "mu_star_high": [0.35, 0.0], "sigma": [0.26, 0.0],
                      "mu": [0.2, 0.0]})
    md = _morris_md(t)
    assert "| 1 | map_size | 0.2 [0.02, 0.35] |" in md
    assert "| 2 | inactivity | 0 (every elementary effect 0) |" in md and "[0, 0]" not in md
