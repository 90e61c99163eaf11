#!/usr/bin/env bash
# faultlab check on every SLAM of reports/wild: the pairwise suite (20 cases, seed 2026, 100 active steps)
# over Table I with small maps (space.toml), truth-free oracles, faultlab's EKF as the differential reference.
# Resumable: each check keeps its judged cases in reports/wild/check/<slam>/cases and skips them on a rerun.
#   nice bash reports/wild/check/run.sh            (from the repository root; MRPT built as in examples/mrpt-kfslam)
set -euo pipefail
here=reports/wild/check
common=(--space "$here/space.toml" --steps 100 --seed 2026 --jobs 1
        --relations rigid_motion id_relabel bearing_turn)
run() {  # name, then the SLAM arguments
    local name=$1; shift
    local t0=$SECONDS
    /usr/bin/time -a -f "user %U s, system %S s, wall %e s" -o "$here/$name/time.txt" \
        faultlab check "$@" "${common[@]}" --out "$here/$name" >"$here/$name.log" 2>&1 || true
    echo "$name: $((SECONDS - t0)) s"
}
mkdir -p "$here"/{ekf,g2o,mrpt,rtb}
run ekf ekf
run g2o faultlab_g2o_smoother:G2oSmoother
run mrpt --command build/mrpt-kfslam/mrpt_kfslam
run rtb faultlab_rtb_ekf_slam:RtbEkfSlam
