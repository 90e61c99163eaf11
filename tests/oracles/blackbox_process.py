"""A SLAM program speaking faultlab's process protocol: the test suite's plain EKF-SLAM behind stdin/stdout.

``--bug NAME`` plants one of the EKF's bugs (``turn_first``: the motion turns before it drives).
"""

import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from blackbox import PlainEkf  # noqa: E402  (the program runs as a script)

from faultlab.slam import Observations  # noqa: E402


def main() -> int:
    bug = sys.argv[sys.argv.index("--bug") + 1] if "--bug" in sys.argv else None
    slam = PlainEkf(bug)
    for line in sys.stdin:
        msg = json.loads(line)
        kind = msg["type"]
        if kind == "reset":
            if msg["protocol"] != 1:
                print(json.dumps({"type": "error", "message": "protocol 1 only"}), flush=True)
                continue
            slam.reset(np.array(msg["pose"], dtype=float), rng=np.random.default_rng(msg["seed"]))
            print(json.dumps({"type": "ready", "protocol": 1}), flush=True)
        elif kind == "step":
            slam.step(msg["control"], Observations(msg["ranges"], msg["bearings"], np.array(msg["ids"], dtype=np.int64)))
            print(json.dumps({"type": "ack", "t": msg["t"]}), flush=True)
        elif kind == "estimate":
            est = slam.estimate()
            lms = [[int(i), float(x), float(y)] for i, (x, y) in zip(est.landmark_ids, est.landmarks)]
            if not np.all(np.isfinite(est.pose)) or not all(np.isfinite(v) for _, *xy in lms for v in xy):
                print(json.dumps({"type": "error", "message": "non-finite estimate"}), flush=True)
                continue
            print(json.dumps({"type": "estimate", "pose": est.pose.tolist(), "landmarks": lms}), flush=True)
        elif kind == "bye":
            return 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
