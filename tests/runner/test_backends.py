"""Backends: a dying worker is a crash row; dask gives the loky table."""

import pandas as pd
import pytest

from faultlab.runner import load_metadata, load_results, run_experiment
from tests.runner.suts import SUTS, fastslam_batches, one_case, without_runtime, write_experiment


def test_worker_death_is_recorded_as_crash(tmp_path):
    exp = write_experiment(tmp_path / "e.toml", **one_case(variants=["baseline", f"{SUTS}:EXIT"]))
    summary = run_experiment(exp, tmp_path / "out", jobs=2, progress=False)
    df = load_results(tmp_path / "out").set_index("variant")
    assert df.loc[f"{SUTS}:EXIT", "status"] == "crash"
    assert df.loc[f"{SUTS}:EXIT", "error"].startswith("WorkerDied:")
    assert df.loc["baseline", "status"] == "ok"
    assert summary.n_jobs == 2 and summary.complete


@pytest.mark.slow
def test_dask_local_cluster_gives_the_loky_table(tmp_path):
    distributed = pytest.importorskip("distributed")
    exp = write_experiment(tmp_path / "e.toml", runs=1, variants=["baseline", f"{SUTS}:BIAS"])
    run_experiment(exp, tmp_path / "loky", jobs=2, progress=False)
    with distributed.LocalCluster(n_workers=2, processes=True, threads_per_worker=1, host="127.0.0.1",
                                  dashboard_address=None) as cluster, distributed.Client(cluster):
        summary = run_experiment(exp, tmp_path / "dask", backend="dask", progress=False)
    assert summary.complete and summary.counts["ok"] == summary.n_jobs == 12
    pd.testing.assert_frame_equal(without_runtime(load_results(tmp_path / "dask")),
                                  without_runtime(load_results(tmp_path / "loky")), check_exact=True)
    assert load_metadata(tmp_path / "dask")["sessions"][0]["backend"] == "dask"


def test_a_batch_that_kills_its_worker_is_a_crash_of_each_repetition(tmp_path):
    exp = fastslam_batches(tmp_path, variants=["baseline", f"{SUTS}:FS_EXIT"], suites={"random": 1},
                            repetitions=2)
    summary = run_experiment(exp, tmp_path / "out", jobs=2, progress=False)
    df = load_results(tmp_path / "out")
    died = df[df.variant == f"{SUTS}:FS_EXIT"]
    assert list(died.status) == ["crash", "crash"] and died.error.str.startswith("WorkerDied:").all()
    assert (df[df.variant == "baseline"].status == "ok").all() and summary.complete
