"""``python -m faultlab export CASE... --format rosbag2|tum|jsonl --out D``: test cases in the field's formats."""

from __future__ import annotations

import argparse
from pathlib import Path

from faultlab.cli.options import add_examples, print_paths
from faultlab.errors import ConfigError

__all__ = ["register", "FORMATS", "targets"]

#: Export formats and what each writes per case (``<name>`` is the case file's name without suffix).
FORMATS = {
    "rosbag2": "<name>/: a ROS 2 bag (odometry, range-bearing observations, true poses, landmark map)",
    "tum": "<name>.groundtruth.tum and <name>.odometry.tum: the true and the odometry trajectory",
    "jsonl": "<name>.jsonl: the process protocol's requests of one execution (program < file)",
}


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "export", help="export saved test cases as a ROS 2 bag, TUM trajectories or a process-protocol transcript",
        description="Export saved test cases (CASE.npz + CASE.json, as written by generate or a campaign) into "
                    "OUT: " + "; ".join(f"{k}: {v}" for k, v in FORMATS.items()) + ". Topics and message "
                    "types: faultlab.scenario.rosbag; the transcript: docs/reference/process-protocol.md. "
                    "Nothing is overwritten: if any output exists, nothing is written.")
    p.add_argument("cases", nargs="+", metavar="CASE", help="a saved case (with or without .npz/.json)")
    p.add_argument("--format", required=True, choices=tuple(FORMATS), dest="fmt", help="output format")
    p.add_argument("--out", required=True, type=Path, help="output directory (created)")
    p.add_argument("--seed", type=int, default=None,
                   help="jsonl only: the seed sent in the reset, an integer in [0, 2**53) (default: 0)")
    add_examples(p, ["faultlab export cases/systematic/case1 --format rosbag2 --out bags",
                     "faultlab export cases/systematic/case1.npz cases/systematic/case2.npz --format tum --out tum",
                     "faultlab export cases/systematic/case1 --format jsonl --seed 7 --out transcripts"])
    p.set_defaults(func=_handler)


def targets(case: Path, fmt: str, out: Path) -> list[Path]:
    """The paths ``fmt`` writes for ``case`` into ``out``."""
    name = Path(case).name
    for suffix in (".npz", ".json"):
        name = name.removesuffix(suffix)
    if fmt == "rosbag2":
        return [out / name]
    if fmt == "tum":
        return [out / f"{name}.groundtruth.tum", out / f"{name}.odometry.tum"]
    return [out / f"{name}.jsonl"]


def _handler(args: argparse.Namespace) -> int:
    from faultlab.scenario.model import load_scenario
    from faultlab.scenario.rosbag import write_bag
    from faultlab.scenario.tum import odometry_poses, step_times, write_tum
    from faultlab.slam.process import transcript

    if args.seed is not None and args.fmt != "jsonl":
        raise ConfigError(f"export: --seed applies to --format jsonl only, not {args.fmt}")
    seed = 0 if args.seed is None else args.seed
    if not 0 <= seed < 2 ** 53:
        raise ConfigError(f"export: --seed must be in [0, 2**53), got {seed}")
    scenarios = [load_scenario(case) for case in args.cases]  # every case readable before anything is written
    plan = [targets(case, args.fmt, args.out) for case in args.cases]
    flat = [p for paths in plan for p in paths]
    clash = next((p for p in flat if p.exists()), None) or next((p for p in flat if flat.count(p) > 1), None)
    if clash is not None:
        raise ConfigError(f"export: {clash} already exists (or two cases share its name); nothing was written")
    written = []
    for scenario, paths in zip(scenarios, plan):
        if args.fmt == "rosbag2":
            written.append(write_bag(scenario, paths[0]))
        elif args.fmt == "tum":
            times = step_times(scenario.n_steps)
            written.append(write_tum(paths[0], times, scenario.true_poses))
            written.append(write_tum(paths[1], times, odometry_poses(scenario.start_pose, scenario.controls)))
        else:
            paths[0].parent.mkdir(parents=True, exist_ok=True)
            paths[0].write_text("".join(line + "\n" for line in transcript(scenario, seed=seed)))
            written.append(paths[0])
    return print_paths(written)
