"""What a results store's metadata says about its campaign: detection rule, parameter space, size.

The runner stores the experiment with its results (:func:`faultlab.runner.load_metadata`); the
analysis judges the results by that experiment's settings, never by defaults, so every
consumer of the same store sees the same figures.
"""

from __future__ import annotations

from typing import Mapping

from faultlab.errors import FaultlabError, ResultsError
from faultlab.runner.store import SKIPPED_VARIANTS_KEY
from faultlab.space import ParameterSpace, space_from_mapping, table1_space
from faultlab.stats.detection import DetectionRule

__all__ = ["read_rule", "read_space", "count_expected_jobs"]


def read_rule(metadata: Mapping) -> tuple[DetectionRule, bool]:
    """The detection rule stored with the campaign (Sec. VII-A thresholds, ``[detection]``).

    Parameters
    ----------
    metadata : mapping
        :func:`faultlab.runner.load_metadata` (its ``detection`` entry).

    Returns
    -------
    (rule, stored) : (DetectionRule, bool)
        ``stored`` is False when the metadata holds no rule; then the rule is the paper's
        (thresholds missing from a stored rule take the paper's values too).

    Raises
    ------
    ResultsError
        The stored rule is malformed.
    """
    det = metadata.get("detection") or {}
    try:
        rule = DetectionRule(**{k: det[k] for k in ("abs_mm", "rel", "rule", "alpha", "family")
                                 if k in det})
    except (TypeError, ValueError, FaultlabError) as exc:
        raise ResultsError(f"results metadata has an invalid detection rule {det!r} ({exc})") from exc
    return rule, bool(det)


def read_space(metadata: Mapping) -> ParameterSpace:
    """The campaign's parameter space: Table I with the experiment's ``[space]`` overrides.

    Raises
    ------
    ConfigError
        The stored overrides are malformed.
    """
    overrides = (metadata.get("experiment") or {}).get("space") or {}
    if not overrides:
        return table1_space()
    return space_from_mapping(overrides, source=f"{metadata.get('experiment_source', 'experiment')} [space]")


def count_expected_jobs(metadata: Mapping) -> int | None:
    """Jobs of the complete campaign (runs x cases x variants x repetitions).

    Variants the runner skipped because their fault does not apply to the SLAM
    (``metadata["skipped_variants"]``) have no jobs.  None when the stored experiment does not
    say, e.g. a suite with ``"auto"`` cases.
    """
    exp = metadata.get("experiment") or {}
    try:
        suites = exp.get("suites") or {}
        pairs = suites.items() if isinstance(suites, dict) else suites
        n_cases = sum(int(n) for _, n in pairs)
        skipped = {s["fault"] for s in metadata.get(SKIPPED_VARIANTS_KEY) or ()}
        n_variants = sum(1 for v in exp["variants"] if v not in skipped)
        return int(exp["runs"]) * n_cases * n_variants * int(exp["repetitions"])
    except (KeyError, TypeError, ValueError, AttributeError):
        return None
