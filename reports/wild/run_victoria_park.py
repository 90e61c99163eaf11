"""Victoria Park (the gtsam wheel's copy) through every SLAM that handles known association, judged without truth.

Run from the repository root with the [wild] extra, examples/rtb-ekf-slam, examples/g2o-smoother installed and
examples/mrpt-kfslam built into build/mrpt-kfslam (reports/wild/README.md):

    nice python reports/wild/run_victoria_park.py --mrpt build/mrpt-kfslam/mrpt_kfslam --out reports/wild

Writes victoria_park.csv (one row per SLAM: run time, landmarks mapped, distance from the g2o smoother's map),
victoria_park_relations.csv (the truth-free metamorphic relations per SLAM), victoria_park_consistency.csv
(landmark Mahalanobis distances from the smoother under each filter's own covariance) and
victoria_park_maps.png (the maps over each other).
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from scipy.stats import chi2  # noqa: E402

from faultlab.metamorphic import BearingTurn, IdPermutation, RigidMotion, check_relation  # noqa: E402
from faultlab.metrics.alignment import kabsch_rms  # noqa: E402
from faultlab.scenario.isam import victoria_park  # noqa: E402
from faultlab.slam import DeadReckoning, EkfSlam, run_slam  # noqa: E402
from faultlab.slam.ekf import EkfSlamConfig  # noqa: E402
from faultlab.slam.process import ProcessSlam, ProcessSlamConfig  # noqa: E402
from faultlab_g2o_smoother import G2oSmoother  # noqa: E402
from faultlab_rtb_ekf_slam import RtbEkfSlam  # noqa: E402


def factories(noise: dict, mrpt: str | None) -> dict:
    env = {"MRPT_KFSLAM_STD_V": noise["std_v"], "MRPT_KFSLAM_STD_OMEGA_DEG": noise["std_omega_deg"],
           "MRPT_KFSLAM_STD_RANGE": noise["std_range"], "MRPT_KFSLAM_STD_BEARING_DEG": noise["std_bearing_deg"]}
    out = {
        "dead_reckoning": DeadReckoning,
        "faultlab ekf": lambda: EkfSlam(EkfSlamConfig.from_options(noise)),
        "rtb ekf (roboticstoolbox-python)": lambda: RtbEkfSlam(**noise),
        "g2o smoother (g2opy)": lambda: G2oSmoother(**noise),
    }
    if mrpt:
        out["mrpt CRangeBearingKFSLAM2D"] = lambda: ProcessSlam(ProcessSlamConfig.from_options(
            {"command": [mrpt], "env": {k: repr(float(v)) for k, v in env.items()}, "reply_timeout_s": 120.0,
             "execution_timeout_s": 3600.0}))
    return out


def relations(vp, noise, args, out) -> None:
    """The truth-free metamorphic relations on Victoria Park for the SLAMs named (by prefix)."""
    rel_rows = []
    for name, make in factories(noise, args.mrpt).items():
        if not any(name.startswith(p) for p in args.relations):
            continue
        for relation in (RigidMotion(angle=1.0, translation=(50.0, -20.0)), IdPermutation(keep_order=True),
                         BearingTurn()):
            t0 = time.perf_counter()
            res = check_relation(make, relation, vp, rngs=[np.random.default_rng(i) for i in range(2)])
            rel_rows.append({"slam": name, "relation": relation.name, "verdict": str(res.verdict),
                             "median_discrepancy_m": float(np.median(res.discrepancies)),
                             "tolerance_m": res.tolerance, "seconds": round(time.perf_counter() - t0, 1)})
            print(name, relation.name, res.verdict, flush=True)
            pd.DataFrame(rel_rows).to_csv(out / "victoria_park_relations.csv", index=False)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--mrpt", help="the built MRPT front end")
    ap.add_argument("--out", default="reports/wild")
    ap.add_argument("--relations", nargs="*", default=None, metavar="SLAM",
                    help="only check the metamorphic relations (4 runs each) of these SLAMs (name prefixes)")
    args = ap.parse_args()
    out = Path(args.out)
    vp = victoria_park()
    noise = vp.meta["noise"]
    if args.relations is not None:
        relations(vp, noise, args, out)
        return
    rows, estimates, covs = [], {}, {}
    for name, make in factories(noise, args.mrpt).items():
        slam = make()
        t0 = time.perf_counter()
        est = run_slam(slam, vp, rng=np.random.default_rng(0))
        seconds = time.perf_counter() - t0
        if hasattr(slam, "close"):
            slam.close()
        estimates[name] = est
        cov = getattr(slam, "covariance", None)
        if cov is not None:
            covs[name] = cov
        rows.append({"slam": name, "seconds": round(seconds, 1), "landmarks_mapped": int(est.landmark_ids.size)})
        print(name, f"{seconds:.1f} s", flush=True)
    # the smoother again, started from faultlab's EKF estimate: a lower chi2 there means the run from dead
    # reckoning stopped in a local minimum and is no reference
    warm = G2oSmoother(**noise, initial=estimates["faultlab ekf"])
    t0 = time.perf_counter()
    estimates["g2o smoother from the EKF"] = run_slam(warm, vp, rng=np.random.default_rng(0))
    rows.append({"slam": "g2o smoother from the EKF", "seconds": round(time.perf_counter() - t0, 1),
                 "landmarks_mapped": int(estimates["g2o smoother from the EKF"].landmark_ids.size)})
    cold = G2oSmoother(**noise)
    run_slam(cold, vp, rng=np.random.default_rng(0))
    pd.DataFrame([{"start": "dead reckoning", "chi2": cold.chi2}, {"start": "faultlab ekf", "chi2": warm.chi2}]
                 ).to_csv(out / "victoria_park_smoother_chi2.csv", index=False)
    ref = estimates["g2o smoother from the EKF" if warm.chi2 < cold.chi2 else "g2o smoother (g2opy)"]
    order = np.argsort(ref.landmark_ids)
    for row in rows:
        est = estimates[row["slam"]]
        o = np.argsort(est.landmark_ids)
        same = np.array_equal(est.landmark_ids[o], ref.landmark_ids[order])
        raw = (math.sqrt(np.mean(np.sum((est.landmarks[o] - ref.landmarks[order]) ** 2, axis=1))) * 1000
               if same else float("nan"))
        row["rms_vs_g2o_same_frame_mm"] = round(raw, 1)
        row["rms_vs_g2o_kabsch_mm"] = round(kabsch_rms(ref.landmark_ids, ref.landmarks, est.landmark_ids,
                                                       est.landmarks).rms * 1000, 1)
        row["final_pose_vs_g2o_mm"] = round(float(np.hypot(*(est.pose[:2] - ref.pose[:2]))) * 1000, 1)
    pd.DataFrame(rows).to_csv(out / "victoria_park.csv", index=False)

    cons = []
    for name, P in covs.items():
        est = estimates[name]
        pos = {int(i): k for k, i in enumerate(ref.landmark_ids)}
        d2 = []
        for k, i in enumerate(est.landmark_ids):
            block = P[3 + 2 * k:5 + 2 * k, 3 + 2 * k:5 + 2 * k]
            d = est.landmarks[k] - ref.landmarks[pos[int(i)]]
            d2.append(float(d @ np.linalg.solve(block, d)))
        d2 = np.array(d2)
        cons.append({"slam": name, "landmarks": d2.size, "median_d2": round(float(np.median(d2)), 2),
                     "share_beyond_chi2_2_0.95": round(float(np.mean(d2 > chi2.ppf(0.95, 2))), 3),
                     "expected_share_if_consistent": 0.05})
    pd.DataFrame(cons).to_csv(out / "victoria_park_consistency.csv", index=False)

    np.savez(out / "victoria_park_estimates.npz", **{
        f"{k}|{part}": getattr(e, part) for k, e in estimates.items() for part in ("landmark_ids", "landmarks")
        if getattr(e, part) is not None}, **{f"{k}|trajectory": e.trajectory for k, e in estimates.items()
                                              if e.trajectory is not None})
    fig, ax = plt.subplots(figsize=(8, 8))
    marks = ["1", "o", "s", "x", "+", "^", "D"]
    for (name, est), mk in zip(estimates.items(), marks):
        ax.scatter(est.landmarks[:, 0], est.landmarks[:, 1], s=16, marker=mk, label=f"{name} map", linewidths=0.8)
        if est.trajectory is not None and name in ("g2o smoother (g2opy)", "g2o smoother from the EKF",
                                                   "faultlab ekf"):
            ax.plot(est.trajectory[:, 0], est.trajectory[:, 1], lw=0.4, label=f"{name} path")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title("Victoria Park (gtsam wheel): landmark maps, no ground truth")
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(out / "victoria_park_maps.png", dpi=130)


if __name__ == "__main__":
    main()
