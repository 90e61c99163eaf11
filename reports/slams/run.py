"""Run the cross-SLAM campaign (experiments/slams.toml once per SLAM) and render its report.

    nice -n 10 python reports/slams/run.py run [--jobs 2]    # resumable: finished jobs are skipped
    python reports/slams/run.py report                      # reports/slams/README.md, tables, figure

Every SLAM runs the same protocol (cases, seeds, faults, K, rule); only the ``[slam]`` table
changes.  The FastSLAMs use 30 particles; every SLAM keeps the paper's noise settings (Sec. VII-A).
A SLAM that needs an optional dependency that is not installed (gtsam) is left out and said so.
Stores: reports/slams/store/<label>/results.sqlite (the generated cases are not committed: the same
seed regenerates them).
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
from pathlib import Path

from faultlab.runner import run_experiment
from faultlab.runner.experiment import load_experiment, parse_experiment

HERE = Path(__file__).resolve().parent

#: label -> the [slam] table of that SLAM under test (the protocol's other keys are the file's).
SUTS: dict[str, dict] = {
    "fastslam1": {"name": "fastslam", "particles": 30},
    "fastslam2": {"name": "fastslam2", "particles": 30},
    "ekf": {"name": "ekf"},
    "gtsam": {"name": "gtsam"},
    "fastslam1-unknown": {"name": "fastslam", "particles": 30, "association": "unknown"},
    "fastslam2-unknown": {"name": "fastslam2", "particles": 30, "association": "unknown"},
}
#: SLAM name -> the module it needs.
REQUIRES = {"gtsam": "gtsam"}


def experiments() -> dict:
    """label -> the experiment of that SLAM (None when its optional dependency is missing)."""
    base = load_experiment("slams")
    out = {}
    for label, table in SUTS.items():
        need = REQUIRES.get(table["name"])
        if need is not None and importlib.util.find_spec(need) is None:
            out[label] = None
            continue
        data = base.to_dict()
        data["slam"] = dict(table)
        data.pop("metric")  # chosen by the SLAM's association: rms, or emd without landmark ids
        out[label] = parse_experiment(data, source=f"slams [{label}]", text=base.text)
    return out


def run(jobs: int) -> None:
    for label, exp in experiments().items():
        if exp is None:
            print(f"{label}: skipped ({SUTS[label]['name']} is not installed)", flush=True)
            continue
        print(f"== {label}", flush=True)
        print(run_experiment(exp, HERE / "store" / label, jobs=jobs), flush=True)


def report() -> None:
    from faultlab.analysis.slams import compare_slams
    from faultlab.report.slams import write_slam_report

    stores = {label: HERE / "store" / label for label, exp in experiments().items() if exp is not None}
    missing = [label for label, exp in experiments().items() if exp is None]
    comparison = compare_slams(stores, not_installed=missing)
    write_slam_report(comparison, HERE)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("what", choices=("run", "report"))
    p.add_argument("--jobs", type=int, default=2)
    args = p.parse_args(argv)
    run(args.jobs) if args.what == "run" else report()
    return 0


if __name__ == "__main__":
    sys.exit(main())
