"""Names shared by every layer: variants, suites, faults, metrics, backends and outcome classes.

Each name is defined here once; the computation, campaign, analysis, report and command-line
layers import it from here.  Orders are those of the paper's Table II (Sec. VII).
"""

from __future__ import annotations

from enum import StrEnum
from types import MappingProxyType

__all__ = [
    "BASELINE",
    "REPLICA",
    "UNMODIFIED",
    "PAPER_PROTOCOL",
    "MUTANT_PREFIX",
    "SUITE_ORDER",
    "PAPER_FAULTS",
    "METRICS",
    "MAP_METRICS",
    "ASSOCIATIONS",
    "KNOWN_ASSOCIATION",
    "UNKNOWN_ASSOCIATION",
    "BACKENDS",
    "DEFAULT_ALPHA",
    "DEFAULT_POWER",
    "POWER_TEXT",
    "MDD_COLUMN",
    "DIRECTIONS",
    "DEFAULT_DIRECTION",
    "PAPER_DIRECTION",
    "EFFECTS_STAGES",
    "EFFECTS_FILE",
    "JobStatus",
    "Change",
    "Outcome",
    "ordered",
]

#: The variant name of the unmodified SLAM (no fault).
BASELINE = "baseline"

#: The unmodified SLAM again, with SLAM seeds independent of the baseline's: an A/A control whose
#: "detections" against the baseline are false alarms (``faultlab calibrate``).
REPLICA = "baseline_replica"

#: Variant names that mean "no fault" (reserved: no fault may use them).
UNMODIFIED: tuple[str, ...] = (BASELINE, REPLICA)

#: Prefix of the variant name of a mutant of the reference's units: ``"mutant:<id>"``.
MUTANT_PREFIX = "mutant:"

#: Suite order of reports: the paper's Table II, then the combinatorial strategies (the strategies
#: themselves are registered in :mod:`faultlab.space.registry`; one not named here is listed last).
SUITE_ORDER: tuple[str, ...] = ("systematic", "fixed", "random", "base-choice", "pairwise", "3-wise", "4-wise",
                                "effect-guided")

#: The paper's protocol (Sec. VII-A), by experiment-file key: steps per case, particles of its
#: FastSLAM and evaluation runs.  The defaults of a scenario and of FastSLAM are the paper's; a
#: campaign with fewer is *reduced* (:mod:`faultlab.analysis.fidelity`).
PAPER_PROTOCOL = MappingProxyType({"n_steps": 1000, "particles": 200, "runs": 3})

#: The paper's three injected faults (Sec. VII-A), in Table II order.
PAPER_FAULTS: tuple[str, ...] = ("naive_resampling", "missing_angle_wrap", "motion_sign_error")

#: The metrics a job records (stored as ``<name>_mm``): the map errors RMS and EMD (Sec. VII-B) and the
#: absolute trajectory error ``"ate"`` (:func:`faultlab.metrics.trajectory_error_mm`); an experiment
#: records all of them unless its ``metrics`` option says otherwise.
METRICS: tuple[str, ...] = ("rms", "emd", "ate")
#: The map-error metrics among :data:`METRICS`: every metric there was before the trajectory error, what a
#: store without a metrics list recorded.
MAP_METRICS: tuple[str, ...] = ("rms", "emd")

#: Data association of a SLAM under test: ``"known"``, observations carry the landmark ids; ``"unknown"``,
#: the driver hides them and the SLAM associates observations itself.  A map without ids has no
#: correspondences with the ground truth, so it is scored by the earth mover's distance (Sec. VII-B).
KNOWN_ASSOCIATION = "known"
UNKNOWN_ASSOCIATION = "unknown"
ASSOCIATIONS: tuple[str, ...] = (KNOWN_ASSOCIATION, UNKNOWN_ASSOCIATION)

#: The stages of an effects study (``faultlab effects``), in running order: Morris screening, then Sobol
#: indices over the parameters it keeps; each is a results store ``OUT/<stage>`` and the suite label of its cases.
EFFECTS_STAGES: tuple[str, ...] = ("morris", "sobol")
#: File in an effects study's output directory recording its settings and the kept parameters.
EFFECTS_FILE = "effects.json"

#: Execution backends of the runner (joblib backends; dask and ray are optional extras).
BACKENDS: tuple[str, ...] = ("loky", "threading", "dask", "ray")


#: Default level of every test and 1 - confidence level of every interval (the paper's 5 %).
DEFAULT_ALPHA = 0.05

#: Default power of every sample-size and detectable-difference figure (the conventional choice).
DEFAULT_POWER = 0.8
#: :data:`DEFAULT_POWER` as tables and messages write it (``"80 %"``).
POWER_TEXT = f"{100 * DEFAULT_POWER:g} %"
#: Column of the smallest difference detectable with :data:`DEFAULT_POWER` (``"mdd80"``).
MDD_COLUMN = f"mdd{100 * DEFAULT_POWER:g}"

#: Which change of the map error a per-case test looks for: ``"either"`` (two-sided: the variant
#: behaves differently, worse or better) or ``"worse"`` (one-sided: the paper's notion of detecting
#: a fault, Sec. VII-A, "the faulty implementation's map error exceeds the baseline's").
DIRECTIONS: tuple[str, ...] = ("either", "worse")
#: Default direction of the per-case tests (mutation kill, kill matrix, the statistical rule).
DEFAULT_DIRECTION = "either"
#: The paper's one-sided direction.
PAPER_DIRECTION = "worse"


class Change(StrEnum):
    """Observed direction of a variant's effect on the map error (sign of the mean paired difference)."""

    WORSE = "worse"
    BETTER = "better"
    NONE = "none"


class JobStatus(StrEnum):
    """Outcome of one job's SLAM execution."""

    OK = "ok"
    CRASH = "crash"
    TIMEOUT = "timeout"


class Outcome(StrEnum):
    """Outcome class of one faulty job paired with its baseline (see :mod:`faultlab.stats.detection`)."""

    DETECTED = "detected"
    NOT_DETECTED = "not_detected"
    CRASH = "crash"
    TIMEOUT = "timeout"
    BASELINE_FAILED = "baseline_failed"


def ordered(values, preferred) -> list:
    """Distinct ``values``: those in ``preferred`` first (in that order), then the rest sorted."""
    present = list(dict.fromkeys(values))
    return [v for v in preferred if v in present] + sorted(v for v in present if v not in preferred)
