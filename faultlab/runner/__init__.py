"""faultlab.runner: declarative experiments, a deterministic joblib runner and a crash-safe results store.

Modules: :mod:`~faultlab.runner.experiment` (experiment files), :mod:`~faultlab.runner.jobs`
(jobs and batches), :mod:`~faultlab.runner.execution` (executing a job or a batch in a worker),
:mod:`~faultlab.runner.backends` (loky workers streaming results back, under the parent's deadlines),
:mod:`~faultlab.runner.orchestration` (:func:`run_experiment`: cases, jobs, store) and
:mod:`~faultlab.runner.store` (the results store).

>>> from faultlab.runner import load_experiment, run_experiment, load_results   # doctest: +SKIP
>>> summary = run_experiment(load_experiment("experiments/paper.toml"), "results/paper")  # doctest: +SKIP
>>> df = load_results("results/paper")                                         # doctest: +SKIP
"""

from faultlab.runner.backends import check_backend, stream_batches, stream_results
from faultlab.runner.execution import JobResult, TimeLimitExceeded, execute_batch, execute_job, time_limit
from faultlab.runner.orchestration import CaseInfo, RunSummary, prepare_cases, result_row, run_experiment, store_session
from faultlab.runner.experiment import (
    Experiment,
    SlamSpec,
    SuiteSpec,
    load_experiment,
    parse_experiment,
)
from faultlab.runner.jobs import JobBatch, JobKey, JobSpec, batch_jobs, expand_jobs
from faultlab.runner.store import (
    RESULT_COLUMNS,
    ResultStore,
    case_path,
    load_metadata,
    load_results,
    results_path,
)

__all__ = [
    "TimeLimitExceeded", "time_limit",
    "check_backend",
    "Experiment",
    "SuiteSpec",
    "SlamSpec",
    "load_experiment",
    "parse_experiment",
    "JobKey",
    "JobSpec",
    "JobBatch",
    "JobResult",
    "CaseInfo",
    "RunSummary",
    "expand_jobs",
    "batch_jobs",
    "execute_job",
    "execute_batch",
    "prepare_cases",
    "result_row",
    "stream_results",
    "stream_batches",
    "run_experiment",
    "store_session",
    "RESULT_COLUMNS",
    "ResultStore",
    "load_results",
    "load_metadata",
    "case_path",
    "results_path",
]
