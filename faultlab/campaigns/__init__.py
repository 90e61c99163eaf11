"""faultlab.campaigns: every campaign faultlab runs, each on the runner's public API.

One module per campaign: :mod:`~faultlab.campaigns.reproduce` (the paper's protocol, its profiles
and the ablation of the paper profile), :mod:`~faultlab.campaigns.calibrate` (the A/A campaign of
the detection rules), :mod:`~faultlab.campaigns.mutation` (mutants of the reference FastSLAM with
early stopping), :mod:`~faultlab.campaigns.study` (the case pools of the test-design strategies
study) and :mod:`~faultlab.campaigns.slams` (one protocol on every built-in SLAM).  A campaign
only runs and stores; :mod:`faultlab.analysis` reads the stores and :mod:`faultlab.report`
renders them.
"""

from faultlab.lazy import lazy_exports

_EXPORTS = {
    "reproduce": ["ReproduceRun", "reproduce", "run_ablation", "quick_overrides", "profile_overrides"],
    "calibrate": ["CalibrationRun", "calibrate"],
    "mutation": ["MutationExperiment", "MutationRun", "load_mutation_experiment", "run_mutation"],
    "study": ["StudyExperiment", "load_study_experiment", "run_study"],
    "slams": ["SlamsRun", "slam_experiments", "slam_stores", "run_slams"],
}

__getattr__, __dir__, __all__ = lazy_exports(__name__, _EXPORTS)
