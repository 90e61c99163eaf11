"""What a results store's metadata says about its campaign: detection rule, parameter space, size.

The runner stores the experiment with its results (:func:`faultlab.runner.load_metadata`); the
analysis judges the results by that experiment's settings, never by defaults, so every
consumer of the same store sees the same figures.
"""

from __future__ import annotations

from typing import Mapping

from faultlab.errors import ConfigError, FaultlabError, ResultsError
from faultlab.runner.staging import STOPS_KEY
from faultlab.runner.store import SKIPPED_VARIANTS_KEY, recorded_metrics
from faultlab.space import ParameterSpace, space_from_mapping, table1_space
from faultlab.stats.detection import DetectionRule
from faultlab.vocabulary import BASELINE, DEFAULT_DIRECTION, MAP_METRICS, METRICS, PAPER_DIRECTION

__all__ = ["read_rule", "read_space", "count_expected_jobs", "adaptive_summary", "judged_metric", "metrics_note"]


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
        (thresholds missing from a stored rule take the paper's values too).  A statistical rule
        stored without a ``direction`` was run before the two-sided default: its direction is the
        paper's one-sided ``"worse"``, so a campaign is analysed with the test it ran with.

    Raises
    ------
    ResultsError
        The stored rule is malformed.
    """
    det = metadata.get("detection") or {}
    try:
        # a statistical rule stored before the direction existed was judged one-sided: analyse it so
        before = PAPER_DIRECTION if det.get("rule") == "statistical" else DEFAULT_DIRECTION
        rule = DetectionRule(**{k: det[k] for k in ("abs_mm", "rel", "rule", "alpha", "family") if k in det},
                             direction=det.get("direction", before))
    except (TypeError, ValueError, FaultlabError) as exc:
        raise ResultsError(f"results metadata has an invalid detection rule {det!r} ({exc})") from exc
    return rule, bool(det)


def judged_metric(metadata: Mapping, metric: str | None = None) -> str:
    """The metric a campaign's results are judged by: ``metric``, by default the stored primary one.

    Parameters
    ----------
    metadata : mapping
        :func:`faultlab.runner.load_metadata` (its ``metric`` and ``metrics`` entries).
    metric : {"rms", "emd", "ate"}, optional
        Judge by this metric instead of the experiment's.

    Raises
    ------
    ConfigError
        ``metric`` is not a metric name.
    ResultsError
        The store did not record that metric (the experiment's ``metrics`` left it out).
    """
    if metric is None:
        metric = metadata.get("metric") or (metadata.get("experiment") or {}).get("metric") or "rms"
        metric = metric if metric in METRICS else "rms"
    elif metric not in METRICS:
        raise ConfigError(f"analysis: metric must be one of {', '.join(map(repr, METRICS))}, got {metric!r}")
    recorded = recorded_metrics(metadata)
    if metric not in recorded:
        raise ResultsError(f"the results of {metadata.get('experiment_source', 'this campaign')} cannot be judged "
                           f"by {metric!r}: the experiment recorded only {', '.join(map(repr, recorded))} "
                           f"(its metrics option); rerun it with {metric!r} in metrics")
    return metric


def metrics_note(metadata: Mapping) -> str | None:
    """One sentence naming the recorded map errors when the experiment left one out (None when it recorded both).

    Only the map errors (:data:`~faultlab.vocabulary.MAP_METRICS`) are named: the reports' tables
    are of map errors, and the trajectory error is a column of the results of its own.
    """
    recorded = tuple(m for m in recorded_metrics(metadata) if m in MAP_METRICS)
    if recorded == MAP_METRICS:
        return None
    left = [m.upper() for m in MAP_METRICS if m not in recorded]
    return (f"Metrics recorded: {', '.join(m.upper() for m in recorded)} only; {', '.join(left)} "
            f"{'was' if len(left) == 1 else 'were'} not computed (the experiment's metrics option) and "
            f"{'is' if len(left) == 1 else 'are'} empty in every row.")


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


def count_expected_jobs(metadata: Mapping, *, adaptive: bool = True) -> int | None:
    """Jobs of the complete campaign (runs x cases x variants x repetitions).

    Variants the runner skipped because their fault does not apply to the SLAM
    (``metadata["skipped_variants"]``) have no jobs.  With ``[adaptive]`` repetitions
    (:mod:`faultlab.runner.staging`) and ``adaptive`` true, a stopped (case, variant) counts the
    repetitions it used, and a case's baseline the most any of its variants used; ``adaptive``
    false gives the fixed-K count.  None when the stored experiment does not say, e.g. a suite
    with ``"auto"`` cases.
    """
    exp = metadata.get("experiment") or {}
    try:
        suites = exp.get("suites") or {}
        pairs = suites.items() if isinstance(suites, dict) else suites
        n_cases = sum(int(n) for _, n in pairs)
        skipped = {s["fault"] for s in metadata.get(SKIPPED_VARIANTS_KEY) or ()}
        n_variants = sum(1 for v in exp["variants"] if v not in skipped)
        k = int(exp["repetitions"])
        full = int(exp["runs"]) * n_cases * n_variants * k
        if not adaptive:
            return full
        by_case: dict[tuple, list[int]] = {}
        for stop in metadata.get(STOPS_KEY) or ():
            by_case.setdefault((stop["run"], stop["suite"], stop["case"]), []).append(int(stop["repetitions"]))
            full -= k - int(stop["repetitions"])
        n_faulty = n_variants - (BASELINE in exp["variants"])
        for used in by_case.values():  # a case whose variants all stopped ran its baseline as far as they did
            if len(used) == n_faulty:
                full -= k - max(used)
        return full
    except (KeyError, TypeError, ValueError, AttributeError):
        return None


def adaptive_summary(metadata: Mapping) -> str | None:
    """One sentence on a campaign's adaptive repetitions (None for a fixed-K campaign)."""
    design = (metadata.get("experiment") or {}).get("adaptive")
    if not design:
        return None
    stops = metadata.get(STOPS_KEY) or []
    run, full = count_expected_jobs(metadata), count_expected_jobs(metadata, adaptive=False)
    reasons: dict[str, int] = {}
    for stop in stops:
        reasons[stop["reason"]] = reasons.get(stop["reason"], 0) + 1
    why = ", ".join(f"{n} {r.replace('_', ' ')}" for r, n in sorted(reasons.items())) or "none"
    saved = ("" if not full or run is None else
             f"; {run} of the fixed design's {full} executions ({100 * (1 - run / full):.1f} % saved)")
    return (f"adaptive repetitions in stages {design['stages']} (per-case level {design['level']:g}, "
            f"{design['alternative']}, futility bound {design['futility']:g}): {len(stops)} (case, variant) pair(s) "
            f"stopped early ({why}); the others used all {design['stages'][-1]} repetitions{saved}.")
