"""Tables of the `faultlab check` runs in this directory (run.sh): verdicts, map errors and cost per SLAM.

    python reports/wild/check/summarise.py            (from the repository root, after run.sh)

Reads ``<slam>/cases/*.json`` (one judged case each, as ``faultlab check`` stores them) and ``<slam>/time.txt``
and writes ``summary.csv`` (per SLAM and oracle: cases passed, failed, not judged; the failing cases; CPU and
wall seconds of the check) and ``errors.csv`` (per case and SLAM: map error in mm, the floor oracle's bound,
the largest metamorphic discrepancy in m, and which oracles failed).
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pandas as pd

HERE = Path(__file__).resolve().parent
SLAMS = {"ekf": "faultlab EKF (reference)", "rtb": "roboticstoolbox EKF", "mrpt": "MRPT CRangeBearingKFSLAM2D",
         "g2o": "g2o smoother"}
ORACLES = ("execution", "metamorphic", "floor", "differential")


def _cost(path: Path) -> dict:
    """The last complete ``user U s, system S s, wall W s`` line of /usr/bin/time (a resumed check sums its runs)."""
    if not path.exists():
        return {}
    runs = [tuple(float(x) for x in m) for m in
            re.findall(r"user ([\d.]+) s, system ([\d.]+) s, wall ([\d.]+) s", path.read_text())]
    if not runs:
        return {}
    return {"cpu_s": round(sum(u + s for u, s, _ in runs), 1), "wall_s": round(sum(w for *_, w in runs), 1),
            "sessions": len(runs)}


def main() -> None:
    summary, errors = [], []
    for key, label in SLAMS.items():
        files = sorted((HERE / key / "cases").glob("*.json"))
        records = [json.loads(f.read_text()) for f in files]
        for oracle in ORACLES:
            res = [(r["case_id"], next(x for x in r["results"] if x["oracle"] == oracle)) for r in records]
            summary.append({"slam": label, "oracle": oracle, "cases": len(res),
                            "pass": sum(x["status"] == "pass" for _, x in res),
                            "fail": sum(x["status"] == "fail" for _, x in res),
                            "not_judged": sum(x["status"] not in ("pass", "fail") for _, x in res),
                            "failing_cases": " ".join(c.rsplit("-", 1)[1] for c, x in res if x["status"] == "fail"),
                            **_cost(HERE / key / "time.txt")})
        for r in records:
            by = {x["oracle"]: x for x in r["results"]}
            floor = by["floor"]["details"]
            meta = by["metamorphic"]
            errors.append({"case": r["case_id"].rsplit("-", 1)[1], "slam": label, "steps": r["n_steps"],
                           "landmarks": r["n_landmarks"],
                           "map_error_mm": float(floor["error_mm"][0]) if floor.get("error_mm") else None,
                           "floor_bound_mm": float(floor["bound_mm"][0]) if floor.get("bound_mm") else None,
                           "metamorphic_discrepancy_m": meta["statistic"] if meta["status"] in ("pass", "fail")
                           else None,
                           "failed": " ".join(o for o in ORACLES if by[o]["status"] == "fail"),
                           "minimal_steps": (r["reduction"] or {}).get("metamorphic", {}).get("minimal", {}).get("steps")})
    pd.DataFrame(summary).to_csv(HERE / "summary.csv", index=False)
    pd.DataFrame(errors).to_csv(HERE / "errors.csv", index=False, float_format="%.4g")
    print(pd.DataFrame(summary).to_string())


if __name__ == "__main__":
    main()
